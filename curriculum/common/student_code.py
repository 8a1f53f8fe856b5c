"""Run a student's file where it cannot decide the verdict: the harness of every chapter's code exercise.

    problem = source_problem(path)  # (exit code, sentence) if it cannot be checked; runs none of it
    run = collect(path, "exercises.support.ex2_cases", tasks, prog="python -m exercises.check_ex2")

The file runs in a child Python in a session of its own (-s -P, PYTHONHASHSEED=0: one verdict per file), its
folder on sys.path after the standard library; the child hands each task to collector.collect(module, task) and
sends the answers as JSON lines on a pipe. Its prints go to a sink that keeps the first few kB and only counts the
rest. However the checker ends (a signal is the guard's one line, SIGKILL too), a sentinel the child forks sees
the checker's end of a pipe close, kills the child's process group and removes its scratch folder. A task that
never ends costs its group; the others run again in a new child.
"""

import argparse
import ast
import builtins
import contextlib
import importlib
import importlib.util
import io
import json
import os
import select
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import textwrap
import time
import tokenize
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from curriculum.common import interrupts
from curriculum.common.cli import shown
from curriculum.common.outputs import OutputError, one_line_failures

REPO = Path(__file__).resolve().parents[2]
MAX_SOURCE_BYTES = 1_000_000  # a file of a few functions is a few kB; past this it is not the student's file
KEPT_OUTPUT_BYTES = 4096  # of what the student's code prints: enough to show, bounded whatever it does
MAX_ANSWER_BYTES = 64_000_000  # what the child may send back; past this the run counts as malformed
DONE = b'{"done": true}\n'  # the child's last answer
PHASES = (b'{"stage": "import"}', b'{"stage": "tasks"}')  # each starts the time limit afresh
CHILD = "import sys; sys.path.append(sys.argv[2]); from curriculum.common.student_code import _child; _child()"


# --- before anything runs: a regular, readable, compiling Python file ---


def source_problem(path: Path) -> tuple[int, str] | None:
    """(exit code, sentence) if `path` cannot be checked: 2 if it is not a Python source file, 1 if it does not
    compile (the sentence then ends with the line and a caret). None if it can. Runs none of its code."""
    where, name = shown(path, 100), shown(path.name, 60)
    try:
        info = path.stat()
        if stat.S_ISDIR(info.st_mode):
            return 2, f"{where} is a folder; give the .py file itself"
        if not stat.S_ISREG(info.st_mode):  # a FIFO or a device: reading it could block forever
            return 2, f"{where} is not a regular file (it is a pipe or a device); give the .py file itself"
        if path.suffix != ".py":
            if path.suffix.lower() == ".py":
                return 2, f"{name} ends in {shown(path.suffix)}: Python imports only files ending in .py: rename it"
            return 2, f"{name} is not a Python file: the checker imports it, so it must end in .py"
        if info.st_size > MAX_SOURCE_BYTES:
            return 2, f"{where} is {info.st_size / 1e6:,.0f} MB; a file of a few functions is a few kB. Is it the" \
                      " right file?"
        data = path.read_bytes()
    except FileNotFoundError:
        return 2, f"there is no file {where}"
    except OSError as error:
        return 2, f"cannot read {where}: {error.strerror}"
    if b"\0" in data:
        line = data[: data.index(b"\0")].count(b"\n") + 1
        return 1, (f"{where}, line {line}: the file contains a null byte (\\0), which Python source cannot hold;"
                   " it was probably saved by a word processor. Save it as plain text.")
    try:
        try:
            encoding = tokenize.detect_encoding(iter(data.splitlines(keepends=True)).__next__)[0]
        except SyntaxError as error:  # not UTF-8 in the first two lines, or a bad `coding:` comment
            data.decode("utf-8")  # raises UnicodeDecodeError with the position if that is the problem
            return 1, f"{where}: {shown(error.msg, None)}"
        source = data.decode(encoding)
    except UnicodeDecodeError as error:
        line = data[: error.start].count(b"\n") + 1
        return 1, f"{where}, line {line}: this line is not valid text (byte {data[error.start]:#04x}); save the file" \
                  " as UTF-8."
    try:
        compile(source, str(path), "exec", dont_inherit=True)
    except SyntaxError as error:  # IndentationError and TabError too
        why = {"TabError": " Indent with spaces only; most editors can turn tabs into spaces.",
               "IndentationError": " The lines of one block must start in the same column."}
        kind, text = type(error).__name__, (source.splitlines() or [""])[max(0, (error.lineno or 1) - 1)]
        quoted = f"    {shown(text.strip(), None)}"
        if error.offset and text.strip() and kind == "SyntaxError":
            quoted += "\n    " + " " * max(0, error.offset - 1 - (len(text) - len(text.lstrip()))) + "^"
        return 1, f"{where}, line {error.lineno}: {kind}: {shown(error.msg, None)}.{why.get(kind, '')}\n{quoted}"
    return None


