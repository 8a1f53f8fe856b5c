"""Checker for exercise 2: runs your two steps and tells you what they do.

    python -m exercises.check_ex2                          # checks exercises/ex2_integrators.py
    python -m exercises.check_ex2 path/to/your_file.py     # or any .py file defining the two steps

Your file runs in a separate Python process with a time limit; this checker only reads the numbers your
steps return. A step passes when its single steps from a few dozen states of seven systems equal the
engine's, and its whole runs (each step fed its own output) on the chapter's three systems and on the
checker's own stay with the engine's runs from the same start. When they differ, it says which usual
mistake it sees, or what it measured. Exit code 0: both solved; 1: something to fix; 2: could not start.
"""

import os
import sys

if __package__ in (None, ""):  # run as a file (python exercises/check_ex2.py): make the repo importable
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from curriculum.common.interrupts import guard  # noqa: E402

guard("python -m exercises.check_ex2")  # Ctrl-C or SIGTERM from here on: one line, 130 or 143

import argparse  # noqa: E402
import math  # noqa: E402
from pathlib import Path  # noqa: E402
from types import SimpleNamespace  # noqa: E402

import numpy as np  # noqa: E402

import engine  # noqa: E402
from curriculum.common import student_code  # noqa: E402
from curriculum.common.cli import OneLineParser  # noqa: E402
from curriculum.common.predict import explain  # noqa: E402
from exercises.support import ex2_cases  # noqa: E402
from exercises.support.ex2_mistakes import MISTAKES  # noqa: E402

PROG = "python -m exercises.check_ex2"
DEFAULT_FILE = Path(__file__).resolve().parent / "ex2_integrators.py"
METHODS = {"semi_implicit_step": ("semi-implicit Euler", engine.semi_implicit_step, 1),
           "rk4_step": ("RK4", engine.rk4_step, 4)}  # (what it is, the engine's step, its order)
ENGINE = SimpleNamespace(**{name: method[1] for name, method in METHODS.items()})
TIME_LIMIT = 20.0  # seconds for one child to run everything; a normal check takes about one
PARAMETERS = ["q", "v", "m", "force", "dt"]

# Single steps from these states, on every system, at two timesteps: the arithmetic, system by system.
STATES = {"spring": [([0.8, -0.3, 0.5], [0.2, 0.6, -0.4]), ([-1.1, 0.4, 0.2], [-0.5, 0.1, 0.9])],
          "orbit": [([1.0, 0.1, 0.05], [-0.1, 1.05, 0.02]), ([0.6, -0.8, 0.1], [0.7, 0.5, -0.1])]}
SYSTEMS = (*ex2_cases.CHAPTER, *ex2_cases.OWN)
PROBES = [{"system": system, "q": q, "v": v, "dt": dt} for system in SYSTEMS
          for q, v in STATES["orbit" if "orbit" in system else "spring"] for dt in (0.1, 0.03)]
# Whole runs: the chapter's three as the chapter runs them, an orbit with drag, and two ladders (dt, then
# dt/2) on springs whose exact motion is known, for the order of convergence.
CHAPTER_RUN = {"dt": 0.01, "steps": 2000}
LADDER = {"semi_implicit_step": (0.02, 0.01), "rk4_step": (0.2, 0.1)}
LADDER_START, LADDER_SECONDS = ([0.7, -0.2, 0.4], [0.3, 0.5, -0.6]), 2.0
ORDER_BAND = 0.25  # the measured order must be the method's, 1 or 4, give or take this (the engine's: 1.00, 4.13)
# A run agrees when no state along it is further from the engine's than TOLERANCE, relative to the run's
# largest value. RIGHT_GAP is the largest such gap of the planted right files, which only round differently
# (tests/test_check_ex2.py measures it again; 8.9e-12, right_np_add.py's RK4); TOLERANCE allows 100 times that.
RIGHT_GAP = 8.9e-12
TOLERANCE = 100 * RIGHT_GAP


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


def probes_of(steps) -> np.ndarray:
    return np.array(ex2_cases.collect(steps, tasks("rk4_step")[0] | {"function": "step"})["outputs"], dtype=float)


def agrees(mine: np.ndarray, theirs: np.ndarray) -> np.ndarray:
    """Per probe: equal up to round-off (1e-9 of the size), so any order of the same arithmetic agrees."""
    close = np.abs(mine - theirs) <= 1e-9 * np.maximum(1.0, np.abs(theirs))
    return close.reshape(len(mine), -1).all(axis=1)


