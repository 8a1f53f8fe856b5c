"""The checker's runner (curriculum/common/student_code.py), with real processes and real signals: nothing of the
student's file runs on however the checker ends, one verdict per file (a fixed hash seed), prints that cost
nothing, a crash named by its signal, a sentence for every file that is not source."""

import errno
import os
import signal
import subprocess
import sys
import tempfile
import time

import pytest

from conftest import REPO
from curriculum.common import student_code

SPIN = "def semi_implicit_step(q, v, m, force, dt):\n    while True:\n        pass\n\n\nrk4_step = semi_implicit_step\n"
SLEEPER = "import subprocess, sys\nsubprocess.Popen([sys.executable, '-c', 'import time; time.sleep(600)'])\n"


def collect(tmp_path, source: str, tasks=({"x": 1},), **kwargs) -> student_code.Run:
    (tmp_path / "mine.py").write_text(source)
    return student_code.collect(tmp_path / "mine.py", "tests.collector_for_tests", list(tasks), "test", **kwargs)


def left_behind(scratch) -> list:
    """Processes whose working folder is in `scratch` (the checker's TMPDIR: its child starts in a folder there,
    and what it starts inherits it, even once removed): what a checker run left running."""
    found = []
    for entry in filter(str.isdigit, os.listdir("/proc")):
        try:
            if os.readlink(f"/proc/{entry}/cwd").startswith(f"{scratch}/"):
                found.append(int(entry))
        except OSError:
            pass
    return found


