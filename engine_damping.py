"""The damped rung's audit, for `python engine.py --system damped_spring`: each integrator against the
closed-form solution, whether it stays bounded, and the energy the damper took out.

A leaf: it imports engine, and engine.main() loads it only for a damped system. The physics (the
damped spring, its exact motion, implicit_step) is in engine.py; docs/damping.md has the figures.
"""

import math

import numpy as np

from curriculum.common.report import cell, sim_time
from engine import dot3

BOUNDED_SLACK = 1e-3  # a steady oscillation's sampled peaks differ by less than this between halves


def against_exact(system: dict, positions, velocities, energies, kept, dt: float) -> dict:
    """A damped run (one body) against its closed-form solution: what the report prints for it.

    err_max, err_final: the largest and the last distance |q - q_exact| over the kept states.
    bounded: finite, and the second half of the run swings no wider than the first (largest |q|,
    give or take BOUNDED_SLACK for where the samples fall on a steady oscillation).
    energy_lost against damper_work: E0 - E(t) against the integral of b |v|^2 up to the same t,
    by composite Simpson over the kept states (order 4, so it does not hide RK4's own order 4);
    work_mismatch = (energy_lost - damper_work) / E0 shrinks like dt^order when dt halves.
    """
    if not np.isfinite(energies).all():  # the energy squares q and v: finite energy, finite everything
        return {"err_max": None, "err_final": None, "bounded": False, "energy_lost": None,
                "damper_work": None, "work_mismatch": None}
    gap = positions - system["exact"](system["q0"], system["v0"], kept * dt)
    distance = np.sqrt(dot3(gap, gap))
    swing = np.sqrt(dot3(positions, positions))
    half = len(swing) // 2
    bounded = swing[half:].max() <= swing[:half + 1].max() * (1.0 + BOUNDED_SLACK)
    spacing = kept[1:] - kept[:-1]
    uniform = len(kept) - 1 if (spacing == spacing[0]).all() else len(kept) - 2  # thinned: drop the short tail
    work = simpson(system["dissipation"](positions[: uniform + 1], velocities[: uniform + 1]), spacing[0] * dt)
    lost = float(energies[0] - energies[kept[uniform]])
    return {"err_max": float(distance.max()), "err_final": float(distance[-1]), "bounded": bool(bounded),
            "energy_lost": lost, "damper_work": work, "work_mismatch": (lost - work) / float(energies[0])}


def simpson(values, h: float) -> float:
    """Composite Simpson's rule over equally spaced samples; an odd count of intervals ends with the 3/8 rule."""
    f = [float(value) for value in values]  # math.fsum: exactly rounded, the same on every CPU
    n = len(f) - 1
    if n < 3:  # too few for Simpson: the trapezoid
        return h * (0.5 * f[0] + math.fsum(f[1:n]) + 0.5 * f[n]) if n else 0.0
    head = n if n % 2 == 0 else n - 3  # even part by Simpson 1-4-2-4-...-1, the rest by 3/8
    total = h / 3.0 * (f[0] + 4.0 * math.fsum(f[1:head:2]) + 2.0 * math.fsum(f[2:head:2]) + f[head])
    if head < n:
        total += 3.0 * h / 8.0 * (f[n - 3] + 3.0 * f[n - 2] + 3.0 * f[n - 1] + f[n])
    return total


def print_damped_report(system: dict, dt: float, steps: int, drifts: dict, solution: dict) -> None:
    """The damped spring's table: distance from the closed form, boundedness, the energy audit."""
    k, m, b = system["k"], system["m"], system["b"]
    ratio = b / (2.0 * math.sqrt(k * m))
    regime = "under-damped" if ratio < 1.0 else "critically damped" if ratio == 1.0 else "over-damped"
    print(f"integrated {system['name']} (k {k:g}, m {m:g}, b {b:g}: {regime}) for {steps} steps of {dt} s"
          f" -> {sim_time(steps * dt)} s of sim time")
    print(f"per step: damping dt b/m = {dt * b / m:.4g}, stiffness dt sqrt(k/m) = {dt * math.sqrt(k / m):.4g}"
          " (docs/damping.md maps where each integrator stays bounded)")
    print(f"{'integrator':<14}{'max |q-exact|':>14}{'final':>12}{'bounded':>9}{'E lost':>10}"
          f"{'damper work':>13}{'mismatch/E0':>13}")
    for name, d in solution.items():
        if drifts[name]["diverged"]:
            print(f"{name:<14}  diverged: energy non-finite from step {drifts[name]['diverged_at_step']:,}")
        else:
            print(f"{name:<14}{d['err_max']:>14.4e}{d['err_final']:>12.4e}{'yes' if d['bounded'] else 'NO':>9}"
                  f"{cell(d['energy_lost'], 10)}{cell(d['damper_work'], 13)}{d['work_mismatch']:>+13.4e}")
    print("truth: the closed-form solution; damper work: the integral of b |v|^2, by composite Simpson")
