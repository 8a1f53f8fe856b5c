"""check_ex2's child process: runs a student's steps and writes down the numbers. It judges nothing.

    python exercises/support/ex2_child.py JOB.json OUT_DIR

The checker (the parent) starts this in a fresh interpreter with a time limit, so nothing the
student's file does (sys.exit, os._exit, patching `engine`, an endless loop, a flood of prints)
can reach the verdict: the parent compares the numbers written here with its own references.
What is written to OUT_DIR:
    status.txt       one line per stage started ("import", "<function> probe 3", ...): where a hang was
    report.json      per function: an error (with the line in the student's file) or the counts below
    <function>.npz   probe outputs, force calls per probe, and the runs' histories
"""

import importlib.util
import inspect
import json
import os
import sys
import traceback
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
EXPECTED_PARAMETERS = ("q", "v", "m", "force", "dt")


class StepProblem(Exception):
    """The student's step did something the checker cannot use; the message says what."""


def main(job_path: str, out_dir: str) -> int:
    job = json.loads(Path(job_path).read_text())
    out = Path(out_dir)
    status = open(out / "status.txt", "a", buffering=1)  # line-buffered: the parent reads it after a kill
    student_file = Path(job["file"]).resolve()
    sys.path.insert(0, str(REPO))

    import numpy as np

    from exercises.support import ex2_cases  # before the student's folder joins the path: nothing there shadows it

    sys.path.insert(0, str(student_file.parent))  # the student's own helper modules import as they would at home

    np.seterr(all="ignore")  # a diverging student step is measured, not warned about
    warnings.simplefilter("ignore")
    delegation = DelegationWatch(student_file, (REPO / "engine.py").resolve(), REPO / "exercises" / "solutions")
    report = {}

    def write_report():
        (out / "report.json.partial").write_text(json.dumps(report))
        os.replace(out / "report.json.partial", out / "report.json")

    status.write("import\n")
    try:
        spec = importlib.util.spec_from_file_location("student_ex2", student_file)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except BaseException as error:  # noqa: BLE001 (SystemExit too: the student's exit is reported, not obeyed)
        report["import"] = describe_exception(error, student_file)
        write_report()
        return 0

    for name in job["functions"]:
        status.write(f"{name} start\n")
        try:
            report[name] = run_function(module, name, job, ex2_cases, delegation, status, out, np)
        except StepProblem as problem:
            report[name] = {"error": str(problem)}
        except BaseException as error:  # noqa: BLE001
            report[name] = {"exception": describe_exception(error, student_file), "stage": current_stage(out)}
        write_report()
    return 0


def run_function(module, name, job, ex2_cases, delegation, status, out, np) -> dict:
    step = getattr(module, name, None)
    if step is None:
        raise StepProblem("missing")
    if not callable(step):
        raise StepProblem(f"not a function: it is {type(step).__name__}")
    signature_problem = check_signature(step)
    if signature_problem:
        return {"signature": signature_problem}

    probes = job["probes"]
    outputs = np.full((len(probes), 2, 3), np.nan)
    calls = np.zeros(len(probes), dtype=int)
    modified = []
    for i, probe in enumerate(probes):
        status.write(f"{name} probe {i} {probe['case']}\n")
        force = CountingForce(ex2_cases.force_law(probe["case"]))
        q, v = np.array(probe["q"]), np.array(probe["v"])
        q_given, v_given = q.copy(), v.copy()
        with delegation:
            result = step(q, v, ex2_cases.mass(probe["case"]), force, probe["dt"])
        if delegation.calls:
            return {"delegates": sorted(delegation.calls)}
        outputs[i] = as_state(result, np)
        calls[i] = force.calls
        if not (np.array_equal(q, q_given) and np.array_equal(v, v_given)):
            modified.append("q" if not np.array_equal(q, q_given) else "v")

    arrays = {"outputs": outputs, "force_calls": calls}
    for j, run in enumerate(job["runs"][name]):
        status.write(f"{name} run {j} {run['case']} dt {run['dt']}\n")
        force, m, dt = ex2_cases.force_law(run["case"]), ex2_cases.mass(run["case"]), run["dt"]
        q, v = np.array(run["q0"]), np.array(run["v0"])
        positions, velocities = np.empty((run["steps"] + 1, 3)), np.empty((run["steps"] + 1, 3))
        positions[0], velocities[0] = q, v
        for k in range(1, run["steps"] + 1):
            q, v = as_state(step(q, v, m, force, dt), np)
            positions[k], velocities[k] = q, v
        arrays[f"run{j}_q"], arrays[f"run{j}_v"] = positions, velocities
    np.savez(out / f"{name}.npz", **arrays)
    return {"modified": sorted(set(modified))}


