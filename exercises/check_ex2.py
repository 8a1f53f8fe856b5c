"""Checker for exercise 2: runs your two steps and tells you what they do.

    python -m exercises.check_ex2                          # checks exercises/ex2_integrators.py
    python -m exercises.check_ex2 path/to/your_file.py     # or any .py file defining the two steps

Your file runs in a separate Python process with a time limit. A step passes when its single steps from
a few dozen states equal the engine's and its whole runs (each step fed its own output) stay with the
engine's. Otherwise it names the usual mistake it sees, or says what it measured. Exit code 0: both solved.
"""

import sys

from curriculum.common.exercise import start

start(__file__)  # first: Ctrl-C is one line from here on, and the checker runs as a file too

import functools
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import engine
from curriculum.common import student_code
from exercises.support import ex2_cases
from exercises.support.ex2_mistakes import FLOOR, MISTAKES

PROG, DEFAULT_FILE = "python -m exercises.check_ex2", Path(__file__).resolve().parent / "ex2_integrators.py"
METHODS = {"semi_implicit_step": ("semi-implicit Euler", engine.semi_implicit_step, 1, 1),
           "rk4_step": ("RK4", engine.rk4_step, 4, 4)}  # (what it is, the engine's step, order, force calls)
ENGINE = SimpleNamespace(**{name: method[1] for name, method in METHODS.items()})
TIME_LIMIT = 20.0  # seconds for a child's start, again for importing the file, again for its tasks (about one in all)

# Single steps from these states, on every system, at two timesteps: the arithmetic, system by system.
STATES = {"spring": [([0.8, -0.3, 0.5], [0.2, 0.6, -0.4]), ([-1.1, 0.4, 0.2], [-0.5, 0.1, 0.9])],
          "orbit": [([1.0, 0.1, 0.05], [-0.1, 1.05, 0.02]), ([0.6, -0.8, 0.1], [0.7, 0.5, -0.1])]}
SYSTEMS = (*ex2_cases.CHAPTER, *ex2_cases.OWN)
PROBES = [{"system": system, "q": q, "v": v, "dt": dt} for system in SYSTEMS
          for q, v in STATES["orbit" if "orbit" in system else "spring"] for dt in (0.1, 0.03)]
STARTS = np.array([[probe["q"], probe["v"]] for probe in PROBES])
# Whole runs: the chapter's three as the chapter runs them, an orbit with drag, and two ladders (dt, then
# dt/2) on springs whose exact motion is known, for the order of convergence.
CHAPTER_RUN = {"dt": 0.01, "steps": 2000}
LADDER = {"semi_implicit_step": (0.02, 0.01), "rk4_step": (0.2, 0.1)}
LADDER_START, LADDER_SECONDS = ([0.7, -0.2, 0.4], [0.3, 0.5, -0.6]), 2.0
# A run agrees when no state is further from the engine's than TOLERANCE, relative to the run's largest value:
# 100 times RIGHT_GAP, the largest gap of the planted right files (right_np_add.py's RK4), which only round
# differently. tests/test_check_ex2.py measures it again.
RIGHT_GAP, TOLERANCE = 8.9e-12, 100 * 8.9e-12


def tasks(name: str) -> list:
    """What the child runs for one function: the probes, then the whole runs."""
    chapter = [{"system": s, "q0": ex2_cases.BUILT[s]["q0"].tolist(), "v0": ex2_cases.BUILT[s]["v0"].tolist(),
                **CHAPTER_RUN} for s in ex2_cases.CHAPTER]
    ladders = [{"system": s, "q0": LADDER_START[0], "v0": LADDER_START[1], "dt": dt,
                "steps": round(LADDER_SECONDS / dt)} for s in ("heavy_spring", "heavy_damped_spring")
               for dt in LADDER[name]]
    dragged = {"system": "dragged_orbit", "q0": [1.0, 0.0, 0.1], "v0": [0.0, 1.1, 0.0], "dt": 0.01, "steps": 500}
    return [{"function": name, "group": name, "kind": "probes", "probes": PROBES},
            *({"function": name, "group": name, "kind": "run", **run} for run in [*chapter, *ladders, dragged])]


