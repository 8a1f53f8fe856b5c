"""Run a student's file where it cannot decide the verdict: the harness of every chapter's code exercise
(how it works and what it promises: docs/DEVELOPING.md, "Adding a checker mistake").

    problem = source_problem(path)  # (exit code, sentence) if it cannot be checked; runs none of it
    run = collect(path, "exercises.support.ex2_cases", tasks)  # in a child: collector.collect(module, task)
"""

import argparse
import ast
import builtins
import contextlib
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
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from curriculum.common import interrupts
from curriculum.common.cli import OneLineParser, shown
from curriculum.common.outputs import one_line_failures

REPO = Path(__file__).resolve().parents[2]
KEPT_OUTPUT_BYTES = 4096  # of what the student's code prints: enough to show, bounded whatever it does
MAX_ANSWER_BYTES = 64_000_000  # what the child may send back; past this the run counts as malformed
DONE = b'{"done": true}\n'  # the child's last answer
PHASES = (b'{"stage": "import"}', b'{"stage": "tasks"}')  # each starts the time limit afresh
CHILD = "import sys; sys.path.append(sys.argv[2]); from curriculum.common.student_code import _child; _child()"


# --- before anything runs: a readable, compiling Python file ---


def source_problem(path: Path) -> tuple[int, str] | None:
    """(exit code, sentence) if `path` cannot be checked: 2 if it is not a Python source file, 1 if it does not
    compile (the sentence then ends with the line and a caret). None if it can. Runs none of its code."""
    where = shown(path, 100)
    try:
        if stat.S_ISDIR(path.stat().st_mode):
            return 2, f"{where} is a folder; give the .py file itself"
        if path.suffix != ".py":
            return 2, f"{shown(path.name, 60)} is not a Python file: the checker imports it, so it must end in .py"
        compile(path.read_bytes(), str(path), "exec", dont_inherit=True)  # decoded as Python imports it
    except FileNotFoundError:
        return 2, f"there is no file {where}"
    except OSError as error:
        return 2, f"cannot read {where}: {error.strerror}"
    except SyntaxError as error:  # IndentationError and TabError too; a null byte or text that is not UTF-8
        why = {"TabError": " Indent with spaces only; most editors can turn tabs into spaces.",
               "IndentationError": " The lines of one block must start in the same column."}
        kind, text = type(error).__name__, (error.text or "").rstrip("\n")
        quoted = f"    {shown(text.strip(), None)}"
        if error.offset and text.strip() and kind == "SyntaxError":
            quoted += "\n    " + " " * max(0, error.offset - 1 - (len(text) - len(text.lstrip()))) + "^"
        at = f", line {error.lineno}" if error.lineno else ""
        return 1, f"{where}{at}: {kind}: {shown(error.msg, None)}.{why.get(kind, '')}\n{quoted}"
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


# --- the parent: start the child, keep what it says, end it on every path ---


@dataclass
class Run:
    results: dict = field(default_factory=dict)  # task index -> the collector's answer, or {"error": ...}
    stopped: dict = field(default_factory=dict)  # task index -> "time limit", "exit code N" or the signal
    imported: dict | None = None  # {"error": ...} or {"stopped": ...} if importing the student's file failed
    printed: bytes = b""  # the first KEPT_OUTPUT_BYTES of what the student's code printed
    printed_bytes: int = 0
    prints: int = 0  # print() calls made once the kept bytes were full: counted, never formatted
    malformed: str | None = None  # what was wrong with the child's answers, if they could not be read


def collect(path: Path, collector: str, tasks: list, time_limit: float = 20.0) -> Run:
    """Run `tasks` (dicts; "group" names a task's group) on the student's file, in as many children as needed.
    A signal meanwhile is the guard's one line, which says the run was stopped."""
    run, pending, said = Run(), list(range(len(tasks))), interrupts.said()
    interrupts.said("your file's run was stopped and its scratch folder removed")
    while pending and run.imported is None and run.malformed is None:
        stuck = _one_child(path, collector, tasks, pending, time_limit, run)
        if stuck is None:
            break
        for i in pending:  # the stuck task's group is lost; the others get a fresh child
            if i not in run.results and tasks[i].get("group") == tasks[stuck].get("group"):
                run.stopped.setdefault(i, run.stopped[stuck])
        pending = [i for i in pending if i not in run.results and i not in run.stopped]
    interrupts.said(said)
    return run