def source_notes(path: Path, name: str, parameters: list) -> tuple[str | None, str]:
    """(sentence if the last `def name` changed the given parameters, else None; a note if `name` is defined
    more than once). Read from the source, so nothing runs."""
    defined = [node for node in ast.parse(path.read_bytes()).body
               if isinstance(node, ast.FunctionDef) and node.name == name]
    note = ""
    if len(defined) > 1:
        lines = ", ".join(str(node.lineno) for node in defined)
        note = (f" It is defined {len(defined)} times in your file (lines {lines}): Python keeps the last one, line"
                f" {defined[-1].lineno}, and that is the one checked.")
    given = [a.arg for a in defined[-1].args.posonlyargs + defined[-1].args.args] if defined else parameters
    if given[: len(parameters)] != parameters and (sorted(given) == sorted(parameters) or len(given) < len(parameters)):
        return (f"you changed its signature to {name}({', '.join(given)}). It is called as {name}"
                f"({', '.join(parameters)}), in that order; keep the first line as it was given."), note
    return None, note


class NotOutputs(Exception):
    """What a student's function returned is not what was asked for; the message says what."""


def as_arrays(result, names: tuple, shape: tuple, np) -> tuple:
    """The function's outputs as float arrays of `shape`, one per name, not copied (a reused input shows).
    numpy is passed in: this module imports nothing heavy."""
    wanted = f"({', '.join(names)})"
    if result is None:
        raise NotOutputs(f"returns None: the function ends without returning {wanted}")
    if isinstance(result, np.ndarray) and result.ndim == 1:
        raise NotOutputs(f"returns one array of shape {result.shape}; it must return {len(names)}, {wanted}")
    try:
        values = list(result)
    except TypeError:
        raise NotOutputs(f"returns one {type(result).__name__}, not {wanted}") from None
    if len(values) != len(names):
        raise NotOutputs(f"returns {len(values)} values; it must return {len(names)}, {wanted}")
    arrays = []
    for what, value in zip(names, values, strict=True):
        try:
            arrays.append(np.asarray(value, dtype=float))
        except (TypeError, ValueError):
            raise NotOutputs(f"returns a {what} that is not numbers: {type(value).__name__}") from None
        if arrays[-1].shape != shape:
            raise NotOutputs(f"returns a {what} of shape {arrays[-1].shape}; it must have shape {shape}")
    return tuple(arrays)


# --- the parent: start the child, keep what it says, end it on every path ---


@dataclass
class Run:
    results: dict = field(default_factory=dict)  # task index -> the collector's answer, or {"error": ...}
    stopped: dict = field(default_factory=dict)  # task index -> "time limit", "exit code N" or "crashed (...)"
    imported: dict | None = None  # {"error": ...} if importing the student's file failed
    clashes: list = field(default_factory=list)  # (file beside the student's, the module Python uses instead)
    printed: bytes = b""  # the first KEPT_OUTPUT_BYTES of what the student's code printed
    printed_bytes: int = 0
    prints: int = 0  # print() calls made once the kept bytes were full: counted, never formatted
    malformed: str | None = None  # what was wrong with the child's answers, if they could not be read