def agrees(mine, theirs):
    """Per row: equal up to round-off (1e-9 of the size), so any order of the same arithmetic agrees."""
    with np.errstate(all="ignore"):
        return (np.abs(mine - theirs) <= 1e-9 * np.maximum(1.0, np.abs(theirs))).reshape(len(mine), -1).all(axis=1)


def gaps(mine, theirs):
    """Per row of a run: the largest difference from the engine's, relative to the run's largest value."""
    with np.errstate(all="ignore"):
        gap = np.max(np.abs(mine - theirs), axis=1) / max(1.0, float(np.max(np.abs(theirs))))
    return np.where(np.isfinite(gap), gap, np.inf)


class Measured:
    """One function's numbers beside the engine's, and the figures its messages quote."""

    def __init__(self, name: str, results: list, references: list):
        self.name, self.tasks, probes = name, tasks(name), results[0]
        self.mine, self.again = np.array([probes["outputs"], probes["again"]], float).reshape(2, len(PROBES), 2, 3)
        self.calls, self.changed = np.array(probes["calls"], dtype=int), list(probes["changed"])
        self.theirs = np.array(references[0]["outputs"], dtype=float)
        self.right = agrees(self.mine, self.theirs)
        self.runs = [np.array(r["rows"], dtype=float).reshape(t["steps"] + 1, 6)
                     for r, t in zip(results[1:], self.tasks[1:], strict=True)]
        self.engine_runs = [np.array(r["rows"]) for r in references[1:]]
        self.reused = next((r["reused"] for r in results[1:] if r["reused"]), None)
        self.gaps = [gaps(a, b) for a, b in zip(self.runs, self.engine_runs, strict=True)]

    def order(self, system: str, runs=None) -> tuple[float, float, float]:
        """(error at the smaller dt, what halving dt divides it by, order) against the exact motion."""
        errors = []
        for dt in LADDER[self.name]:
            i = next(i for i, t in enumerate(self.tasks[1:]) if t["system"] == system and t["dt"] == dt)
            exact = ex2_cases.exact_position(system, *LADDER_START, round(LADDER_SECONDS / dt) * dt)
            errors.append(float(np.max(np.abs((runs or self.runs)[i][-1, :3] - exact))))
        factor = errors[0] / errors[1] if errors[1] else math.inf  # Python floats: no numpy warnings either
        return errors[1], factor, math.log2(factor) if 0 < factor < math.inf else math.nan

    def orbit(self, runs=None) -> str:
        rows = (runs or self.runs)[ex2_cases.CHAPTER.index("orbit")]
        worst = engine.energy_drift(ex2_cases.BUILT["orbit"]["energy"](rows[:, :3], rows[:, 3:]))["rel_max"]
        return "inf (it blew up)" if worst is None else f"{worst:.1%}" if worst >= 5e-4 else f"{worst:.1e}"


@functools.cache  # the same for every file checked
def engine_answers(name: str) -> list:
    return [ex2_cases.collect(ENGINE, task) for task in tasks(name)]


def judge(name: str, path: Path, run: student_code.Run, indices: list) -> tuple[bool, str]:
    """(solved, message) for one function."""
    signature, note = student_code.source_notes(path, name, ["q", "v", "m", "force", "dt"])
    where = {i: "during single steps from fresh states" if task["kind"] == "probes" else
             f"during a whole run ({task['steps']:,} steps) on {ex2_cases.describe(task['system'])}"
             for i, task in enumerate(every())}
    problem = signature or student_code.failure_sentence(run, indices, where.get, TIME_LIMIT)
    if problem:
        return False, f"{name}: {problem}{note}"
    try:
        measured = Measured(name, [run.results[i] for i in indices], engine_answers(name))
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as error:
        return False, f"{name}: your file's run did not finish: it sent back {type(error).__name__} instead of numbers."
    solved, message = verdict(measured, *METHODS[name][::2])
    return solved, f"{name}: {message}{note}"


