"""Exercise 6, predict then run: stiff damping. Which integrators stay bounded?

    python -m exercises.ex6_stiff_damping                          # the question, and nothing else
    python -m exercises.ex6_stiff_damping --predict <names>        # commit (names, or none), then measure

The chapter's spring (k = 4 N/m, m = 1 kg, stretched about 1 m) gets a damper: a force -b v against
the velocity. Four integrators run it: the chapter's three, and `implicit`, the engine's fourth step,
which takes the damping force at the new velocity instead of the old one (implicit_step, in engine_damping.py).
The run measures which stay bounded; --more also draws where each one does across dampings and
stiffnesses, and points at the line of MuJoCo's source that decides it for mj_step.
"""

import sys

from curriculum.common.exercise import start

start(__file__)  # first: Ctrl-C is one line from here on, and the exercise runs as a file too

import argparse
import math

import numpy as np

import engine
import engine_damping
from curriculum.common.cli import OneLineParser
from curriculum.common.outputs import one_line_failures
from curriculum.common.predict import SomeOf, ask, explain, verdict
from engine_referee import overflow_step
from exercises.support import stability_map

DAMPING, DT, STEPS = 250.0, 0.01, 2000  # b in N s/m; 2000 steps is the chapter's run
NAMES = ["euler", "semi_implicit", "rk4", "implicit"]
MUJOCO_LINE = "d->qH[m->M_rowadr[i] + m->M_rownnz[i] - 1] += m->opt.timestep * damp_deriv;"
MAP_STIFFNESS = [4.0, 3.0, 2.5, 2.0, 1.5, 1.0, 0.5, 0.02]  # w = dt sqrt(k/m), top row stiffest
MAP_DAMPING = [0.0, 0.001, 0.01, 0.1, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 5.0, 10.0, 100.0]  # c = dt b/m


def measure(damping: float = DAMPING) -> dict:
    """{integrator: (bounded, the step its energy overflowed at or None, worst |q - exact|)} on the chapter's damped
    spring: the step engine.py's table and metrics.json name (engine_referee.overflow_step)."""
    system = engine.build_system("damped_spring", np.random.default_rng(0), damping)
    results = {}
    steps = engine.integrators_for(system)
    for name in NAMES:  # the four the question names, whatever else the engine may have learnt since
        positions, velocities, energies = engine.simulate(steps[name], system, DT, STEPS)
        audit = engine_damping.against_exact(system, positions, velocities, energies, engine.kept_steps(STEPS), DT)
        results[name] = (audit["bounded"], overflow_step(energies), audit["err_max"])
    return results


def bounded_map() -> dict:
    """{integrator: bool grid (stiffness rows x damping columns)}: one batched run per integrator."""
    w, c = np.meshgrid(MAP_STIFFNESS, MAP_DAMPING, indexing="ij")
    return {name: stability_map.stays_bounded(name, w.ravel(), c.ravel(), steps=2000).reshape(w.shape)
            for name in NAMES}


def print_map(grid: dict, here: tuple[int, int]) -> None:
    """Four small maps side by side: '#' bounded, '.' not; the question's spring, at (row, column) here, '@' or 'x'."""
    width = len(MAP_DAMPING)
    print("".join(f"{name:<{width + 3}}" for name in NAMES))
    for row, w in enumerate(MAP_STIFFNESS):
        cells = []
        for name in NAMES:
            marks = ["#" if ok else "." for ok in grid[name][row]]
            if row == here[0]:
                marks[here[1]] = "@" if grid[name][here] else "x"
            cells.append("".join(marks) + "   ")
        print("".join(cells) + f"w = {w:g}")
    print(f"columns: c = dt b/m = {', '.join(f'{c:g}' for c in MAP_DAMPING)}")


