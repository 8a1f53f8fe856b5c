"""Checker for exercise 2: runs your two steps and tells you what they do.

    python -m exercises.check_ex2                          # checks exercises/ex2_integrators.py
    python -m exercises.check_ex2 path/to/your_file.py     # or any .py file defining the two steps

Your file runs in a separate Python process with a time limit; this checker only reads the numbers
your steps return. It asks each step for single steps from a few dozen states of six systems (masses
other than 1, forces that depend on velocity) and compares them with the engine's integrators, then
runs whole trajectories where the exact motion is known. When your numbers differ, it compares them
with the usual mistakes and says which one it sees, or what it measured if it is none of them.
Exit code 0 means both steps are solved, 1 that something is left to fix, 2 that it could not start.
"""

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import tokenize
from pathlib import Path

if __package__ in (None, ""):  # run as a file (python exercises/check_ex2.py): make the repo importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

import engine
from curriculum.common.cli import OneLineParser
from curriculum.common.predict import explain
from exercises.support import ex2_cases
from exercises.support.ex2_mistakes import RK4_MISTAKES, SEMI_MISTAKES

DEFAULT_FILE = Path(__file__).resolve().parent / "ex2_integrators.py"
CHILD = Path(__file__).resolve().parent / "support" / "ex2_child.py"
FUNCTIONS = ("semi_implicit_step", "rk4_step")
TIME_LIMIT = 20.0  # seconds for the child to run both steps; a normal check needs about one
SHOWN_OUTPUT_LINES = 8

# Single steps from these states, on every case, at two timesteps: the arithmetic, case by case.
PROBE_STATES = {
    "spring": [([0.8, -0.3, 0.5], [0.2, 0.6, -0.4]), ([-1.1, 0.4, 0.2], [-0.5, 0.1, 0.9])],
    "orbit": [([1.0, 0.1, 0.05], [-0.1, 1.05, 0.02]), ([0.6, -0.8, 0.1], [0.7, 0.5, -0.1])],
}
PROBE_DTS = (0.1, 0.03)
PROBES = [{"case": case, "q": q, "v": v, "dt": dt}
          for case in ex2_cases.CASES
          for q, v in PROBE_STATES["orbit" if "orbit" in case else "spring"]
          for dt in PROBE_DTS]

# Whole runs: the chapter's orbit for the energy band, and the springs whose motion is known exactly.
ORBIT = engine.build_system("orbit", np.random.default_rng(0))
ORDER_SECONDS = 2.0
ORDER_START = ([0.7, -0.2, 0.4], [0.3, 0.5, -0.6])
ORDER_DTS = {"semi_implicit_step": (0.02, 0.01), "rk4_step": (0.2, 0.1)}
ORDER_DTS_ALL = sorted({dt for dts in ORDER_DTS.values() for dt in dts}, reverse=True)  # both steps run them all
BAND_STEPS = (2000, 8000)
EXPECTED = {"semi_implicit_step": ("semi-implicit Euler", engine.semi_implicit_step, 1, 1),
            "rk4_step": ("RK4", engine.rk4_step, 4, 4)}  # (method, reference, order, force calls per step)


# --- before running anything: is it a Python file that compiles? ---