def verdict(measured: Measured, method: str, nominal: int) -> tuple[bool, str]:
    mine, runs = measured.mine, len(measured.runs)
    if measured.changed:
        return False, (f"it changes the {' and '.join(measured.changed)} it was given (an in-place update), so"
                       " the caller's state is overwritten. Which arrays may a step write into?")
    worst = int(np.argmax([np.max(gap) for gap in measured.gaps]))
    worst_gap = float(np.max(measured.gaps[worst]))  # the ladders are runs too: within TOLERANCE, the engine's order
    if measured.right.all() and worst_gap <= TOLERANCE:
        return True, (f"solved: the engine's {method} on {len(PROBES)} single steps and {runs} whole runs, "
                      + ("to the last bit." if not worst_gap else f"within {worst_gap:.1e} of its size (allowed:"
                                                                  f" {TOLERANCE:.0e})."))
    varies = ~np.isclose(mine, measured.again, rtol=1e-9, atol=1e-9, equal_nan=True).all(axis=(1, 2))
    if varies.any():
        return False, (f"its results vary between calls: called twice in a row from the same state, it returned"
                       f" different numbers on {varies.sum()} of {len(PROBES)} single steps. A step must depend only"
                       " on what it is given: what does yours keep from one call to the next?")
    if measured.right.all():
        task, parts = measured.tasks[1 + worst], int(np.argmax(measured.gaps[worst] > TOLERANCE))
        ours, theirs = measured.runs[worst], measured.engine_runs[worst]
        off = float(np.max(np.abs(ours[-1, :3] - theirs[-1, :3])))
        return False, (
            f"every single step from a fresh state matches the engine's {method}, but a whole run, each step fed its"
            f" own output, does not: on {ex2_cases.describe(task['system'])}, at dt {task['dt']}, it parts from the"
            f" engine's at step {parts} of {task['steps']:,}, where the engine's speed is"
            f" {np.linalg.norm(theirs[parts, 3:]):.3g} m/s, and "
            + (f"ends {off:.3g} m away." if math.isfinite(off) else "ends in inf or NaN.")
            + (f" From step {measured.reused} of a run on, the arrays it returns share memory with the ones it was"
               " given." if measured.reused else "") + " A step must depend only on what it is given: does yours"
            " keep something from one call to the next, write into arrays it returned before, or limit a value that"
            " single steps never reached?")
    change, rk_change = mine - STARTS, measured.theirs - STARTS  # what a step adds, and what the engine's adds
    if np.isfinite(change).all() and agrees(change, np.round(change)).all():
        whole = ", ".join(map("{:g}".format, np.unique(np.round(change)) + 0.0))
        return False, f"every change your step makes is a whole number ({whole}). {FLOOR}"
    scale = float(np.sum(change * rk_change) / np.sum(rk_change * rk_change))  # a uniform rescaling, if it is one
    if measured.name == "rk4_step" and agrees(change, scale * rk_change).all():
        return False, (f"every change your step makes is {scale:.5g} times RK4's: " + (
            "close to 1, not 1. Is a fraction written as a rounded decimal?" if abs(scale - 1) < 0.01 else
            f"the weights of your final blend add up to {scale:.5g}, not 1. What do the chapter's add up to?"))
    for function, variant, message, where_ in MISTAKES:
        relevant = [where_ == "all" or ex2_cases.velocity_free(p["system"]) for p in PROBES]
        steps = SimpleNamespace(step=variant)
        theirs = ex2_cases.collect(steps, tasks(function)[0] | {"function": "step"})
        if function == measured.name and agrees(mine, np.array(theirs["outputs"]))[relevant].all():
            runs = ([np.array(ex2_cases.collect(steps, t | {"function": "step"})["rows"]) for t in measured.tasks[1:]]
                    if "{" in message else None)  # its figures are the named method's, not the file's
            return False, message.format(orbit=measured.orbit(runs),
                                         halving=f"{measured.order('heavy_spring', runs)[1]:.1f}")
    if agrees(mine[:, ::-1], measured.theirs).all():
        return False, "your numbers are right but returned in the wrong order: which comes first in the pair?"
    return False, unrecognised(measured, method, nominal)