def collect(path: Path, collector: str, tasks: list, prog: str, time_limit: float = 20.0) -> Run:
    """Run `tasks` (dicts; "group" names a task's group) on the student's file, in as many children as needed.
    (`prog` names the checker; a signal meanwhile is the guard's one line.)"""
    run, pending, said = Run(), list(range(len(tasks))), interrupts.said()
    interrupts.said("your file's run was stopped and its scratch folder removed")  # what a signal says meanwhile
    try:
        while pending and run.imported is None and run.malformed is None:
            stuck = _one_child(path, collector, tasks, pending, time_limit, run)
            if stuck is None:
                break
            group = tasks[stuck].get("group")  # the stuck task's group is lost; the others get a fresh child
            for i in pending:
                if i not in run.results and (i == stuck or tasks[i].get("group") == group):
                    run.stopped[i] = run.stopped.get(stuck, "")
            pending = [i for i in pending if i not in run.results and i not in run.stopped]
    finally:
        interrupts.said(said)
    return run


def _one_child(path, collector, tasks, pending, time_limit, run) -> int | None:
    """One child for the `pending` tasks. Returns the index of a task it stopped in (time limit or exit), or None."""
    try:
        scratch = tempfile.mkdtemp(prefix="student-code-")
        job = Path(scratch, "job.json")
        job.write_text(json.dumps({"file": str(path.resolve()), "collector": collector,
                                   "tasks": {i: tasks[i] for i in pending}}))
    except OSError as error:
        raise OutputError(f"the checker cannot make its scratch folder in {shown(tempfile.gettempdir(), 100)}"
                          f" ({error.strerror}); free some space there, or set TMPDIR to another folder", 2) from None
    answers_read, answers_write = os.pipe()
    watch_read, watch = os.pipe()  # its closing (our end, or our death by any signal) ends the child's group
    env = {**{k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}, "PYTHONHASHSEED": "0",
           "TMPDIR": scratch}  # -s -P: no user site, nothing from the working folder; the environment's PYTHON* gone
    try:
        child = subprocess.Popen(
            [sys.executable, "-s", "-P", "-B", "-c", CHILD, str(answers_write), str(REPO), str(job), str(watch_read)],
            cwd=scratch, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            pass_fds=(answers_write, watch_read), start_new_session=True)
    except OSError:
        shutil.rmtree(scratch, ignore_errors=True)
        os.close(watch)
        raise
    finally:
        os.close(answers_write)
        os.close(watch_read)
    answers, deadline, phase, ended = bytearray(), time.monotonic() + time_limit, 0, False
    try:
        while not ended and time.monotonic() < deadline and len(answers) <= MAX_ANSWER_BYTES:
            if select.select([answers_read], [], [], 0.01)[0]:
                answers += os.read(answers_read, 1 << 20)
            if phase < len(PHASES) and PHASES[phase] in answers:  # the import, then the tasks: time afresh
                phase, deadline = phase + 1, time.monotonic() + time_limit
            ended = answers.endswith(DONE) or child.poll() is not None  # (its threads may outlive DONE)
        code = child.poll()
    finally:
        _end(child, scratch, watch)
        os.set_blocking(answers_read, False)  # what is left, unless a process that escaped the group holds it
        with contextlib.suppress(OSError):
            while len(answers) <= MAX_ANSWER_BYTES and (chunk := os.read(answers_read, 1 << 20)):
                answers += chunk
        os.close(answers_read)
    return _read_answers(bytes(answers[:MAX_ANSWER_BYTES + 1]), run, pending, ended, code)


def _end(child, scratch: str, watch: int) -> None:
    """Kill the child's process group (all it started, unless it left the group) and remove its scratch folder."""
    os.close(watch)
    with contextlib.suppress(OSError):
        os.killpg(child.pid, signal.SIGKILL)
    child.wait()
    for _ in range(200):  # the group's processes are gone in a moment: SIGKILL cannot be caught
        try:
            os.killpg(child.pid, 0)
        except OSError:
            break
        time.sleep(0.005)
    shutil.rmtree(scratch, ignore_errors=True)