def unreadable(path: Path) -> tuple[int, str] | None:
    """(exit code, sentence) if the file cannot be checked at all, else None. Runs none of its code."""
    if not path.exists():
        return 2, f"there is no file {path}"
    if path.is_dir():
        return 2, f"{path} is a folder; give the .py file that defines semi_implicit_step and rk4_step"
    if path.suffix != ".py":
        if path.suffix.lower() == ".py":
            return 2, f"{path.name} ends in {path.suffix}: Python imports only files ending in .py: rename it"
        return 2, (f"{path.name} is not a Python file: the checker imports your steps, so they must be in a file"
                   " ending in .py (save it as, e.g., my_steps.py)")
    data = path.read_bytes()
    if b"\0" in data:
        line = data[: data.index(b"\0")].count(b"\n") + 1
        return 1, (f"{path}, line {line}: the file contains a null byte (\\0), which Python source cannot hold;"
                   " it was probably saved by a word processor or is not a text file. Save it as plain text.\n"
                   f"    {shown_line(data, line)}")
    try:
        try:
            encoding, _ = tokenize.detect_encoding(iter(data.splitlines(keepends=True)).__next__)
        except SyntaxError as error:  # not UTF-8 in the first two lines, or a bad `coding:` comment
            encoding = "utf-8"
            data.decode(encoding)  # raises UnicodeDecodeError with the position if that is the problem
            return 1, f"{path}: {error.msg}"
        source = data.decode(encoding)
    except UnicodeDecodeError as error:
        line = data[: error.start].count(b"\n") + 1
        return 1, (f"{path}, line {line}: this line is not valid {encoding} text (byte {data[error.start]:#04x});"
                   f" save the file as UTF-8.\n    {shown_line(data, line)}")
    try:
        compile(source, str(path), "exec", dont_inherit=True)
    except SyntaxError as error:
        return 1, syntax_message(path, error, source)
    return None


def shown_line(data: bytes, line: int) -> str:
    text = data.splitlines()[line - 1].decode("utf-8", "replace") if data.splitlines() else ""
    return text.replace("\0", "\\0").strip()[:160]


def syntax_message(path: Path, error: SyntaxError, source: str) -> str:
    """File, line, the offending line with a caret, and what the error means."""
    kind = type(error).__name__
    why = {"TabError": " Indent with spaces only; most editors can turn tabs into spaces.",
           "IndentationError": " The lines of one block must start in the same column (four spaces per level)."}
    lines = source.splitlines()
    line = error.lineno or 0
    text = lines[line - 1] if 0 < line <= len(lines) else (error.text or "").rstrip("\n")
    stripped = text.lstrip()
    shown = f"    {stripped.expandtabs(4)}"
    if error.offset and stripped and kind == "SyntaxError":
        column = max(error.offset - 1 - (len(text) - len(stripped)), 0)
        shown += "\n    " + " " * len(stripped[:column].expandtabs(4)) + "^"
    return f"{path}, line {line}: {kind}: {error.msg}.{why.get(kind, '')}\n{shown}"


# --- running the student's steps, in a child process ---


def run_child(path: Path, functions: list) -> tuple[dict, dict, list, int, str | None]:
    """Run `functions` of the file in a child Python with a time limit.

    Returns (report, arrays by function, first printed lines, number of printed lines, what was running
    when it had to be stopped or ended by itself, or None if it finished).
    """
    job = {"file": str(path.resolve()), "functions": functions, "probes": PROBES,
           "runs": {name: runs(name) for name in functions}}
    with tempfile.TemporaryDirectory(prefix="check_ex2-") as scratch:
        scratch = Path(scratch)
        (scratch / "job.json").write_text(json.dumps(job))
        env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1", "PYTHONIOENCODING": "utf-8"}
        child = subprocess.Popen([sys.executable, str(CHILD), str(scratch / "job.json"), str(scratch)],
                                 stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                 env=env, start_new_session=True)
        printed, count = [], [0]
        reader = threading.Thread(target=keep_first_lines, args=(child.stdout, printed, count), daemon=True)
        reader.start()
        stopped = None
        try:
            child.wait(timeout=TIME_LIMIT)
        except subprocess.TimeoutExpired:
            stopped = "timeout"
            os.killpg(child.pid, signal.SIGKILL)
            child.wait()
        reader.join(timeout=5)
        status = (scratch / "status.txt").read_text().splitlines() if (scratch / "status.txt").exists() else []
        report = json.loads((scratch / "report.json").read_text()) if (scratch / "report.json").exists() else {}
        arrays = {}
        for name in functions:
            if (scratch / f"{name}.npz").exists():
                with np.load(scratch / f"{name}.npz", allow_pickle=False) as saved:
                    arrays[name] = dict(saved)
        if stopped is None and any(name not in report for name in functions) and "import" not in report:
            stopped = f"exit {child.returncode}"
        stage = status[-1] if status else "start"
        return report, arrays, printed, count[0], (f"{stopped}|{stage}" if stopped else None)