def _one_child(path, collector, tasks, pending, time_limit, run) -> int | None:
    """One child for the `pending` tasks. Returns the index of a task it stopped in (time limit or exit), or None."""
    with tempfile.TemporaryDirectory(prefix="student-code-", ignore_cleanup_errors=True) as scratch:
        job = Path(scratch, "job.json")
        job.write_text(json.dumps({"file": str(path.resolve()), "collector": collector,
                                   "tasks": {i: tasks[i] for i in pending}}))
        env = {**{k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}, "PYTHONHASHSEED": "0",
               "TMPDIR": scratch}  # -s -P -B: no user site, nothing from the working folder, no .pyc written
        fd, answers_write = os.pipe()
        with open(fd, "rb", buffering=0) as pipe:  # its closing (here, or by any signal) ends the child's group
            child = subprocess.Popen(
                [sys.executable, "-s", "-P", "-B", "-c", CHILD, str(answers_write), str(REPO), str(job)],
                cwd=scratch, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL, pass_fds=(answers_write,), start_new_session=True)
            os.close(answers_write)
            answers, deadline, phase, ended = bytearray(), time.monotonic() + time_limit, 0, False
            while not ended and time.monotonic() < deadline and len(answers) <= MAX_ANSWER_BYTES:
                if select.select([pipe], [], [], 0.01)[0]:
                    answers += pipe.read(1 << 20)
                if phase < len(PHASES) and PHASES[phase] in answers:  # the import, then the tasks: time afresh
                    phase, deadline = phase + 1, time.monotonic() + time_limit
                ended = answers.endswith(DONE) or child.poll() is not None  # (its threads may outlive DONE)
            code = child.poll()
            with contextlib.suppress(OSError):  # its session: all it started, unless a process left it; SIGKILL
                os.killpg(child.pid, signal.SIGKILL)  # ends them at once (on any other way out: the sentinel)
            child.wait()
            os.set_blocking(fd, False)  # what is left: the sentinel holds the pipe open, so it never ends
            while len(answers) <= MAX_ANSWER_BYTES and (chunk := pipe.read(1 << 20)):
                answers += chunk
    return _read_answers(bytes(answers[:MAX_ANSWER_BYTES + 1]), run, pending, ended, code)


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
        why = f"{signal.strsignal(-code).lower()}, signal {-code}"
    if stage is None and ended:
        run.malformed = f"Python stopped before your file was even imported ({why})"
    elif stage is None or stage == "import" and run.imported is None:
        run.imported = {"stopped": why}
    elif missing := [i for i in pending if i not in run.results]:  # the tasks run in order: the first missing
        run.stopped[missing[0]] = why  # one is where it stopped (time limit, os._exit, a crash), the one to blame
        return missing[0]
    return None


# --- sentences ---


def failure_sentence(run: Run, indices: list, where, time_limit: float) -> str | None:
    """The sentence for tasks `indices` of one function if they ended without an answer, else None.
    where(i) says what task i is doing ("during a whole run on ...")."""
    if run.malformed:
        return f"your file's run did not finish: {run.malformed}."
    if run.imported and "error" in run.imported:
        return f"your file stopped while Python was importing it: it {error_sentence(run.imported['error'])}."
    if run.imported and run.imported["stopped"] != "time limit":
        return (f"your file ended Python while it was being imported ({run.imported['stopped']}): does it call"
                " os._exit() at the top level? Only definitions need to be there.")
    if run.imported:
        return (f"importing your file did not finish within {time_limit:.0f} s. Code at the top level runs when a"
                " file is imported: put trial runs under `if __name__ == \"__main__\":`, and look for a loop that"
                " never ends.")
    for i in indices:
        stopped, result = run.stopped.get(i), run.results.get(i, {})
        if stopped == "time limit":
            return (f"stopped after {time_limit:.0f} s {where(i)}, without returning. Is there a loop that never ends,"
                    " or a sleep? One call should take well under a millisecond.")
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