@pytest.mark.parametrize("number, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143), (signal.SIGKILL, -9)])
def test_however_the_checker_ends_nothing_of_the_file_runs_on_and_no_scratch_is_left(number, code, tmp_path):
    """Signalled while the file loops, after the file started a child of its own (SIGKILL: no handler sees it)."""
    (tmp_path / "spin.py").write_text(SLEEPER + SPIN)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    checker = subprocess.Popen([sys.executable, "-m", "exercises.check_ex2", str(tmp_path / "spin.py")], cwd=REPO,
                               env={**os.environ, "TMPDIR": str(scratch)}, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    while len(left_behind(scratch)) < 2:  # the child and what the file started (the sentinel waits in /)
        assert checker.poll() is None, checker.communicate()
        time.sleep(0.05)
    checker.send_signal(number)
    out, err = checker.communicate(timeout=60)
    assert checker.returncode == code and "Traceback" not in err + out
    if number != signal.SIGKILL:
        assert err == f"{'interrupted' if code == 130 else 'terminated'}: your file's run was stopped and its scratch" \
                      " folder removed\n"
    for _ in range(600):  # the child's sentinel, which saw the checker's end of its pipe close, ends them at once
        if not left_behind(scratch) and not os.listdir(scratch):
            break
        time.sleep(0.05)
    assert left_behind(scratch) == [] and os.listdir(scratch) == []


def test_a_signal_during_the_checkers_own_imports_is_one_line():
    """The moment guard() catches SIGTERM (Python itself never does), numpy and the engine are still loading."""
    checker = subprocess.Popen([sys.executable, "-m", "exercises.check_ex2", "--help"], cwd=REPO,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    caught = 0
    while not caught >> (signal.SIGTERM - 1) & 1 and checker.poll() is None:
        with open(f"/proc/{checker.pid}/status") as status:
            caught = int(next(line for line in status if line.startswith("SigCgt:")).split()[1], 16)
    checker.send_signal(signal.SIGTERM)
    out, err = checker.communicate(timeout=30)
    assert (checker.returncode, out, err) == (143, "", "terminated: no file was written\n")


def test_a_normal_end_reaps_what_the_file_started_gives_the_handlers_back_and_is_isolated(tmp_path, monkeypatch):
    """A process and a thread of the file's own outlive its last answer: the checker neither waits nor leaves
    them. The file's folder comes after the standard library: a scratch threading.py there is named, not used."""
    (tmp_path / "threading.py").write_text("raise RuntimeError('the scratch threading.py was imported')\n")
    (tmp_path / "mine_helper.py").write_text("def twice(x):\n    return 2 * x\n")
    lingering = "import threading, time\nthreading.Thread(target=time.sleep, args=(60,)).start()\n"
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    before = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    run = collect(tmp_path, SLEEPER + lingering + "from mine_helper import twice\n\n\ndef f(x):\n    return twice(x)\n",
                  tasks=[{"x": 2}])
    assert run.imported is None and run.results == {0: {"got": 4}} and left_behind(tmp_path / "tmp") == []
    assert run.clashes == [("threading.py", "Python's standard module threading")]
    assert {number: signal.getsignal(number) for number in before} == before


def test_every_run_gets_the_same_hash_seed(tmp_path, monkeypatch):
    """`python -I` ignores PYTHONHASHSEED: a file choosing by hash() got a new verdict on every run."""
    expected = subprocess.run([sys.executable, "-c", "print(hash('pick'))"], capture_output=True, text=True,
                              env={**os.environ, "PYTHONHASHSEED": "0"}).stdout.strip()
    for seed in ("1", "random"):
        monkeypatch.setenv("PYTHONHASHSEED", seed)
        assert collect(tmp_path, "def f(x):\n    return hash('pick')\n").results == {0: {"got": int(expected)}}


def test_prints_are_kept_bounded_and_cost_no_verdict(tmp_path):
    """A print in every call is counted, not formatted, once the first few kB are kept; a flood without newlines
    is kept bounded and still stopped by the time limit."""
    run = collect(tmp_path, "def f(x):\n    print('debug', x, 'x' * 100)\n    return x\n",
                  tasks=[{"x": i} for i in range(100)])
    assert run.results == {i: {"got": i} for i in range(100)} and run.prints > 0
    assert run.printed.startswith(b"debug 0 xxx") and len(run.printed) <= student_code.KEPT_OUTPUT_BYTES
    run = collect(tmp_path, "import sys\nwhile True:\n    sys.stdout.write('x' * 65536)\n", time_limit=2)
    assert run.imported == {"stopped": "time limit"}
    assert len(run.printed) == student_code.KEPT_OUTPUT_BYTES and run.printed_bytes > 10 * len(run.printed)


def test_a_crash_is_named_by_its_signal_and_a_forged_answer_is_a_sentence(tmp_path):
    run = collect(tmp_path, "import os, signal\n\n\ndef f(x):\n    os.kill(os.getpid(), signal.SIGSEGV)\n")
    assert run.stopped == {0: "crashed (segmentation fault, signal 11)"}
    assert "your code crashed (segmentation fault, signal 11) in f" in \
        student_code.failure_sentence(run, [0], lambda i: "in f", 20)
    run = collect(tmp_path, "import os, sys\nos.write(int(sys.argv[1]), b'{not json\\n')\nos._exit(0)\n")
    assert student_code.failure_sentence(run, [0], str, 20).startswith("your file's run did not finish: what it sent"
                                                                       " back could not be read")


def test_the_import_and_the_tasks_each_get_the_time_limit(tmp_path):
    """An import of 1.5 s and a task of 1.5 s with a 2 s limit: each within it, so the answer comes."""
    run = collect(tmp_path, "import time\ntime.sleep(1.5)\n\n\ndef f(x):\n    time.sleep(1.5)\n    return x\n",
                  tasks=[{"x": 3}], time_limit=2)
    assert run.imported is None and run.results == {0: {"got": 3}} and run.stopped == {}


def test_what_is_not_a_regular_source_file_gets_a_sentence(tmp_path, monkeypatch):
    os.mkfifo(tmp_path / "pipe.py")
    with open(tmp_path / "big.py", "wb") as big:
        big.truncate(200_000_000)  # sparse: 200 MB on paper, nothing on disk
    assert student_code.source_problem(tmp_path / "big.py") == (2, f"{tmp_path / 'big.py'} is 200 MB; a file of a"
                                                                  " few functions is a few kB. Is it the right file?")
    assert "is not a regular file" in student_code.source_problem(student_code.Path("/dev/zero"))[1]
    result = subprocess.run([sys.executable, "-m", "exercises.check_ex2", str(tmp_path / "pipe.py")], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == f"python -m exercises.check_ex2: error: {tmp_path / 'pipe.py'} is not a regular file (it" \
                            " is a pipe or a device); give the .py file itself\n"

    def full(**kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(tempfile, "mkdtemp", full)
    with pytest.raises(student_code.OutputError, match="No space left on device") as refused:
        collect(tmp_path, "def f(x):\n    return x\n")
    assert refused.value.exit_code == 2