def unrecognised(measured: Measured, method: str, nominal: int) -> str:
    """A mistake nobody listed: say what the numbers show, and only that."""
    mine, theirs, right = measured.mine, measured.theirs, measured.right
    if (measured.calls == 0).all():
        return "it never calls force: where does the acceleration come from in the chapter's steps?"
    seen = [f"not {method} yet. What the checker measured:"]
    by_dt = mine.reshape(len(SYSTEMS), 2, 2, 6)  # system, state, dt, (q, v)
    if np.array_equal(by_dt[:, :, 0], by_dt[:, :, 1]):
        seen.append("From the same state, dt = 0.1 and dt = 0.03 give the very same result: is dt overwritten?")
    with np.errstate(all="ignore"):
        off = float(np.max(np.abs(mine - theirs) / np.maximum(1.0, np.abs(theirs))))
        gap_by_dt = np.abs(mine - theirs).reshape(len(SYSTEMS), 2, 2, 6).max(axis=(0, 1, 3))
    if off < 1e-3 and gap_by_dt[0] < 3 * gap_by_dt[1]:  # a few digits off at any dt: rounding, not a method
        seen.append(f"Its numbers agree with {method}'s to about {-math.log10(off):.0f} digits, where the same"
                    " arithmetic agrees to 15. Is a number rounded somewhere, or is the arithmetic in float32?")
    ok = {s: bool(right[[p["system"] == s for p in PROBES]].all()) for s in SYSTEMS}
    wrong = "; ".join(ex2_cases.describe(s) for s in SYSTEMS if not ok[s]) if any(ok.values()) else "every system"
    if all(ok[s] for s in SYSTEMS if ex2_cases.mass(s) == 1.0):
        seen.append(f"It is right whenever m = 1 and wrong on {wrong}: where does m enter your step?")
    elif all(ok[s] for s in SYSTEMS if ex2_cases.velocity_free(s)):
        seen.append(f"It is right where the force ignores velocity, wrong on {wrong}: which velocity goes to force?")
    else:
        seen.append(f"It differs from {method} on {wrong}.")
    q_right, v_right = agrees(mine[:, :1], theirs[:, :1]).all(), agrees(mine[:, 1:], theirs[:, 1:]).all()
    if q_right != v_right:
        right, wrong = ("q_next", "v_next") if q_right else ("v_next", "q_next")
        seen.append(f"Its {right} is right; its {wrong} is not.")
    if int(np.median(measured.calls)) != METHODS[measured.name][3]:
        seen.append(f"It calls force {int(np.median(measured.calls))} times per step; {method} calls it"
                    f" {METHODS[measured.name][3]}.")
    error, factor, order = measured.order("heavy_damped_spring")
    seen.append("On a damped spring with m = 2.5 (exact motion known) " + (
        f"halving dt divides its error by {factor:.2f}: order {order:.2f}, where {method} is order {nominal}."
        if math.isfinite(order) and error < 0.1 else f"after {LADDER_SECONDS:.0f} s at dt {LADDER[measured.name][1]}"
        f" it is {error:.3g} m from the exact motion: it does not follow it."))
    return " ".join(seen)


# --- the command ---


def every() -> list:
    return [task for name in METHODS for task in tasks(name)]


def check(path: Path, run: student_code.Run | None = None) -> tuple[dict, list[str], student_code.Run]:
    """({function: solved}, one message per function, the run) for a file that compiles (or for its `run`)."""
    run = run or student_code.collect(path, "exercises.support.ex2_cases", every(), TIME_LIMIT)
    judged = [judge(name, path, run, [i for i, t in enumerate(every()) if t["function"] == name]) for name in METHODS]
    return dict(zip(METHODS, (solved for solved, _ in judged), strict=True)), [message for _, message in judged], run


def main(argv=None) -> int:
    return student_code.main(PROG, __doc__, DEFAULT_FILE, "your .py file with the two steps", check, argv)


if __name__ == "__main__":
    sys.exit(main())