def _read_answers(answers: bytes, run: Run, pending: list, ended: bool, code: int | None) -> int | None:
    """Fill `run` from the child's JSON lines. Returns the task it stopped in, if it did not finish."""
    stage, dropped, prints, printed = None, 0, 0, ""
    try:
        for line in answers.decode().splitlines():
            message = json.loads(line)
            if "stage" in message:
                stage = message["stage"]
            elif "result" in message:
                run.results[int(message["task"])] = dict(message["result"])
            elif "import" in message:
                run.imported = dict(message["import"])
            elif "clashes" in message:
                run.clashes = [(str(a), str(b)) for a, b in message["clashes"]]
            elif "printed" in message:  # the first KEPT_OUTPUT_BYTES of what the student's code printed
                printed += str(message["printed"])
            elif "dropped" in message:  # what the sink counted and did not pass on, so far
                dropped, prints = int(message["dropped"]), int(message.get("prints", 0))
            elif "done" not in message:
                raise ValueError("an answer the checker never asks for")
    except (ValueError, TypeError, KeyError, UnicodeDecodeError) as error:  # a forgery, or a cut-off line
        run.malformed = f"what it sent back could not be read ({type(error).__name__}: {shown(error, 80)})"
        return None
    run.printed = run.printed or printed.encode()  # a second child (after a stuck task) prints the same start again
    run.printed_bytes, run.prints = run.printed_bytes + len(printed.encode()) + dropped, run.prints + prints
    why = "time limit" if not ended else f"exit code {code}"
    if ended and code is not None and code < 0:
        why = f"crashed ({signal.strsignal(-code).lower()}, signal {-code})"
    if stage is None or stage == "import" and run.imported is None:
        if ended and stage is None:
            run.malformed = f"Python stopped before your file was even imported ({why})"
        else:
            run.imported = {"stopped": why}
        return None
    missing = [i for i in pending if i not in run.results]
    if missing:  # stopped in a task (time limit, os._exit, a crash): that task is the one to blame
        stuck = stage if stage in missing else missing[0]
        run.stopped[stuck] = why
        return stuck
    return None


# --- comparing outputs with the reference's (numpy arrays, passed in) ---


def agrees(mine, theirs):
    """Per row: equal up to round-off (1e-9 of the size), so any order of the same arithmetic agrees."""
    import numpy as np  # here, so that importing this module stays light

    with np.errstate(all="ignore"):
        return (np.abs(mine - theirs) <= 1e-9 * np.maximum(1.0, np.abs(theirs))).reshape(len(mine), -1).all(axis=1)


def gaps(mine, theirs):
    """Per row of a run: the largest difference from the reference's, relative to the run's largest value."""
    import numpy as np

    with np.errstate(all="ignore"):
        gap = np.max(np.abs(mine - theirs), axis=1) / max(1.0, float(np.max(np.abs(theirs))))
    return np.where(np.isfinite(gap), gap, np.inf)


# --- sentences ---


def failure_sentence(run: Run, indices: list, where, time_limit: float) -> str | None:
    """The sentence for tasks `indices` of one function if they ended without an answer, else None.
    where(i) says what task i is doing ("during a whole run on ...")."""
    if run.malformed:
        return f"your file's run did not finish: {run.malformed}."
    if run.imported and "error" in run.imported:
        return f"your file stopped while Python was importing it: it {error_sentence(run.imported['error'])}."
    if run.imported:
        flood = f" It printed {run.printed_bytes:,} bytes meanwhile." if run.printed_bytes > 1_000_000 else ""
        if run.imported["stopped"].startswith("crashed"):
            return f"your code {run.imported['stopped']} while Python was importing your file.{flood}"
        if run.imported["stopped"].startswith("exit"):
            return (f"your file ended Python while it was being imported ({run.imported['stopped']}): does it call"
                    f" os._exit() at the top level? Only definitions need to be there.{flood}")
        return (f"importing your file did not finish within {time_limit:.0f} s. Code at the top level runs when a"
                " file is imported: put trial runs under `if __name__ == \"__main__\":`, and look for a loop that"
                f" never ends.{flood}")
    for i in indices:
        stopped, result = run.stopped.get(i), run.results.get(i, {})
        if stopped == "time limit":
            return (f"stopped after {time_limit:.0f} s {where(i)}, without returning. Is there a loop that never ends,"
                    " or a sleep? One call should take well under a millisecond.")
        if stopped and stopped.startswith("crashed"):
            return f"your code {stopped} {where(i)}: Python itself stopped. Does it call os.kill(), os.abort(), ctypes?"
        if stopped:
            return (f"the checker's run of your file ended by itself ({stopped}) {where(i)}. Does your code call"
                    " os._exit(), or crash Python? A function should only return its result.")
        error = result.get("error", {})
        if error.get("type") == "NotImplementedError":
            return "not solved yet. It still raises NotImplementedError: fill in its TODO."
        if error.get("type") == "SystemExit":
            return (f"your code ends Python with sys.exit() or exit() ({error['message']}) {where(i)}: a function"
                    " should only return its result.")
        if error:
            return f"it {error_sentence(error)}."
        if result.get("problem") == "missing":
            return "not found in your file. Keep the function names as they are."
        if "problem" in result:
            return f"your function {shown(result['problem'], 300)}."
    return None


