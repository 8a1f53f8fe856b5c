"""A code exercise checked again: each file against a fresh private copy of the checker (from a snapshot taken
before any student's code ran), in a child with a time limit and its own session, as `nobody` when the grader is
root and can. Back comes the verdict: never what the code printed, nor an error's message (its type and line)."""

import contextlib
import functools
import json
import os
import pwd
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

from curriculum.common.exercise import EXERCISE_FILE, EXERCISES

COURSE = EXERCISES.parent
NEEDED = ["engine*.py", "curriculum/__init__.py", "curriculum/common", "exercises"]  # not the grader, tests, outputs
TIME_LIMIT = 300  # seconds for a whole check (the checker limits each part of the child's run to 20 s)
DRIVER = """import json, sys; sys.path.insert(0, sys.argv[1]); from pathlib import Path  # argv[2]: in the cwd
from curriculum.common import student_code
from exercises import check_ex{n} as checker
student_code.error_sentence = lambda e, f=student_code.error_sentence: f({{**e, "message": ""}})
problem = student_code.source_problem(Path(sys.argv[2]))
parts, messages = ({{}}, [problem[1]]) if problem else checker.check(Path(sys.argv[2]))[:2]
print("\\nVERDICT " + json.dumps({{"parts": parts, "messages": messages}}))
"""


@functools.cache
def check(module: str, data: bytes | None) -> tuple[bool, str]:
    """(solved, what the checker said) for a handed-in file; the same bytes give the same verdict, checked once."""
    if data is None:
        return False, f"no {module}.py handed in"
    if data == (EXERCISES / "support" / "pristine" / f"{module}.py").read_bytes():
        return False, "the untouched stub"
    user = unprivileged()
    with tempfile.TemporaryDirectory(prefix="grading-") as scratch:
        os.chmod(scratch, 0o755)  # readable by `nobody`, writable by no student's code
        copy, work = Path(scratch, "course"), Path(scratch, "work")
        for relative, content in snapshot().items():
            (copy / relative).parent.mkdir(parents=True, exist_ok=True)
            (copy / relative).write_bytes(content)
        work.mkdir(mode=0o700)
        (work / f"{module}.py").write_bytes(data)
        if user:
            os.chown(work, user.pw_uid, user.pw_gid)
        env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(work), "TMPDIR": str(work),
               "COURSE_JOURNAL": "off", "LANG": "C.UTF-8", "PYTHONDONTWRITEBYTECODE": "1",
               **{k: v for k, v in os.environ.items() if k == "LD_LIBRARY_PATH"}}  # a Python that needs it
        drop = {"user": user.pw_uid, "group": user.pw_gid, "extra_groups": []} if user else {}
        child = subprocess.Popen([sys.executable, "-I", "-c", DRIVER.format(n=EXERCISE_FILE.fullmatch(
            f"{module}.py")[1]), str(copy), f"{module}.py"], cwd=work, env=env, stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, start_new_session=True, **drop)
        try:
            out = child.communicate(timeout=TIME_LIMIT)[0]
        except subprocess.TimeoutExpired:
            out = b""
        finally:
            with contextlib.suppress(OSError):
                os.killpg(child.pid, signal.SIGKILL)  # its session: the checker's keeper, anything the code started
            child.wait()
    try:
        said = json.loads(out.rpartition(b"\nVERDICT ")[2])
        parts, messages = dict(said["parts"]), [str(m) for m in said["messages"]]
    except (ValueError, KeyError, TypeError):
        return False, "the checker could not finish on this file here (it ran past its time or ended Python)"
    solved = bool(parts) and all(v is True for v in parts.values())
    return solved, "solved, checked again here" if solved else " ".join(messages)[:2000]


@functools.cache
def snapshot() -> dict:
    """{path: bytes} of what a checker needs, read once before any student's code runs."""
    return {str(path.relative_to(COURSE)): path.read_bytes() for pattern in NEEDED for part in COURSE.glob(pattern)
            for path in ([part] if part.is_file() else sorted(part.rglob("*.py")) + sorted(part.rglob("*.md")))
            if "__pycache__" not in path.parts and ".before-reset-" not in path.name}


@functools.cache
def unprivileged():
    """`nobody`'s passwd entry if the grader is root and `nobody` can run this Python with numpy, else None."""
    if os.geteuid() != 0:
        return None
    with contextlib.suppress(KeyError, OSError, subprocess.SubprocessError):
        user = pwd.getpwnam("nobody")
        if subprocess.run([sys.executable, "-I", "-c", "import numpy"], user=user.pw_uid, group=user.pw_gid,
                          extra_groups=[], cwd="/", capture_output=True, timeout=120).returncode == 0:
            return user
    print(f"note: the user nobody cannot run {sys.executable} (a private folder on its path?), so students' code"
          " runs as root: grade in a container (docs/TEACHING.md)", file=sys.stderr)
    return None