def gaps(mine: np.ndarray, theirs: np.ndarray) -> np.ndarray:
    """Per state of a run: how far it is from the engine's, relative to the run's largest value."""
    with np.errstate(all="ignore"):
        gap = np.max(np.abs(mine - theirs), axis=1) / max(1.0, float(np.max(np.abs(theirs))))
    return np.where(np.isfinite(gap), gap, np.inf)


# --- judging one function from what its child run sent back ---


class Measured:
    """The student's numbers for one function beside the engine's, and the figures the messages quote."""

    def __init__(self, name: str, results: list, references: list):
        self.name, self.tasks = name, tasks(name)
        self.mine = np.array(results[0]["outputs"], dtype=float).reshape(len(PROBES), 2, 3)
        self.calls, self.changed = np.array(results[0]["calls"], dtype=int), list(results[0]["changed"])
        self.theirs = np.array(references[0]["outputs"], dtype=float)
        self.right = agrees(self.mine, self.theirs)
        self.runs = [np.array(r["rows"], dtype=float).reshape(t["steps"] + 1, 6) for r, t in
                     zip(results[1:], self.tasks[1:], strict=True)]
        self.engine_runs = [np.array(r["rows"]) for r in references[1:]]
        self.reused = [r["reused"] for r in results[1:]]
        self.gaps = [gaps(mine, theirs) for mine, theirs in zip(self.runs, self.engine_runs, strict=True)]

    def run_of(self, system: str, dt: float | None = None) -> int:
        return next(i for i, t in enumerate(self.tasks[1:]) if t["system"] == system and dt in (None, t["dt"]))

    def order(self, system: str, runs=None) -> tuple[float, float, float]:
        """(error at dt/2, halving factor, order) of the final position against the exact motion."""
        errors = []
        for dt in LADDER[self.name]:
            rows = (runs or self.runs)[self.run_of(system, dt)]
            exact = ex2_cases.exact_position(system, *LADDER_START, round(LADDER_SECONDS / dt) * dt)
            errors.append(float(np.max(np.abs(rows[-1, :3] - exact))))
        with np.errstate(all="ignore"):
            factor = errors[0] / errors[1] if errors[1] > 0 else math.inf
        return errors[1], factor, math.log2(factor) if 0 < factor < math.inf else math.nan

    def orbit(self) -> str:
        rows = self.runs[self.run_of("orbit")]
        drift = engine.energy_drift(ex2_cases.BUILT["orbit"]["energy"](rows[:, :3], rows[:, 3:]))
        return "inf (it blew up)" if drift["diverged"] else f"{drift['rel_max']:.1%}"


def judge(name: str, run: student_code.Run, indices: list, definitions: dict) -> tuple[bool, str]:
    """(solved, message) for one function."""
    method, _, nominal = METHODS[name]
    defined = definitions.get(name, [])
    note = (f" It is defined {len(defined)} times in your file (lines {', '.join(str(d[0]) for d in defined)}):"
            f" Python keeps the last one, line {defined[-1][0]}, and that is the one checked." if len(defined) > 1 else "")
    if defined and defined[-1][1][:5] != PARAMETERS and (sorted(defined[-1][1][:5]) == sorted(PARAMETERS)
                                                         or len(defined[-1][1]) < 5):
        return False, (f"{name}: you changed its signature to {name}({', '.join(defined[-1][1])}). The engine calls"
                       f" every step as {name}({', '.join(PARAMETERS)}), in that order; keep the first line.{note}")
    problem = failure(name, run, indices)
    if problem:
        return False, f"{name}: {problem}{note}"
    try:
        measured = Measured(name, [run.results[i] for i in indices],
                            [ex2_cases.collect(ENGINE, tasks(name)[k]) for k in range(len(indices))])
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as error:
        return False, f"{name}: your file's run did not finish: it sent back {type(error).__name__} instead of numbers."
    solved, message = verdict(measured, method, nominal)
    return solved, f"{name}: {message}{note}"