def print_notes(run: Run) -> None:
    """What the student's code printed (the start of it) and any module clash, before the verdicts."""
    if run.printed_bytes or run.prints:
        lines = run.printed.decode("utf-8", "replace").splitlines()[:8]
        more = f" and called print() {run.prints:,} times more" if run.prints else ""
        print(f"Your code printed {run.printed_bytes:,} bytes{more} while it was checked; the start:")
        print("\n".join(f"  | {shown(line, 200)}" for line in lines) + "\n")
    if run.clashes:
        print(textwrap.fill(clash_sentence(run.clashes), width=100) + "\n")


def error_sentence(error: dict) -> str:
    """'raised ZeroDivisionError: float division by zero in rk4_step(), line 31 of mine.py: k2 = ...'."""
    what = shown(f"{error['type']}: {error['message']}" if error["message"] else error["type"], 300)
    if "line" not in error:
        return f"raised {what} (inside Python or numpy, called from your code)"
    return (f"raised {what} in {shown(error['function'])}(), line {error['line']} of {shown(error['file'], 60)}:"
            f" {shown(error['code'], 200)}")


def clash_sentence(clashes: list) -> str:
    return " ".join(f"{shown(file)} beside your file has the name of {module}, which Python imports first; `import"
                    f" {shown(Path(file).stem)}` gets that one, never yours. Rename yours." for file, module in clashes)


# --- the command of a chapter's checker ---


def main(prog: str, doc: str, default: Path, what: str, check, argv=None) -> int:
    """`prog [FILE]`: check(path) -> ({function: solved}, messages, run) for a file that compiles; 0 solved, 1 not,
    2 unusable. Each check goes to the journal (journal.checked), and the run ends with its "Next:" line."""
    return one_line_failures(prog)(_main)(prog, doc, default, what, check, argv)


def _main(prog: str, doc: str, default: Path, what: str, check, argv) -> int:
    from curriculum.common.cli import OneLineParser
    from curriculum.common.journal import checked
    from curriculum.common.predict import explain

    parser = OneLineParser(prog=prog, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file", nargs="?", type=Path, default=default,
                        help=f"{what} (default: {default.parent.name}/{default.name})")
    args = parser.parse_args(argv)
    problem = source_problem(args.file)
    if problem and problem[0] == 2:
        parser.exit(2, f"{prog}: error: {problem[1]}\n")
    if problem:  # does not compile: the sentence, then the line as it is in the file
        sentence, _, code = problem[1].partition("\n")
        explain(sentence)
        print(code + "\n\nNot solved yet: fix that line, and run the checker again.")
        checked(default, args.file, {})
        return 1
    parts, messages, run = check(args.file)
    print_notes(run)
    explain(*messages)
    solved = all(parts.values())
    print("\nAll solved." if solved else "\nNot solved yet: read the messages above, edit, and run it again.")
    checked(default, args.file, parts)
    return 0 if solved else 1


# --- the child, run as `python -s -P -B -c CHILD FD REPO JOB PARENT` ---


