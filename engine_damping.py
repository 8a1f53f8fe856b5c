"""Beyond the chapter, for `python engine.py --system damped_spring`: a spring with a damper, a step implicit in the
damping as MuJoCo's Euler is, and the audit that referees them against the closed-form solution.

engine.py registers `damped_spring` as a system and `implicit_step` as an integrator, each in one line, so
they are offered like the chapter's own; it imports this module, and this module imports nothing of
engine's. docs/damping.md has the figures; exercise 6 asks first.
"""

import math

import numpy as np

from curriculum.common.report import cell, sim_time
from engine_referee import damped_oscillator, distance, dot3

DAMPING = 0.5  # the damped spring's b, N s/m, unless --damping says otherwise (exercise 6 asks about 250)
MAX_DAMPING = 1e6  # N s/m: dt b/m = 10,000, the map's last column; from ~7e8 the recording's exact velocity overflows
BOUNDED_SLACK = 1e-3  # a steady oscillation's sampled peaks differ by less than this between halves


def damped_spring(rng, damping=DAMPING):
    # The spring again, with a damper pulling against the velocity: force -k q - b v.
    # Energy now drains away, so the referee is the closed-form solution instead, and the
    # energy lost must match the damper's work, the time integral of b |v|^2.
    k, m, b = 4.0, 1.0, float(damping)
    q0 = np.array([1.0 + rng.uniform(-0.1, 0.1), 0.0, 0.0])
    v0 = np.zeros(3)

    def force(q, v):
        return -k * q - b * v  # spring plus damper, added in MuJoCo's order

    def energy(q, v):
        return 0.5 * m * dot3(v, v) + 0.5 * k * dot3(q, q)  # kinetic + spring: what the damper drains

    def dissipation(q, v):
        return b * dot3(v, v)  # the power the damper takes out, one number per body

    def exact(q0, v0, t):  # the truth from any start, so a batch's rows each get their own
        return damped_oscillator(q0, v0, k, m, b, t)

    # What a velocity-dependent force declares for implicit_step: d force / d v, here -b
    # times the identity (MuJoCo's qDeriv). Conservative systems have none.
    return {"q0": q0, "v0": v0, "m": m, "force": force, "energy": energy, "exact": exact,
            "dissipation": dissipation, "dforce_dv": -b, "k": k, "b": b}


def implicit_step(q, v, m, force, dt, dforce_dv):
    """Semi-implicit Euler with the velocity-dependent force taken at the NEW velocity.

    Solves m (v_new - v) / dt = force(q, v) + dforce_dv (v_new - v) for v_new, then q += dt * v_new.
    With a linear damper that is the force at (q_old, v_new): implicit in the damping, explicit
    in the spring. It is MuJoCo's Euler on a joint with damping, and its implicitfast (M - h qDeriv).
    Symplectic only where dforce_dv = 0; order 1; 1 force evaluation per step (and dforce_dv).
    With dforce_dv = 0 it is semi_implicit_step, bit for bit where 1/m is exact (m = 1, 2, 0.5, ...);
    for other masses the last bit can differ, as it multiplies by 1/m where that one divides by m.
    What it buys under stiff damping: exercise 6 (predict first); docs/damping.md has the stability map.
    """
    # MuJoCo factorizes m - dt * qDeriv and multiplies by the inverse of its diagonal, so we do
    # too and match it to the bit (its mjINT_IMPLICIT divides instead: last-bit differences).
    inverse_mass = 1.0 / (m - dt * dforce_dv)
    a = force(q, v) * inverse_mass
    v_next = v + dt * a
    q_next = q + dt * v_next  # the new velocity moves the position, as in semi_implicit_step
    return q_next, v_next


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
    miss = distance(positions, system["exact"](system["q0"], system["v0"], kept * dt))
    swing = np.sqrt(dot3(positions, positions))
    half = len(swing) // 2
    bounded = swing[half:].max() <= swing[:half + 1].max() * (1.0 + BOUNDED_SLACK)
    spacing = kept[1:] - kept[:-1]
    uniform = len(kept) - 1 if (spacing == spacing[0]).all() else len(kept) - 2  # thinned: drop the short tail
    work = simpson(system["dissipation"](positions[: uniform + 1], velocities[: uniform + 1]), spacing[0] * dt)
    lost = float(energies[0] - energies[kept[uniform]])
    return {"err_max": float(miss.max()), "err_final": float(miss[-1]), "bounded": bool(bounded),
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
            print(f"{name:<14}  diverged: energy overflowed at step {drifts[name]['energy_overflow_step']:,}")
        else:
            print(f"{name:<14}{d['err_max']:>14.4e}{d['err_final']:>12.4e}{'yes' if d['bounded'] else 'NO':>9}"
                  f"{cell(d['energy_lost'], 10)}{cell(d['damper_work'], 13)}{d['work_mismatch']:>+13.4e}")
    print("truth: the closed-form solution; bounded: the run's second half swings no wider than its first;\n"
          "E lost: E0 - E_final; damper work: the integral of b |v|^2 (composite Simpson); mismatch/E0: their gap / E0")