def error_sentence(error: dict) -> str:
    """'raised ZeroDivisionError: float division by zero in rk4_step(), line 31 of mine.py: k2 = ...'."""
    what = shown(f"{error['type']}: {error['message']}" if error["message"] else error["type"], 300)
    if "line" not in error:
        return f"raised {what} (inside Python or numpy, called from your code)"
    return (f"raised {what} in {shown(error['function'])}(), line {error['line']} of {shown(error['file'], 60)}:"
            f" {shown(error['code'], 200)}")


# --- the command of a chapter's checker ---


def main(prog: str, doc: str, default: Path, what: str, check, argv=None) -> int:
    """`prog [FILE]`: check(path) -> ({function: solved}, messages, run) for a file that compiles; 0 solved, 1 not,
    2 unusable. Each check goes to the journal (journal.checked), and the run ends with its "Next:" line."""
    return one_line_failures(prog)(_main)(prog, doc, default, what, check, argv)


def _main(prog: str, doc: str, default: Path, what: str, check, argv) -> int:
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
    if run.printed_bytes or run.prints:  # what the student's code printed (the start of it), before the verdicts
        more = f" and called print() {run.prints:,} times more" if run.prints else ""
        print(f"Your code printed {run.printed_bytes:,} bytes{more} while it was checked; the start:")
        lines = run.printed.decode("utf-8", "replace").splitlines()[:8]
        print("\n".join(f"  | {shown(line, 200)}" for line in lines) + "\n")
    explain(*messages)
    solved = all(parts.values())
    print("\nAll solved." if solved else "\nNot solved yet: read the messages above, edit, and run it again.")
    checked(default, args.file, parts)
    return 0 if solved else 1


# --- the child, run as `python -s -P -B -c CHILD FD REPO JOB` ---


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
    answers_fd, _, job_file = sys.argv[1:]
    group, scratch = os.getpid(), os.getcwd()
    if os.fork() == 0:  # a sentinel in a group of its own: the answers' pipe reports an error (POLLERR) here once
        os.setpgid(0, 0)  # the checker's end closes (it is done, or any signal ended it, SIGKILL too); then it ends
        os.chdir("/")  # our group, all we started, and removes the scratch folder
        closed = select.poll()
        closed.register(int(answers_fd), 0)
        closed.poll()
        os.killpg(group, signal.SIGKILL)
        shutil.rmtree(scratch, ignore_errors=True)
        os._exit(0)
    job, answers = json.loads(Path(job_file).read_text()), os.fdopen(int(answers_fd), "w", buffering=1)

    def send(message):
        answers.write(json.dumps(message) + "\n")

    sys.stdout = sys.stderr = sink = _Sink(send)
    student = Path(job["file"])
    sys.path.append(str(student.parent))  # after the standard library and site-packages
    collector = importlib.import_module(job["collector"])
    course = {os.path.realpath(m.__file__) for m in list(sys.modules.values()) if getattr(m, "__file__", None)}
    send({"stage": "import"})
    try:
        spec = importlib.util.spec_from_file_location("student", student)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except BaseException as error:  # noqa: BLE001 (SystemExit too: reported, not obeyed)
        send({"import": {"error": _described(error, student, course)}})
    else:
        send({"stage": "tasks"})
        for index, task in job["tasks"].items():
            try:
                result = collector.collect(module, task)
            except BaseException as error:  # noqa: BLE001
                result = {"error": _described(error, student, course)}
            send({"task": int(index), "result": result})
    send({"dropped": sink.dropped, "prints": sink.prints})
    answers.write(DONE.decode())
    answers.flush()
    os._exit(0)  # the student's threads and exit handlers do not run on


def _described(error: BaseException, student: Path, course: set) -> dict:
    """The exception in one line, and the deepest line it passed through in the student's own code: the
    student's file, or a helper in its folder that is not one of the course's modules."""
    folder, mine = str(student.parent.resolve()) + os.sep, str(student.resolve())
    frames = [f for f in traceback.extract_tb(error.__traceback__) if (file := os.path.realpath(f.filename)) == mine
              or file.startswith(folder) and file not in course]
    message = f"exit code {error.code}" if isinstance(error, SystemExit) else str(error)
    described = {"type": type(error).__name__, "message": message[:300]}
    if frames:
        described.update(file=Path(frames[-1].filename).name, line=frames[-1].lineno,
                         code=(frames[-1].line or "").strip(), function=frames[-1].name)
    return described
