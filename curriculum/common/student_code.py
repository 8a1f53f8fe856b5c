"""Run a student's file where it cannot decide the verdict: the harness of every chapter's code exercise.

    problem = source_problem(path)             # (exit code, sentence) if it cannot be checked; runs none of it
    run = collect(path, "exercises.support.ex2_cases", tasks, prog="python -m exercises.check_ex2")
    run.results[i]                             # the collector's answer to tasks[i], or {"error": ...}
    error_sentence(run.results[i]["error"])    # '... raised ZeroDivisionError ... in f(), line 9 of x.py: ...'

The file runs in a child Python in isolated mode (-I), its folder on sys.path after the standard library,
so a scratch `threading.py` beside it cannot replace Python's own. The child imports the chapter's
collector first, then the student's file, then hands each task to collector.collect(module, task) and
sends the answers back as JSON lines on a pipe of its own; the student's prints go to another pipe, of
which a bounded amount is kept. Start-up, the import and the tasks each get the time limit. The child
runs in a scratch folder (its working directory and TMPDIR) under a keeper, a process of ours that runs
none of the student's code, is the subreaper of all the child starts (Linux), and holds our pipe: on
every way the checker ends (normal end, time limit, Ctrl-C, SIGTERM, SIGHUP, SIGQUIT, SIGKILL) the pipe
closes, and the keeper kills every one of those processes and removes the folder. A task that never ends
costs its group: the other groups' tasks run again in a fresh child, so one endless loop does not hide
the verdict on another function.
"""

import argparse
import ast
import contextlib
import ctypes
import importlib
import importlib.util
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
import threading
import time
import tokenize
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from curriculum.common.cli import shown
from curriculum.common.interrupts import say
from curriculum.common.outputs import OutputError, one_line_failures

REPO = Path(__file__).resolve().parents[2]
MAX_SOURCE_BYTES = 1_000_000  # a file of a few functions is a few kB; past this it is not the student's file
KEPT_OUTPUT_BYTES = 4096  # of what the student's code prints: enough to show, bounded whatever it does
MAX_ANSWER_BYTES = 64_000_000  # what the child may send back; past this the run counts as malformed
STOPS = {signal.SIGINT: ("interrupted", 130), signal.SIGTERM: ("terminated", 143), signal.SIGHUP: ("hung up", 129),
         signal.SIGQUIT: ("quit", 131)}  # the signals that end the checker in one line, and how
DONE = b'{"done": true}\n'  # the child's last answer
PHASES = (b'{"stage": "import"}', b'{"stage": "tasks"}')  # each starts the time limit afresh
KEEPER = f"import sys; sys.path.append({str(REPO)!r}); from curriculum.common.student_code import _keeper;" \
         " _keeper(int(sys.argv[1]))"
PR_SET_PDEATHSIG, PR_SET_CHILD_SUBREAPER = 1, 36  # Linux's prctl(2) options
_active = {}  # the running keeper, for the signal handler


# --- before anything runs: a regular, readable, compiling Python file ---


def source_problem(path: Path) -> tuple[int, str] | None:
    """(exit code, sentence) if `path` cannot be checked: 2 if it is not a Python source file, 1 if it does
    not compile (the sentence then ends with the line and a caret). None if it can. Runs none of its code."""
    where, name = shown(path, 100), shown(path.name, 60)  # as the sentences show them
    try:
        info = path.stat()
    except FileNotFoundError:
        return 2, f"there is no file {where}"
    except OSError as error:
        return 2, f"cannot read {where}: {error.strerror}"
    if stat.S_ISDIR(info.st_mode):
        return 2, f"{where} is a folder; give the .py file itself"
    if not stat.S_ISREG(info.st_mode):  # a FIFO or a device: opening or reading it could block forever
        return 2, f"{where} is not a regular file (it is a pipe or a device); give the .py file itself"
    if path.suffix != ".py":
        if path.suffix.lower() == ".py":
            return 2, f"{name} ends in {shown(path.suffix)}: Python imports only files ending in .py: rename it"
        return 2, f"{name} is not a Python file: the checker imports it, so it must end in .py"
    if info.st_size > MAX_SOURCE_BYTES:
        return 2, (f"{where} is {info.st_size / 1e6:,.0f} MB; a file of a few functions is a few kB. Is it the"
                   " right file?")
    try:
        with open(path, "rb") as file:
            data = file.read(MAX_SOURCE_BYTES + 1)
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
        return 1, (f"{where}, line {line}: this line is not valid text (byte {data[error.start]:#04x});"
                   " save the file as UTF-8.")
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


# --- the parent: start the keeper, keep what the child says, end them on every path ---