class _Sink(io.TextIOBase):
    """The student's sys.stdout and sys.stderr: the first KEPT_OUTPUT_BYTES go to the checker as answers, the rest
    are only counted (said every megabyte, and at the end). Once it is full, print() to it only counts the call:
    formatting arrays costs more than the step, so a print in every call would decide the verdict."""

    encoding = "utf-8"

    def __init__(self, send):
        super().__init__()
        self.send, self.passed, self.dropped, self.prints, self.print = send, 0, 0, 0, builtins.print
        builtins.print = self.counted

    def counted(self, *args, file=None, **kwargs):
        if file in (None, self) and self.passed >= KEPT_OUTPUT_BYTES:
            self.prints += 1
        else:
            self.print(*args, file=file, **kwargs)

    def write(self, text) -> int:
        data = str(text).encode("utf-8", "backslashreplace")
        room = min(len(data), max(0, KEPT_OUTPUT_BYTES - self.passed))
        if room:
            self.passed += room
            self.send({"printed": data[:room].decode("utf-8", "ignore")})
        before, self.dropped = self.dropped, self.dropped + len(data) - room
        if self.dropped >> 20 != before >> 20:
            self.send({"dropped": self.dropped})
        return len(text)


def _child() -> None:
    answers_fd, _, job_file, watch = sys.argv[1:]  # the answers' pipe first, as before
    group, scratch = os.getpid(), os.getcwd()
    if os.fork() == 0:  # a sentinel, in a group of its own: when the checker's end of `watch` closes (it is done,
        os.setpgid(0, 0)  # or any signal ended it, SIGKILL too), it ends our group, all we started, and removes
        os.chdir("/")  # the scratch folder
        os.read(int(watch), 1)
        os.killpg(group, signal.SIGKILL)
        shutil.rmtree(scratch, ignore_errors=True)
        os._exit(0)
    os.close(int(watch))
    job, answers = json.loads(Path(job_file).read_text()), os.fdopen(int(answers_fd), "w", buffering=1)

    def send(message):
        answers.write(json.dumps(message) + "\n")

    sys.stdout = sys.stderr = sink = _Sink(send)
    student = Path(job["file"])
    sys.path.append(str(student.parent))  # after the standard library and site-packages
    collector = importlib.import_module(job["collector"])
    course = {os.path.realpath(m.__file__) for m in list(sys.modules.values()) if getattr(m, "__file__", None)}
    send({"clashes": _clashes(student, course)})
    send({"stage": "import"})
    try:
        spec = importlib.util.spec_from_file_location("student", student)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except BaseException as error:  # noqa: BLE001 (SystemExit too: reported, not obeyed)
        send({"import": {"error": _described(error, student, course)}})
        module = None
    if module is not None:
        send({"stage": "tasks"})
        for index, task in job["tasks"].items():
            send({"stage": int(index)})
            try:
                result = collector.collect(module, task)
            except BaseException as error:  # noqa: BLE001
                result = {"error": _described(error, student, course)}
            send({"task": int(index), "result": result})
    send({"dropped": sink.dropped, "prints": sink.prints})
    answers.write(DONE.decode())
    answers.flush()
    os._exit(0)  # the student's threads and exit handlers do not run on


def _clashes(student: Path, course: set) -> list:
    """Modules beside the student's file whose name Python finds elsewhere first (threading.py, random.py)."""
    found = []
    for file in sorted(student.parent.glob("*.py")):
        if file == student or not file.stem.isidentifier() or os.path.realpath(file) in course:
            continue
        try:
            spec = importlib.util.find_spec(file.stem)
        except (ImportError, ValueError):
            continue
        if spec and spec.origin and Path(spec.origin).parent != student.parent:
            kind = "Python's standard module" if file.stem in sys.stdlib_module_names else "the installed module"
            found.append((file.name, f"{kind} {file.stem}"))
    return found


def _described(error: BaseException, student: Path, course: set) -> dict:
    """The exception in one line, and the deepest line it passed through in the student's own code: the
    student's file, or a helper in its folder that is not one of the course's modules."""
    folder = str(student.parent.resolve()) + os.sep
    mine = [f for f in traceback.extract_tb(error.__traceback__)
            if os.path.realpath(f.filename) == str(student.resolve())
            or (os.path.realpath(f.filename).startswith(folder) and os.path.realpath(f.filename) not in course)]
    message = f"exit code {error.code}" if isinstance(error, SystemExit) else str(error)
    described = {"type": type(error).__name__, "message": message[:300]}
    if mine:
        where = mine[-1]
        described.update(file=Path(where.filename).name, line=where.lineno, code=(where.line or "").strip(),
                         function=where.name)
    return described