def keep_first_lines(stream, kept: list, count: list) -> None:
    """Drain the child's output, keeping the first few lines (a chatty step cannot bury the verdict)."""
    for raw in stream:
        count[0] += 1
        if len(kept) < SHOWN_OUTPUT_LINES:
            kept.append(raw.decode("utf-8", "replace").rstrip()[:200])


def runs(name: str) -> list:
    """The whole runs: the chapter's orbit (its energy band), then the exact springs' order ladders."""
    orbit = {"case": "orbit", "q0": ORBIT["q0"].tolist(), "v0": ORBIT["v0"].tolist(), "dt": 0.01,
             "steps": BAND_STEPS[-1] if name == "semi_implicit_step" else BAND_STEPS[0]}
    ladders = [{"case": case, "q0": ORDER_START[0], "v0": ORDER_START[1], "dt": dt, "steps": round(ORDER_SECONDS / dt)}
               for case in ("heavy_spring", "heavy_damped_spring") for dt in ORDER_DTS_ALL]
    return [orbit, *ladders]


# --- judging: the checker's own numbers against the child's ---


def on_probes(step_fn) -> np.ndarray:
    """(probes, 2, 3): step_fn's (q_next, v_next) from every probe state."""
    out = np.empty((len(PROBES), 2, 3))
    with np.errstate(all="ignore"):
        for i, probe in enumerate(PROBES):
            case = probe["case"]
            q_next, v_next = step_fn(np.array(probe["q"]), np.array(probe["v"]), ex2_cases.mass(case),
                                     ex2_cases.force_law(case), probe["dt"])
            out[i] = q_next, v_next
    return out


def agrees(mine: np.ndarray, theirs: np.ndarray) -> np.ndarray:
    """Per probe: equal up to round-off (1e-9 of the size), so any order of the same arithmetic agrees."""
    close = np.abs(mine - theirs) <= 1e-9 * np.maximum(1.0, np.abs(theirs))
    return close.reshape(len(mine), -1).all(axis=1)


def band(arrays: dict, steps: int) -> float:
    """Worst relative energy excursion on the chapter's orbit over the first `steps` steps."""
    q, v = arrays["run0_q"][: steps + 1], arrays["run0_v"][: steps + 1]
    with np.errstate(all="ignore"):
        e = ex2_cases.energy("orbit", q, v)
        return float(np.max(np.abs(e - e[0])) / abs(e[0]))


def order(arrays: dict, case: str, dts: tuple) -> tuple[float, float]:
    """(shrink factor, order) of the final position error against the exact motion when dt halves."""
    errors = []
    for dt in dts:
        j = 1 + ORDER_DTS_ALL.index(dt) + (len(ORDER_DTS_ALL) if case == "heavy_damped_spring" else 0)
        exact_q, _ = ex2_cases.exact_spring(case, *ORDER_START, round(ORDER_SECONDS / dt) * dt)
        errors.append(float(np.max(np.abs(arrays[f"run{j}_q"][-1] - exact_q))))
    with np.errstate(all="ignore"):
        factor = errors[0] / errors[1] if errors[1] > 0 else math.inf
    return factor, math.log2(factor) if 0 < factor < math.inf else math.nan