@dataclass
class Run:
    results: dict = field(default_factory=dict)  # task index -> the collector's answer, or {"error": ...}
    stopped: dict = field(default_factory=dict)  # task index -> "time limit" or "exit code N"
    imported: dict | None = None  # {"error": ...} if importing the student's file failed
    clashes: list = field(default_factory=list)  # (file beside the student's, the module Python uses instead)
    printed: bytes = b""  # the first KEPT_OUTPUT_BYTES of what the student's code printed
    printed_bytes: int = 0
    malformed: str | None = None  # what was wrong with the child's answers, if they could not be read


def collect(path: Path, collector: str, tasks: list, prog: str, time_limit: float = 20.0) -> Run:
    """Run `tasks` (dicts; "group" names a task's group) on the student's file, in as many children as needed."""
    run, pending = Run(), list(range(len(tasks)))
    with stopping_cleanly(prog):
        while pending and run.imported is None and run.malformed is None:
            stuck = _one_child(path, collector, tasks, pending, time_limit, run)
            if stuck is None:
                break
            group = tasks[stuck].get("group")  # the stuck task's group is lost; the others get a fresh child
            for i in pending:
                if i not in run.results and (i == stuck or tasks[i].get("group") == group):
                    run.stopped[i] = run.stopped.get(stuck, "")
            pending = [i for i in pending if i not in run.results and i not in run.stopped]
    return run


def _one_child(path, collector, tasks, pending, time_limit, run) -> int | None:
    """One child for the `pending` tasks. Returns the index of a task it stopped in (time limit or exit), or None."""
    try:
        scratch = tempfile.mkdtemp(prefix="student-code-")
    except OSError as error:
        raise OutputError(f"the checker cannot make its scratch folder in {shown(tempfile.gettempdir(), 100)}"
                          f" ({error.strerror}); free some space there, or set TMPDIR to another folder", 2) from None
    answers_read, answers_write = os.pipe()
    job = json.dumps({"file": str(path.resolve()), "collector": collector, "scratch": scratch,
                      "tasks": {i: tasks[i] for i in pending}})
    try:  # (a signal before _active knows the keeper ends us, which closes its pipe: it cleans up alone)
        keeper = _active["keeper"] = subprocess.Popen(
            [sys.executable, "-I", "-B", "-c", KEEPER, str(answers_write)], cwd=scratch,
            env={**os.environ, "TMPDIR": scratch}, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, pass_fds=(answers_write,), start_new_session=True)
    except OSError:
        shutil.rmtree(scratch, ignore_errors=True)
        raise
    finally:
        os.close(answers_write)
    printed, answers = bytearray(), bytearray()
    readers = [threading.Thread(target=_drain, args=(keeper.stdout.fileno(), printed, KEPT_OUTPUT_BYTES, run),
                                daemon=True),
               threading.Thread(target=_drain, args=(answers_read, answers, MAX_ANSWER_BYTES, None), daemon=True)]
    try:
        for reader in readers:
            reader.start()
        with contextlib.suppress(OSError):  # the keeper is already gone: what it left says why
            keeper.stdin.write(job.encode() + b"\n")
            keeper.stdin.flush()  # and the pipe stays open: its closing tells the keeper to end it all
        deadline, phase, ended = time.monotonic() + time_limit, 0, False
        while not ended and time.monotonic() < deadline:
            if phase < len(PHASES) and PHASES[phase] in answers:  # the import, then the tasks: time afresh
                phase, deadline = phase + 1, time.monotonic() + time_limit
            ended = (answers.endswith(DONE) or b'{"exited": ' in answers[-32:]  # its threads may outlive DONE
                     or keeper.poll() is not None)
            time.sleep(0.01 if not ended else 0)
    finally:
        with contextlib.suppress(OSError):
            keeper.stdin.close()  # the keeper ends every process of the student's and removes the scratch folder
        keeper.wait()
        _active.clear()
        for reader in readers:
            reader.join(timeout=1.0)  # EOF once they are gone; a process that escaped the keeper cannot hold us
        os.close(answers_read)
        keeper.stdout.close()
        shutil.rmtree(scratch, ignore_errors=True)  # (the keeper's job; this is for a keeper that never started)
    run.printed = run.printed or bytes(printed)  # a second child (after a stuck task) prints the same start again
    return _read_answers(bytes(answers), run, pending, ended)


def _drain(fd: int, kept: bytearray, limit: int, run: Run | None) -> None:
    """Read the pipe to its end, keeping at most `limit` bytes: a file that floods cannot flood the checker."""
    with contextlib.suppress(OSError):  # closed under us after the time limit
        while chunk := os.read(fd, 65536):
            kept += chunk[: max(0, limit - len(kept))]
            if run is not None:
                run.printed_bytes += len(chunk)
            elif len(kept) >= limit:
                kept += b"\n!overflow"
                return