def failure(name: str, run: student_code.Run, indices: list) -> str | None:
    """The sentence for a run that ended without numbers: import, exception, time limit, malformed."""
    if run.malformed:
        return f"your file's run did not finish: {run.malformed}."
    if run.imported:
        if run.imported.get("stopped", "").startswith("exit"):
            return (f"your file ended Python while it was being imported ({run.imported['stopped']}): does it call"
                    " os._exit() at the top level? Only the two steps' definitions need to be there.")
        if "error" not in run.imported:
            return (f"importing your file did not finish ({run.imported['stopped']}, limit {TIME_LIMIT:.0f} s). Code"
                    " at the top level runs when a file is imported: put trial runs under"
                    " `if __name__ == \"__main__\":`, and look for a loop that never ends or a call that ends Python.")
        return (f"your file stopped while Python was importing it: it"
                f" {student_code.error_sentence(run.imported['error'])}.")
    for i in indices:
        task = tasks(name)[indices.index(i)]
        where = ("during single steps from fresh states" if task["kind"] == "probes" else
                 f"during a whole run ({task['steps']:,} steps) on {ex2_cases.describe(task['system'])}")
        if i in run.stopped and run.stopped[i] == "time limit":
            if task["kind"] == "run":
                return (f"every single step returned, but {where} it did not finish within {TIME_LIMIT:.0f} s. One"
                        " step should take well under a millisecond: is there a slow loop, a sleep or a print in it?")
            return (f"stopped after {TIME_LIMIT:.0f} s {where}, without returning. Is there a loop that never ends"
                    " (a `while` whose condition never turns false)?")
        if i in run.stopped:
            return (f"the checker's run of your file ended by itself ({run.stopped[i]}) {where}. Does your code call"
                    " os._exit(), or crash Python? A step should only return (q_next, v_next).")
        result = run.results.get(i, {})
        if "error" in result:
            error = result["error"]
            if error.get("type") == "NotImplementedError":
                return "not solved yet. It still raises NotImplementedError: fill in its TODO."
            if error.get("type") == "SystemExit":
                return (f"your code ends Python with sys.exit() or exit() {where}, line {error.get('line', '?')}:"
                        " a step only returns (q_next, v_next).")
            return f"it {student_code.error_sentence(error)}."
        if result.get("problem") == "missing":
            return "not found in your file. Keep the function names as they are."
        if "problem" in result:
            return f"your function {result['problem']}."
    return None


def verdict(measured: Measured, method: str, nominal: int) -> tuple[bool, str]:
    name, mine = measured.name, measured.mine
    if measured.changed:
        changed = " and ".join(measured.changed)
        return False, (f"it changes the {changed} array it was given (an in-place update), so the caller's state is"
                       " overwritten. Which arrays may a step write into, and which must it leave as they came?")
    worst = int(np.argmax([float(np.max(g)) for g in measured.gaps]))
    worst_gap = float(np.max(measured.gaps[worst]))
    _, _, order = measured.order("heavy_damped_spring")
    _, _, engine_order = measured.order("heavy_damped_spring", measured.engine_runs)
    if measured.right.all() and worst_gap <= TOLERANCE and abs(order - nominal) <= ORDER_BAND:
        return True, (f"solved. Same numbers as the engine's {method} from {len(PROBES)} single steps on"
                      f" {len(SYSTEMS)} systems (masses 1, 2.5 and 0.7; forces with and without velocity), and its"
                      f" {len(measured.runs)} whole runs, each step fed its own output (the chapter's orbit, spring"
                      f" and freefall as the chapter runs them, and {len(measured.runs) - 3} on the checker's), "
                      + ("are the engine's to the last bit." if worst_gap == 0 else f"stay within {worst_gap:.1e} of"
                         f" the engine's, relative to their size (allowed: {TOLERANCE:.0e})."))
    if measured.right.all():
        task = measured.tasks[1 + worst]
        parts = int(np.argmax(measured.gaps[worst] > TOLERANCE))
        speed = float(np.linalg.norm(measured.engine_runs[worst][parts, 3:]))
        off = float(np.max(np.abs(measured.runs[worst][-1, :3] - measured.engine_runs[worst][-1, :3])))
        ends = f"ends {off:.3g} m away" if math.isfinite(off) else "ends in inf or NaN"
        reused = next((r for r in measured.reused if r), None)
        error = measured.order("heavy_damped_spring")[0]
        return False, (
            f"every single step from a fresh state matches the engine's {method}, but a whole run, each step fed its"
            f" own output, does not: on {ex2_cases.describe(task['system'])}, at dt {task['dt']}, it parts from the"
            f" engine's at step {parts} of {task['steps']:,}, where the engine's speed is {speed:.3g} m/s, and {ends}."
            + (f" On a damped spring with m = 2.5 its measured order is {order:.2f}; the engine's {method} measures"
               f" {engine_order:.2f} on the same runs." if abs(order - nominal) > ORDER_BAND and error < 0.1 else "")
            + (f" From step {reused} of a run on, the arrays it returns share memory with the ones it was given."
               if reused else "") + " A step must depend only on what it is given: does yours keep something from"
            " one call to the next, write into arrays it returned before, or limit a value that single steps never"
            " reached?")
    halving = measured.order("heavy_spring")[1]
    for function, variant, message, where in MISTAKES:
        relevant = [ex2_cases.velocity_free(p["system"]) or where == "all" for p in PROBES]
        if function == name and agrees(mine, probes_of(SimpleNamespace(step=variant)))[relevant].all():
            return False, message.format(orbit=measured.orbit(), halving=f"{halving:.1f}")
    scaled = step_scale(mine, measured.theirs)
    if scaled:
        return False, scaled.format(method=method)
    if agrees(mine[:, ::-1], measured.theirs).all():
        return False, ("your numbers are right but returned in the wrong order, (v_next, q_next). The engine unpacks"
                       " the pair position first.")
    return False, unrecognised(measured, method, nominal)