def judge(name: str, report: dict, arrays: dict, stopped: str | None, printed: int = 0) -> tuple[bool, str]:
    """(solved, message) for one function, from what its child run left behind."""
    method, reference, nominal_order, nominal_calls = EXPECTED[name]
    if "import" in report:
        return False, f"{name}: your file stopped while Python was importing it. {exception_sentence(report['import'])}"
    result = report.get(name)
    if result is None:
        return False, f"{name}: {stopped_sentence(stopped, printed)}"
    if "exception" in result:
        error = result["exception"]
        if error["type"] == "NotImplementedError":
            return False, f"{name}: not solved yet. It still raises NotImplementedError: fill in its TODO."
        return False, f"{name}: {exception_sentence(error, name)}"
    if "error" in result:
        if result["error"] == "missing":
            return False, f"{name}: not found in your file. Keep the function names as they are."
        return False, f"{name}: your function {result['error']}."
    if "signature" in result:
        return False, (f"{name}: you changed its signature to {name}{result['signature']}. The engine calls every step"
                       f" as {name}(q, v, m, force, dt), in that order; keep the first line as it was given.")
    if "delegates" in result:
        return False, (f"{name}: it hands the work to {', '.join(result['delegates'])} instead of computing the step"
                       " itself. The exercise is to write it: use only q, v, m, force and dt (and numpy).")

    data = arrays[name]
    mine = data["outputs"]
    if result["modified"]:
        changed = " and ".join(result["modified"])
        return False, (f"{name}: it changes the {changed} array it was given (an in-place update such as"
                       f" `{result['modified'][0]} += ...`), so the caller's state is overwritten. Compute new arrays"
                       f" (q_next = q + ...) and leave q and v as they came in.")
    right = agrees(mine, on_probes(reference))
    factor, measured = order(data, "heavy_damped_spring", ORDER_DTS[name])
    figures = {"orbit_band": f"orbit energy band {band(data, 2000):.3e} after 2,000 steps,"
                             f" {band(data, 8000):.3e} after 8,000",
               "orbit_energy": f"On the orbit its energy error is {band(data, 2000):.1%} after the chapter's 2,000"
                               f" steps and {band(data, 8000):.1%} after 8,000, and keeps climbing."}
    if right.all():
        what = (f"on the orbit its energy stays in a band (worst excursion {band(data, 2000):.3e} after 2,000 steps,"
                f" {band(data, 8000):.3e} after 8,000)" if name == "semi_implicit_step" else
                f"on the orbit its energy error is {band(data, 2000):.1e} after 2,000 steps")
        return True, (f"{name}: solved. Same numbers as the engine's {method} from {len(PROBES)} states of"
                      f" {len(ex2_cases.CASES)} systems (masses 1, 2.5 and 0.7; forces with and without velocity);"
                      f" {what}; on a damped spring, whose exact motion is known, it closes in on the true motion"
                      " as fast as the engine's when dt shrinks (how fast is exercise 3's question).")
    for variant, message in SEMI_MISTAKES if name == "semi_implicit_step" else RK4_MISTAKES:
        if agrees(mine, on_probes(variant)).all():
            return False, f"{name}: {message.format(**figures)}"
    scaled = step_scale(mine, on_probes(reference))
    if scaled is not None:
        return False, f"{name}: {scale_sentence(name, method, *scaled)}"
    if agrees(mine[:, ::-1], on_probes(reference)).all():
        return False, (f"{name}: your numbers are right but returned in the wrong order, (v_next, q_next). The engine"
                       " unpacks q_next, v_next = step(...): return the position first.")
    return False, f"{name}: {unrecognised(name, data, right, factor, measured)}"


