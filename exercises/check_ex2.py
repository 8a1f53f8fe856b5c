"""Checker for exercise 2: runs your integrators and tells you what they do.

    python -m exercises.check_ex2                          # checks exercises/ex2_integrators.py
    python -m exercises.check_ex2 path/to/your_file.py     # or any file defining the two steps

Your steps are run on all three systems through the engine's own simulate(), compared with
the engine's integrators, and measured for the properties that define them: a bounded energy
band for semi-implicit Euler, fourth-order convergence for RK4. When they differ, the checker
compares them with the usual mistakes and says which one it sees. Exit code 0 means solved.
"""

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np

import engine
from exercises.exact import spring_position
from exercises.predict import explain

DEFAULT_FILE = Path(__file__).resolve().parent / "ex2_integrators.py"
SYSTEMS = ("orbit", "spring", "freefall")
DT, STEPS = 0.05, 400  # coarse enough that every mistake shows within a few steps


# --- the usual mistakes, as integrators, so they can be recognised by what they do ---

def position_first_step(q, v, m, force, dt):
    """The other symplectic Euler: position with the old velocity, then velocity from the new position."""
    q_next = q + v * dt
    return q_next, v + force(q_next, v) / m * dt


def rk4_variant(stage_fraction, weights):
    """RK4 with the midpoint stages `stage_fraction * dt` out and the given slope weights."""
    def step(q, v, m, force, dt):
        h = stage_fraction * dt
        k1q, k1v = v, force(q, v) / m
        k2q, k2v = v + k1v * h, force(q + k1q * h, v + k1v * h) / m
        k3q, k3v = v + k2v * h, force(q + k2q * h, v + k2v * h) / m
        k4q, k4v = v + k3v * dt, force(q + k3q * dt, v + k3v * dt) / m
        w1, w2, w3, w4 = (w / sum(weights) for w in weights)
        return (q + (k1q * w1 + k2q * w2 + k3q * w3 + k4q * w4) * dt,
                v + (k1v * w1 + k2v * w2 + k3v * w3 + k4v * w4) * dt)
    return step


# --- measurements ---

def trajectory(step_fn, system_name, dt=DT, steps=STEPS):
    system = engine.build_system(system_name, np.random.default_rng(0))
    positions, _, energies = engine.simulate(step_fn, system, dt, steps)
    return positions, energies


def first_difference(step_fn, reference_fn):
    """(system, step) where step_fn first leaves reference_fn's trajectory, or None if it never does.

    Round-off is allowed (1e-9 of the motion's size): arithmetic in another order is still right."""
    for system_name in SYSTEMS:
        mine, _ = trajectory(step_fn, system_name)
        theirs, _ = trajectory(reference_fn, system_name)
        apart = np.abs(mine - theirs).max(axis=1) > 1e-9 * max(1.0, np.abs(theirs).max())
        apart |= ~np.isfinite(mine).all(axis=1)
        if apart.any():
            return system_name, int(np.argmax(apart))
    return None


def orbit_energy_band(step_fn, steps):
    """Worst relative energy excursion on the chapter's orbit (dt 0.01) over `steps` steps."""
    _, energies = trajectory(step_fn, "orbit", dt=0.01, steps=steps)
    return float(np.max(np.abs(energies - energies[0])) / abs(energies[0]))


def spring_order(step_fn, dt=0.02, seconds=2.0):
    """Convergence order from one halving of dt: log2 of how much the spring's position error shrinks."""
    errors = []
    for h in (dt, dt / 2):
        system = engine.build_system("spring", np.random.default_rng(0))
        steps = round(seconds / h)
        positions, _, _ = engine.simulate(step_fn, system, h, steps)
        errors.append(np.abs(positions[-1] - spring_position(system, steps * h)).max())
    return math.log2(errors[0] / errors[1])


# --- verdicts ---