def unrecognised(measured: Measured, method: str, nominal: int) -> str:
    """A mistake nobody listed: say what the numbers show, and only that."""
    mine, theirs, right = measured.mine, measured.theirs, measured.right
    if not np.isfinite(mine).all():
        bad = PROBES[int(np.argmin(np.isfinite(mine).reshape(len(mine), -1).all(axis=1)))]
        return (f"it returns inf or NaN after one step of {bad['dt']} s on {ex2_cases.describe(bad['system'])}, from"
                f" q = {bad['q']}, v = {bad['v']}. Is there a division that can be by zero, or a sign that sends the"
                " state the wrong way?")
    if (measured.calls == 0).all():
        return ("it never calls force, so its acceleration does not come from the system it is given. Where does"
                " the acceleration come from in the chapter's steps?")
    seen = [f"not {method} yet, and not one of the usual mistakes. What the checker measured:"]
    pairs = mine.reshape(len(SYSTEMS), 2, 2, 2, 3)  # system, state, dt, (q, v), xyz
    if np.array_equal(pairs[:, :, 0], pairs[:, :, 1]):
        seen.append("from the same state, dt = 0.1 and dt = 0.03 give the very same result: is dt overwritten or"
                    " unused inside your step?")
    with np.errstate(all="ignore"):
        off = float(np.max(np.abs(mine - theirs) / np.maximum(1.0, np.abs(theirs))))
        by_dt = np.abs(mine - theirs).reshape(len(SYSTEMS), 2, 2, -1).max(axis=(0, 1, 3))  # at dt 0.1, at 0.03
    if off < 1e-3 and by_dt[0] < 3 * by_dt[1]:  # a few digits off, whatever dt: rounding, not a method
        seen.append(f"its numbers agree with {method}'s to about {-math.log10(off):.0f} digits, where the same"
                    " arithmetic agrees to 15. Is a number rounded somewhere, or is the arithmetic in float32?")
    by_system = {s: bool(right[[p["system"] == s for p in PROBES]].all()) for s in SYSTEMS}
    wrong = [ex2_cases.describe(s) for s, ok in by_system.items() if not ok]
    if all(ok for s, ok in by_system.items() if ex2_cases.mass(s) == 1.0):
        seen.append(f"It is right whenever m = 1 and wrong on {'; '.join(wrong)}: where does m enter your step?")
    elif all(ok for s, ok in by_system.items() if ex2_cases.velocity_free(s)):
        seen.append(f"It is right when the force ignores velocity and wrong on {'; '.join(wrong)}: which velocity"
                    " does your step hand to force(q, v)?")
    else:
        seen.append(f"It differs from {method} on {'every system' if len(wrong) == len(SYSTEMS) else '; '.join(wrong)}.")
    q_right, v_right = agrees(mine[:, :1], theirs[:, :1]).all(), agrees(mine[:, 1:], theirs[:, 1:]).all()
    if q_right != v_right:
        seen.append(f"Its {'q_next' if q_right else 'v_next'} is right; its {'v_next' if q_right else 'q_next'} is not.")
    typical = int(np.median(measured.calls))
    if typical != (4 if nominal == 4 else 1):
        seen.append(f"It calls force {typical} time{'s' * (typical != 1)} per step; {method} calls it"
                    f" {4 if nominal == 4 else 1}.")
    error, factor, order = measured.order("heavy_damped_spring")
    dt = LADDER[measured.name][1]
    if math.isfinite(order) and error < 0.1:
        seen.append(f"On a damped spring with m = 2.5 (exact motion known) halving dt divides its error by"
                    f" {factor:.2f}: order {order:.2f}, where {method} is order {nominal}.")
    else:
        seen.append(f"On a damped spring with m = 2.5 (exact motion known), after {LADDER_SECONDS:.0f} s at dt {dt}"
                    f" its position is {error:.3g} m from the exact motion: it does not follow the motion.")
    return " ".join(seen)