def unrecognised(name: str, data: dict, right: np.ndarray, factor: float, measured: float) -> str:
    """A mistake nobody listed: say what the numbers show, case by case."""
    method, reference, nominal_order, nominal_calls = EXPECTED[name]
    mine, calls = data["outputs"], data["force_calls"]
    if not np.isfinite(mine).all():
        bad = PROBES[int(np.argmin(np.isfinite(mine).reshape(len(mine), -1).all(axis=1)))]
        return (f"it returns inf or NaN after one step of {bad['dt']} s on {ex2_cases.CASES[bad['case']][0]}, from"
                f" q = {bad['q']}, v = {bad['v']}. Look for a division that can be by zero, or a sign that sends"
                " the state the wrong way.")
    if (calls == 0).all():
        return ("it never calls force, so its acceleration does not come from the system it is given: it cannot be"
                " right on the checker's systems (orbits, springs, a damped spring). Get the force with force(q, v)"
                " and divide by m.")
    by_case = {case: bool(right[[p["case"] == case for p in PROBES]].all()) for case in ex2_cases.CASES}
    seen = []
    theirs = on_probes(reference)
    off = float(np.max(np.abs(mine - theirs) / np.maximum(1.0, np.abs(theirs))))
    if off < 1e-3 and abs(measured - nominal_order) < 0.5:  # right order, a few digits off: rounding, not a method
        seen.append(f"Its numbers are close to {method}'s but not equal: they agree to about {-math.log10(off):.0f}"
                    " digits, where the same arithmetic agrees to 15. "
                    + ("Is a constant rounded (0.1667 for 1/6, 0.33 for 1/3), or is the arithmetic in single"
                       " precision (float32)?" if name == "rk4_step" else
                       "Is the arithmetic in single precision (float32), or a number rounded somewhere?"))
    if by_case["spring"] and not by_case["orbit"]:
        seen.append("It is right on the chapter's spring only: does it compute a force of its own (like -4 q)"
                    " instead of using force(q, v)?")
    elif all(by_case[c] for c in ex2_cases.MASS_ONE) and not all(by_case.values()):
        seen.append("It is right whenever m = 1 and wrong when m is 2.5 or 0.7: look at every place a force"
                    " becomes an acceleration (force / m, once).")
    elif all(by_case[c] for c in ex2_cases.VELOCITY_FREE) and not all(by_case.values()):
        seen.append("It is right when the force ignores velocity and wrong on the damped spring and the orbit with"
                    " drag: look at which velocity you hand to force(q, v), stage by stage.")
    elif not any(by_case.values()):
        seen.append(f"It differs from {method} on every system, the chapter's spring included.")
    else:
        wrong = [ex2_cases.CASES[c][0] for c, ok in by_case.items() if not ok]
        seen.append(f"It differs from {method} on {'; '.join(wrong)}.")
    q_right, v_right = agrees(mine[:, :1], theirs[:, :1]), agrees(mine[:, 1:], theirs[:, 1:])
    if q_right.all() and not v_right.all():
        seen.append("Its q_next is right; its v_next is not.")
    elif v_right.all() and not q_right.all():
        seen.append("Its v_next is right; its q_next is not.")
    typical = int(np.median(calls))
    if typical != nominal_calls:
        seen.append(f"It calls force {typical} time{'s' * (typical != 1)} per step; {method} calls it {nominal_calls}.")
    if math.isfinite(measured) and measured < 0.3:
        seen.append(f"On the damped spring (exact motion known) halving dt leaves its error where it was (divided by"
                    f" {factor:.2f}): it does not converge to the true motion, whatever dt; {method}'s error shrinks"
                    " with dt. Look for a sign, a term that is missing its dt, or a term too many"
                    f"{', or a weight in the final blend' if name == 'rk4_step' else ''}.")
    elif math.isfinite(measured):
        seen.append(f"On the damped spring (exact motion known) its error behaves like order {measured:.2f};"
                    f" {method} is order {nominal_order}.")
    else:
        seen.append("On the damped spring its error does not shrink when dt halves: it does not converge to the"
                    " motion at all. Is dt where it belongs in every update?")
    heavy, heavy_order = order(data, "heavy_spring", ORDER_DTS[name])
    if name == "semi_implicit_step" and 1.7 < heavy_order < 2.4:
        return ("this is a second-order method (velocity Verlet, leapfrog, or a cousin: a half kick, a drift and a"
                f" half kick, or the force averaged over the step): halving dt divides its error by {heavy:.1f}"
                " on a spring. A fine integrator, but not MuJoCo's mjINT_EULER, which is first order: one full"
                " kick v_next = v + dt * force(q, v) / m, then one drift q_next = q + dt * v_next.")
    if name == "rk4_step" and 3.7 < heavy_order < 4.4:
        seen.insert(0, "It is fourth order (halving dt divides its error by"
                       f" {heavy:.1f} on a spring), but it is not the classical RK4.")
    elif name == "rk4_step" and 1.7 < heavy_order < 2.4 and typical == nominal_calls:
        seen.insert(0, "It samples four slopes but comes out second order (halving dt divides its error by"
                       f" {heavy:.1f} on a spring): the slopes are probably fine and the blend is not. RK4 weights"
                       " them 1-2-2-1 over 6: the two midpoint slopes count double, the end slopes once.")
    return f"not {method} yet, and not one of the usual mistakes. What the checker measured: " + " ".join(seen)