def check_signature(step) -> str | None:
    """None if step can be called as step(q, v, m, force, dt); else what the student's signature is."""
    try:
        parameters = list(inspect.signature(step).parameters.values())
    except (TypeError, ValueError):
        return None
    names = tuple(p.name for p in parameters)
    positional = [p for p in parameters if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    takes_rest = any(p.kind == p.VAR_POSITIONAL for p in parameters)
    required = [p for p in positional if p.default is p.empty]
    fits = (len(positional) >= 5 or takes_rest) and len(required) <= 5
    reordered = sorted(names) == sorted(EXPECTED_PARAMETERS) and names != EXPECTED_PARAMETERS
    if fits and not reordered:
        return None
    return f"({', '.join(names)})"


def as_state(result, np):  # numpy is passed in: it is imported after sys.path is set
    """The step's return value as two float arrays of shape (3,); StepProblem with a sentence if it is not."""
    if result is None:
        raise StepProblem("returns None: the function ends without `return q_next, v_next`")
    if isinstance(result, np.ndarray) and result.ndim == 1:
        hint = " (for a stacked state y, return y[:3], y[3:])" if result.shape == (6,) else ""
        raise StepProblem(f"returns one array of shape {result.shape}; it must return two, (q_next, v_next){hint}")
    try:
        pair = list(result)
    except TypeError:
        raise StepProblem(f"returns one {type(result).__name__}, not a pair (q_next, v_next)") from None
    if len(pair) != 2:
        raise StepProblem(f"returns {len(pair)} values; it must return two, (q_next, v_next)")
    state = []
    for what, value in zip(("q_next", "v_next"), pair, strict=True):
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise StepProblem(f"returns a {what} that is not numbers: {type(value).__name__}") from None
        if array.shape != (3,):
            raise StepProblem(f"returns a {what} of shape {array.shape}; a state here has shape (3,)")
        state.append(array)
    return state


class CountingForce:
    """The case's force law, counting how often the step asks for it."""

    def __init__(self, force):
        self.force, self.calls = force, 0

    def __call__(self, q, v):
        self.calls += 1
        return self.force(q, v)


class DelegationWatch:
    """While active, notes every call into engine.py's steps or exercises/solutions/ (not the student's own file).

    It watches what runs, not what is imported, so an alias or a copy of the module object is caught too.
    """

    def __init__(self, student_file: Path, engine_file: Path, solutions: Path):
        self.student_file, self.engine_file, self.solutions = str(student_file), str(engine_file), str(solutions)
        self.calls = set()

    def __enter__(self):
        self.calls.clear()
        sys.settrace(self.trace)

    def __exit__(self, *exc):
        sys.settrace(None)

    def trace(self, frame, event, arg):
        if event == "call":
            code = frame.f_code
            file = os.path.realpath(code.co_filename)
            if file != self.student_file:
                if file == self.engine_file and (code.co_name.endswith("_step") or code.co_name in ("simulate", "run")):
                    self.calls.add(f"engine.{code.co_name}")
                elif file.startswith(self.solutions + os.sep):
                    self.calls.add(f"exercises/solutions/{Path(file).name}: {code.co_name}")
        return None


def describe_exception(error: BaseException, student_file: Path) -> dict:
    """The exception in one line, and the deepest line of the student's own code it passed through."""
    folder = str(student_file.parent)
    frames = [f for f in traceback.extract_tb(error.__traceback__)
              if os.path.realpath(f.filename).startswith(folder + os.sep)]
    where = frames[-1] if frames else None
    described = {"type": type(error).__name__, "message": str(error)}
    if isinstance(error, SystemExit):
        described["message"] = f"exit code {error.code}"
    if where is not None:
        described.update(file=where.filename, line=where.lineno, code=where.line or "", function=where.name)
    return described


def current_stage(out: Path) -> str:
    lines = (out / "status.txt").read_text().splitlines()
    return lines[-1] if lines else ""


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