def step_scale(mine: np.ndarray, theirs: np.ndarray) -> str | None:
    """A sentence if every probe's change (q_next - q, v_next - v) is s * dt^k times the method's, s dt^k != 1."""
    start = np.array([[p["q"], p["v"]] for p in PROBES])
    dts = np.array([p["dt"] for p in PROBES])
    change, their_change = (mine - start).reshape(len(mine), -1), (theirs - start).reshape(len(mine), -1)
    with np.errstate(all="ignore"):
        ratios = (change * their_change).sum(axis=1) / (their_change * their_change).sum(axis=1)
        if not np.allclose(change, ratios[:, None] * their_change, rtol=1e-7, atol=1e-12):
            return None
        for k in (0, 1, -1):
            s = float((ratios / dts**k).mean())
            if np.ptp(ratios / dts**k) <= 1e-7 * abs(s) and not (k == 0 and abs(s - 1) < 1e-6):
                break
        else:
            return None
    if k == 1:
        return "every change your step makes is dt times {method}'s: dt multiplies your update twice. How many" \
               " times does a slope need dt to become a change?"
    if k == -1:
        return "every change your step makes is {method}'s divided by dt: dt is missing from your update. What turns" \
               " a rate into a change?"
    if abs(s - 1) < 0.01:
        return (f"every change your step makes is {s:.6g} times {{method}}'s, on every system: close to 1, but not"
                " 1. Is a fraction written as a rounded decimal?")
    return (f"every change your step makes is {s:.4g} times {{method}}'s, on every system: the weights of your final"
            f" blend add up to {s:.4g}, not 1. What do the weights of the chapter's blend add up to?")


# --- the command ---


def check(path: Path) -> tuple[bool, list[str], student_code.Run]:
    """(both solved, one message per function, the run) for a file that compiles."""
    every = [task for name in METHODS for task in tasks(name)]
    run = student_code.collect(path, "exercises.support.ex2_cases", every, PROG, TIME_LIMIT)
    definitions, solved, messages, first = student_code.definitions(path), True, [], 0
    for name in METHODS:
        indices = list(range(first, first + len(tasks(name))))
        first += len(indices)
        ok, message = judge(name, run, indices, definitions)
        solved, messages = solved and ok, messages + [message]
    return solved, messages, run


def main(argv=None) -> int:
    parser = OneLineParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file", nargs="?", type=Path, default=DEFAULT_FILE,
                        help="your .py file with semi_implicit_step and rk4_step (default: exercises/ex2_integrators.py)")
    args = parser.parse_args(argv)
    student_code.handle_signals(PROG)
    problem = student_code.source_problem(args.file)
    if problem and problem[0] == 2:
        parser.exit(2, f"{PROG}: error: {problem[1]}\n")
    if problem:  # does not compile: the sentence, then the line as it is in the file
        sentence, _, code = problem[1].partition("\n")
        explain(sentence)
        print(code + "\n\nNot solved yet: fix that line, and run the checker again.")
        return 1
    try:
        solved, messages, run = check(args.file)
    except student_code.ScratchProblem as error:
        parser.exit(2, f"{PROG}: error: {error}\n")
    if run.printed_bytes:
        lines = run.printed.decode("utf-8", "replace").splitlines()[:8]
        print(f"Your code printed {run.printed_bytes:,} bytes while it was checked; the start:")
        print("\n".join(f"  | {line[:200]}" for line in lines) + "\n")
    if run.clashes:
        explain(student_code.clash_sentence(run.clashes), "")
    explain(*messages)
    print("\nAll solved." if solved else "\nNot solved yet: read the messages above, edit, and run the checker again.")
    return 0 if solved else 1


if __name__ == "__main__":
    try:
        sys.exit(main())
    except BrokenPipeError:  # piped into `head`, which stopped reading: not an error worth a traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(1)