def step_scale(mine: np.ndarray, theirs: np.ndarray) -> tuple[float, int] | None:
    """(s, k) if every probe's change (q_next - q, v_next - v) is s * dt^k times the reference's, s * dt^k != 1.

    k = 0: the weights of the final blend add up to s; k = 1: dt is in there twice; k = -1: dt is missing."""
    start = np.array([[p["q"], p["v"]] for p in PROBES])
    dts = np.array([p["dt"] for p in PROBES])
    mine_change, their_change = (mine - start).reshape(len(mine), -1), (theirs - start).reshape(len(mine), -1)
    with np.errstate(all="ignore"):
        ratios = (mine_change * their_change).sum(axis=1) / (their_change * their_change).sum(axis=1)
        if not np.allclose(mine_change, ratios[:, None] * their_change, rtol=1e-7, atol=1e-12):
            return None
        for k in (0, 1, -1):
            s = ratios / dts**k
            if np.ptp(s) <= 1e-7 * abs(s.mean()) and not (k == 0 and abs(s.mean() - 1) < 1e-6):
                return float(s.mean()), k
    return None


def scale_sentence(name: str, method: str, s: float, k: int) -> str:
    """Every change the step makes is s * dt^k times the method's: say what that means."""
    if k == 1:
        times = "dt" if abs(s - 1) < 1e-6 else f"{s:.4g} dt"
        return (f"every change your step makes is {times} times {method}'s: dt multiplies your update twice."
                " A slope times dt is a change; multiply by dt once.")
    if k == -1:
        times = f", times {s:.4g}" if abs(s - 1) > 1e-6 else ""
        return (f"every change your step makes is {method}'s divided by dt{times}: dt is missing from your update."
                " A slope is a rate; multiply it by dt to get a change.")
    if abs(s - 1) < 0.01:  # a hair off on every system: a constant written as a rounded decimal
        return (f"every change your step makes is {s:.6g} times {method}'s, on every system: close to 1, but not 1."
                " Is a fraction written as a rounded decimal (0.1667 for 1/6, 0.333 for 1/3)? Write it as a"
                " division, dt / 6, and the numbers come out exact.")
    if name == "rk4_step":
        return (f"every change your step makes is {s:.4g} times RK4's, on every system: the weights of your final"
                f" blend add up to {s:.4g}, not 1. (k1 + 2 k2 + 2 k3 + k4) counts six slopes, so it is multiplied"
                " by dt/6; dt/4 would make the weights add up to 1.5, dt/3 to 2.")
    return (f"every change your step makes is {s:.4g} times {method}'s, on every system: is there an extra factor"
            " in your updates? Each is the old value plus dt times its rate.")


def exception_sentence(error: dict, name: str | None = None) -> str:
    """'rk4_step raised ZeroDivisionError: ... at your_file.py line 31: `k2 = ...`'."""
    if "line" in error:
        where = f" in {error['function']}(), {Path(error['file']).name} line {error['line']}: {error['code'].strip()}"
    else:
        where = " (inside Python or numpy, called from your code)"
    if error["type"] == "SystemExit":
        return (f"your code calls sys.exit() or exit() ({error['message']}){where}. That would end the whole"
                " program; a step only returns (q_next, v_next).")
    what = f"{error['type']}: {error['message']}" if error["message"] else error["type"]
    hint = ""
    if "object is not callable" in error["message"] and "float" in error["message"]:
        hint = " A number is being called like a function: are the parameters in the order (q, v, m, force, dt)?"
    return f"{'it ' if name else ''}raised {what}{where}.{hint}"