@one_line_failures("exercises.ex6_stiff_damping")  # Ctrl-C or a closed stdout (`| head`): one line, no traceback
def main(argv=None) -> int:
    parser = OneLineParser(prog="exercises.ex6_stiff_damping", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    ask(parser,
        f"The chapter's spring (k = 4 N/m, m = 1 kg) with a damper of b = {DAMPING:g} N s/m, run for"
        f" {STEPS} steps of {DT * 1000:g} ms: which of {', '.join(NAMES)} stay bounded?",
        SomeOf(NAMES, "the ones that stay bounded", "an integrator"), argv)

    results = measure()
    k, m = 4.0, 1.0
    c, w = DT * DAMPING / m, DT * math.sqrt(k / m)
    print(f"damped spring, b = {DAMPING:g} N s/m, dt = {DT} s: per step c = dt b/m = {c:g}, w = dt sqrt(k/m) = {w:g}")
    print(f"{'integrator':<15}{'bounded':>9}   what happened")
    for name, (bounded, blown, err) in results.items():
        story = f"blew up: energy overflowed at step {blown:,}" if blown is not None else (
            f"worst distance from the exact solution {err:.2e} m" if bounded else "grew, still finite")
        print(f"{name:<15}{'yes' if bounded else 'NO':>9}   {story}")
    answer = frozenset(name for name, (bounded, _, _) in results.items() if bounded)
    shown = ", ".join(name for name in NAMES if name in answer) or "none"
    print()
    verdict(answer, f"the ones that stay bounded are {shown}")

    bounds = {name: stability_map.analytic_interval(name, w) for name in NAMES}
    explain("", f"Here c = dt b/m = {c:g} per step. Both Eulers take the damping at the old velocity, so each step"
            " multiplies v by 1 - c: past c = 2 it flips sign and grows. RK4 takes it at old velocities too, four"
            f" times a step, which moves its limit to c = {bounds['rk4'][1]:.3f} on this spring: it survives"
            f" {c:g}, not 3. The implicit step takes the damping at the new velocity and divides v by 1 + c:"
            " bounded at any damping, as MuJoCo's default Euler is on a damped joint. Order moves the limit;"
            " the new velocity removes it.",
            more=lambda: the_whole_story(c, w, bounds))
    return 0


def the_whole_story(c: float, w: float, bounds: dict) -> list:
    """The full explanation (--more): the maps, measured here, then what decides each integrator."""
    print_map(bounded_map(), (MAP_STIFFNESS.index(w), MAP_DAMPING.index(c)))
    return [
        "",
        f"The maps: stiffness per step w = dt sqrt(k/m) up, damping per step c = dt b/m across; '#' stayed"
        f" bounded for 2000 steps, '.' did not; your spring is the bottom row at c = {c:g} ('@' bounded,"
        f" 'x' not). From the eigenvalues of each one-step matrix, at w = {w:g} the bounded dampings are"
        " (ends included: there an eigenvalue has modulus 1 and the motion neither grows nor decays): "
        + ", ".join(f"{name} {stability_map.shown(bounds[name], 5)}" for name in NAMES) + ".",
        f"- Both Eulers take the damping at the OLD velocity: v_new = v - c v = (1 - c) v = {1 - c:g} v. Past"
        " c = 2 that factor is below -1: the velocity flips sign and grows every step. Explicit Euler also has"
        " a floor, c >= w^2: with less damping than that it adds energy, as it does to the orbit.",
        f"- rk4 samples the damping four times per step; its factor on a pure decay is 1 - c + c^2/2 - c^3/6 + c^4/24,"
        f" {1 - c + c * c / 2 - c * c * c / 6 + c * c * c * c / 24:.3f} at c = {c:g}: between -1 and 1 up to c = 2.785,"
        " where it reaches 1, and no further. At b = 300, c = 3: `python engine.py --system damped_spring"
        " --damping 300` shows RK4 blow up there too.",
        f"- implicit takes it at the NEW velocity: m (v_new - v) = -dt b v_new, so v_new = v / (1 + c) ="
        f" {1 / (1 + c):.3f} v: it shrinks for every c. Its spring is still explicit, though (look at the top"
        " rows): it needs w <= sqrt(4 + 2c) (at c = 0, w < 2), so a stiff enough spring beats it too.",
        "- Where MuJoCo decides it: src/engine/engine_forward.c at 3.10.0, in mj_EulerSkip, under the comment"
        " 'qH += h*diag(B)':",
        "",
        f"    {MUJOCO_LINE}",
        "",
        "- It adds h b to the mass matrix before solving for the acceleration: MuJoCo's default 'Euler' is the"
        " implicit step on any joint with damping (tests/test_damping.py shows it bit for bit), and"
        " implicitfast does the same through qDeriv. MuJoCo's RK4 has no such line: it survives this damping"
        " only because 2.5 is under 2.785; at b = 300 it blows up, warns and resets the simulation.",
    ]


if __name__ == "__main__":
    sys.exit(main())