def _read_answers(answers: bytes, run: Run, pending: list, ended: bool) -> int | None:
    """Fill `run` from the child's JSON lines. Returns the task it stopped in, if it did not finish."""
    stage, code = None, None
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
            elif "exited" in message:  # the keeper's word: the child ended by itself, with this exit code
                code = int(message["exited"])
            elif "done" not in message:
                raise ValueError("an answer the checker never asks for")
    except (ValueError, TypeError, KeyError, UnicodeDecodeError) as error:  # a forgery, or a cut-off line
        run.malformed = f"what it sent back could not be read ({type(error).__name__}: {shown(error, 80)})"
        return None
    why = "time limit" if not ended else f"exit code {code}"
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


@contextlib.contextmanager
def stopping_cleanly(prog: str):
    """Inside: Ctrl-C, SIGTERM, SIGHUP (the terminal closed) and SIGQUIT close the keeper's pipe, wait for it to
    end it all, print one line and exit 130, 143, 129 or 131. The handlers from before are back afterwards."""
    previous = {number: signal.getsignal(number) for number in STOPS}

    def stop(number, frame):
        keeper = _active.get("keeper")
        if keeper:
            with contextlib.suppress(OSError, ValueError):
                os.close(keeper.stdin.fileno())
            with contextlib.suppress(OSError):
                os.waitpid(keeper.pid, 0)  # it has ended the student's processes and removed the scratch folder
        what, code = STOPS[number]
        say(f"{prog}: {what}" + (": your file's run was stopped and its scratch folder removed" if keeper else ""))
        os._exit(code)

    for number in STOPS:
        if previous[number] is not signal.SIG_IGN:  # nohup and friends ignore on purpose
            signal.signal(number, stop)
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


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
                    " a sleep, or a print in every call? One call should take well under a millisecond.")
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
    if run.printed_bytes:
        lines = run.printed.decode("utf-8", "replace").splitlines()[:8]
        print(f"Your code printed {run.printed_bytes:,} bytes while it was checked; the start:")
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
    2 unusable. Each check goes to the journal (journal.checked), and the run ends with its "Next:" line. A closed
    or full stdout, a signal or a refused resource is one line (curriculum.common.outputs)."""
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


# --- the keeper and the child, run as `python -I -B -c KEEPER FD`, the job on stdin ---


def _keeper(answers_fd: int) -> None:
    """Fork the child that runs the student's file, say on the answers pipe when it ends by itself, and when the
    checker closes our stdin (or dies: that closes it too), kill the child and every process it started
    (orphaned, they come to us: the subreaper), round after round, then remove the scratch folder."""
    prctl = getattr(ctypes.CDLL(None), "prctl", lambda *args: -1)  # Linux's prctl(2); elsewhere, the watch on stdin
    prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
    job, keeper = json.loads(sys.stdin.buffer.readline()), os.getpid()
    child = os.fork()
    if child == 0:
        prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)  # the child ends with the keeper, however the keeper ends
        try:
            if os.getppid() == keeper:
                _child(job, answers_fd)
            sys.stdout.flush()
        except BaseException:  # noqa: BLE001 (our own code failed: its traceback reaches the checker as output)
            traceback.print_exc()
        os._exit(0)
    ended = False
    while not select.select([0], [], [], 0.05)[0]:  # until the checker closes our stdin, or is gone
        pid, status = (0, 0) if ended else os.waitpid(child, os.WNOHANG)
        if pid:
            ended = True
            os.write(answers_fd, f'{{"exited": {os.waitstatus_to_exitcode(status)}}}\n'.encode())
    with contextlib.suppress(OSError):
        os.killpg(child, signal.SIGKILL)  # its group: all there is to end where there is no subreaper
    for _ in range(1000):  # orphaned, what it started comes to us: kill our children round by round, till none
        with contextlib.suppress(OSError), open(f"/proc/self/task/{keeper}/children") as listed:
            for pid in listed.read().split():
                os.kill(int(pid), signal.SIGKILL)
        try:
            if os.waitpid(-1, os.WNOHANG) == (0, 0):
                time.sleep(0.005)
        except ChildProcessError:
            break  # no child left
    shutil.rmtree(job["scratch"], ignore_errors=True)


def _child(job: dict, answers_fd: int) -> None:
    os.setpgid(0, 0)
    os.dup2(os.open(os.devnull, os.O_RDONLY), 0)  # input() in the student's code ends, it does not wait
    answers = os.fdopen(answers_fd, "w", buffering=1)

    def send(message):
        answers.write(json.dumps(message) + "\n")

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
        return
    send({"stage": "tasks"})
    for index, task in job["tasks"].items():
        send({"stage": int(index)})
        try:
            result = collector.collect(module, task)
        except BaseException as error:  # noqa: BLE001
            result = {"error": _described(error, student, course)}
        send({"task": int(index), "result": result})
    answers.write(DONE.decode())
    answers.flush()


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