def stopped_sentence(stopped: str | None, printed: int = 0) -> str:
    how, _, stage = (stopped or "exit|start").partition("|")
    where = describe_stage(stage)
    if how == "timeout":
        if where == describe_stage("import"):
            return (f"importing your file did not finish within {TIME_LIMIT:.0f} s. Code at the top level of a file"
                    " runs when it is imported: put trial runs under `if __name__ == \"__main__\":`, and look for a"
                    " loop that never ends.")
        if printed > 10_000:
            return (f"stopped after {TIME_LIMIT:.0f} s {where}, still printing ({printed:,} lines so far). Printing"
                    " is slow, and the checker takes thousands of steps: take the prints out of your step.")
        if " run " in f" {stage} ":
            return (f"stopped after {TIME_LIMIT:.0f} s {where}: every single step returned, but the thousands of steps"
                    " of a whole run did not finish in time. One step should take well under a millisecond: is"
                    " there a slow loop, a sleep or a print in it?")
        return (f"stopped after {TIME_LIMIT:.0f} s {where} without returning. Is there a loop that never ends"
                " (a `while` whose condition never turns false)? One step should take well under a millisecond.")
    code = how.split()[-1]
    return (f"the checker's run of your file ended by itself (exit code {code}) {where}. Does your code call"
            " os._exit(), or crash Python? A step should only return (q_next, v_next).")


def describe_stage(stage: str) -> str:
    words = stage.split()
    if not words or words[0] in ("start", "import"):
        return "while your file was being imported"
    if len(words) >= 4 and words[1] == "probe":
        return f"during one step on {ex2_cases.CASES[words[3]][0]}"
    if len(words) >= 4 and words[1] == "run":
        return f"while running a trajectory on {ex2_cases.CASES[words[3]][0]}"
    return "while it ran"


# --- the command ---


def check(path: Path) -> tuple[bool, list[str], list[str], int]:
    """(all solved, one message per function, first lines the student's code printed, how many it printed)."""
    problem = unreadable(path)
    if problem:
        return False, [problem[1]], [], 0
    messages, solved, printed, count = {}, True, [], 0
    pending = list(FUNCTIONS)
    while pending:
        report, arrays, shown, lines, stopped = run_child(path, pending)
        printed, count = printed + shown[: SHOWN_OUTPUT_LINES - len(printed)], count + lines
        done = [name for name in pending if name in report or "import" in report]
        for name in done:
            ok, messages[name] = judge(name, report, arrays, stopped)
            solved &= ok
        if stopped and len(done) < len(pending):
            # the function that was running is the one stopped; if it was the import, every function is
            stage = stopped.partition("|")[2].split()
            stuck = pending[len(done):] if not stage or stage[0] in ("start", "import") else [pending[len(done)]]
            for name in stuck:
                messages[name] = judge(name, report, arrays, stopped, lines)[1]
            solved = False
            done += stuck
        pending = [name for name in pending if name not in done]
    return solved, [messages[name] for name in FUNCTIONS], printed, count


def main(argv=None) -> int:
    parser = OneLineParser(prog="python -m exercises.check_ex2", description=__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file", nargs="?", type=Path, default=DEFAULT_FILE,
                        help="your .py file with semi_implicit_step and rk4_step"
                             " (default: exercises/ex2_integrators.py)")
    args = parser.parse_args(argv)
    problem = unreadable(args.file)
    if problem and problem[0] == 2:
        parser.exit(2, f"{parser.prog}: error: {problem[1]}\n")
    solved, messages, printed, count = check(args.file)
    if count:
        print(f"Your code printed {count:,} line{'s' * (count != 1)} while it was checked"
              + (f"; the first {len(printed)}:" if count > len(printed) else ":"))
        for line in printed:
            print(f"  | {line}")
        print()
    if problem:  # the file does not compile: the sentence, then the line as it is in the file, no traceback
        sentence, _, code = messages[0].partition("\n")
        explain(sentence)
        print(code)
    else:
        explain(*messages)
    print("\nAll solved." if solved else "\nNot solved yet: read the messages above, edit, and run the checker again.")
    return 0 if solved else 1


if __name__ == "__main__":
    try:
        sys.exit(main())
    except BrokenPipeError:  # piped into `head`, which stopped reading: not an error worth a traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(1)