def check_semi_implicit(step_fn) -> tuple[bool, str]:
    name = "semi_implicit_step"
    differs = first_difference(step_fn, engine.semi_implicit_step)
    if differs is None:
        short, long = orbit_energy_band(step_fn, 2000), orbit_energy_band(step_fn, 8000)
        if not math.isclose(short, long, rel_tol=0.05):  # can only happen if the engine itself changed
            return False, f"{name}: matches engine.semi_implicit_step, but its energy is not bounded. Tell us!"
        return True, (f"{name}: solved. Same trajectory as the engine's on {', '.join(SYSTEMS)}; on the orbit its"
                      f" energy stays in a band: worst excursion {orbit_energy_band(step_fn, 2000):.3e} after"
                      f" 2,000 steps and {orbit_energy_band(step_fn, 8000):.3e} after 8,000.")
    if first_difference(step_fn, engine.euler_step) is None:
        return False, (f"{name}: your step still moves the position with the old velocity: that is explicit Euler."
                       f" Watch the energy: on the orbit it climbs {orbit_energy_band(step_fn, 2000):.1%} in the"
                       " chapter's 2,000 steps and keeps climbing. Update the velocity first, then move the"
                       " position with the new one.")
    short, long = orbit_energy_band(step_fn, 2000), orbit_energy_band(step_fn, 8000)
    if first_difference(step_fn, position_first_step) is None:
        return False, (f"{name}: you move the position first, then take the velocity from the force at the new"
                       " position. That is the other symplectic Euler: valid, and bounded (orbit energy band"
                       f" {short:.3e} after 2,000 steps, {long:.3e} after 8,000), but not MuJoCo's."
                       " mjINT_EULER updates the velocity first and moves the position with the new velocity.")
    system_name, step = differs
    reference = orbit_energy_band(engine.semi_implicit_step, 2000)
    return False, (f"{name}: leaves semi-implicit Euler's trajectory on the {system_name} at step {step}. Its orbit"
                   f" energy error is {short:.3e} after 2,000 steps and {long:.3e} after 8,000; semi-implicit"
                   f" Euler's stays at {reference:.3e}. Compare it line by line with euler_step: only the order"
                   " of the two updates should change.")


def check_rk4(step_fn) -> tuple[bool, str]:
    name = "rk4_step"
    differs = first_difference(step_fn, engine.rk4_step)
    order = spring_order(step_fn)
    if differs is None:
        if abs(order - 4) > 0.2:  # can only happen if the engine itself changed
            return False, f"{name}: matches engine.rk4_step, but converges at order {order:.2f}, not 4. Tell us!"
        return True, (f"{name}: solved. Matches the engine's RK4 to round-off on {', '.join(SYSTEMS)}, and halving"
                      f" dt divides its spring error by {2**order:.1f}: order {order:.2f}.")
    if first_difference(step_fn, rk4_variant(0.5, (1, 1, 1, 1))) is None:
        return False, (f"{name}: your four slopes are weighted 1-1-1-1. The two midpoint slopes must count double:"
                       f" (k1 + 2 k2 + 2 k3 + k4) / 6. With equal weights halving dt divides the error by only"
                       f" {2**order:.1f} (order {order:.2f}, not 4).")
    if first_difference(step_fn, rk4_variant(1.0, (1, 2, 2, 1))) is None:
        return False, (f"{name}: your midpoint stages are a full dt out. k2 is the slope half a step along k1,"
                       " at q + (dt/2) k1q, v + (dt/2) k1v; k3 half a step along k2; only k4 goes the whole dt."
                       f" As written it converges at order {order:.2f}, not 4.")
    system_name, step = differs
    return False, (f"{name}: leaves RK4's trajectory on the {system_name} at step {step}; halving dt divides its"
                   f" spring error by {2**order:.1f} (order {order:.2f}), where RK4's shrinks by 16. Check each"
                   " stage: where is it sampled, and with which slope?")


def check(path: Path) -> tuple[bool, list[str]]:
    """Load the student's file and return (all solved, messages)."""
    spec = importlib.util.spec_from_file_location("student_integrators", path)
    student = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(student)
    solved, messages = True, []
    for name, checker in (("semi_implicit_step", check_semi_implicit), ("rk4_step", check_rk4)):
        step_fn = getattr(student, name, None)
        if step_fn is None:
            ok, message = False, f"{name}: not found in {path.name}. Keep the function names as they are."
        else:
            try:
                ok, message = checker(step_fn)
            except NotImplementedError:
                ok, message = False, f"{name}: not solved yet. It still raises NotImplementedError: fill in its TODO."
            except Exception as error:  # the student's code: report it in one line, not a traceback
                ok, message = False, f"{name}: raised {type(error).__name__}: {error}"
        solved &= ok
        messages.append(message)
    return solved, messages


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    path = Path(argv[0]) if argv else DEFAULT_FILE
    if not path.is_file():
        print(f"check_ex2: no file {path}", file=sys.stderr)
        return 2
    solved, messages = check(path)
    explain(*messages)
    print("\nAll solved." if solved else "\nNot solved yet: read the messages above, edit, and run the checker again.")
    return 0 if solved else 1


if __name__ == "__main__":
    sys.exit(main())
