"""The checker's runner (curriculum/common/student_code.py), with real processes and real signals: nothing of the
student's file runs on however the checker ends, one verdict per file (a fixed hash seed), prints that cost
nothing, a crash named by its signal, a time limit for the import and another for the tasks."""

import contextlib
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
    return student_code.collect(tmp_path / "mine.py", "tests.collector_for_tests", list(tasks), **kwargs)


def left_behind(scratch) -> list:
    """Processes whose working folder is in `scratch` (the checker's TMPDIR: its child starts in a folder there,
    and what it starts inherits it, even once removed): what a checker run left running."""
    found = []
    for entry in filter(str.isdigit, os.listdir("/proc")):
        with contextlib.suppress(OSError):  # a process that ended meanwhile
            found += [int(entry)] if os.readlink(f"/proc/{entry}/cwd").startswith(f"{scratch}/") else []
    return found


def gone(scratch) -> bool:
    """Whether nothing is left in `scratch` within 30 s (on a loaded machine, ending a process takes a moment)."""
    for _ in range(600):
        if not left_behind(scratch) and not os.listdir(scratch):
            return True
        time.sleep(0.05)
    return False


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
    said = {130: "interrupted", 143: "terminated"}.get(code)  # SIGKILL: nothing, and no traceback
    assert err == (f"{said}: your file's run was stopped and its scratch folder removed\n" if said else "")
    assert gone(scratch), left_behind(scratch)  # the child's sentinel saw the checker's end of its pipe close


def test_a_normal_end_reaps_what_the_file_started_gives_the_handlers_back_and_is_isolated(tmp_path, monkeypatch):
    """A process and a thread of the file's own outlive its last answer: the checker neither waits nor leaves
    them. The file's folder comes after the standard library: a scratch threading.py there is not imported."""
    (tmp_path / "threading.py").write_text("raise RuntimeError('the scratch threading.py was imported')\n")
    (tmp_path / "mine_helper.py").write_text("def twice(x):\n    return 2 * x\n")
    lingering = "import threading, time\nthreading.Thread(target=time.sleep, args=(60,)).start()\n"
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    before = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    run = collect(tmp_path, SLEEPER + lingering + "from mine_helper import twice\n\n\ndef f(x):\n    return twice(x)\n",
                  tasks=[{"x": 2}])
    assert run.imported is None and run.results == {0: {"got": 4}} and gone(tmp_path / "tmp")
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
    while the file is imported is kept bounded, counted, and still stopped by the time limit."""
    run = collect(tmp_path, "def f(x):\n    print('debug', x, 'x' * 100)\n    return x\n",
                  tasks=[{"x": i} for i in range(100)])
    assert run.results == {i: {"got": i} for i in range(100)} and run.prints > 0
    assert run.printed.startswith(b"debug 0 xxx") and len(run.printed) <= student_code.KEPT_OUTPUT_BYTES
    run = collect(tmp_path, "import sys\nwhile True:\n    sys.stdout.write('x' * 65536)\n", time_limit=2)
    assert len(run.printed) == student_code.KEPT_OUTPUT_BYTES and run.printed_bytes > 10 * len(run.printed)
    assert student_code.failure_sentence(run, [0], str, 2).startswith("importing your file did not finish within 2 s")


def test_a_crash_is_named_by_its_signal(tmp_path):
    run = collect(tmp_path, "import os, signal\n\n\ndef f(x):\n    os.kill(os.getpid(), signal.SIGSEGV)\n")
    assert run.stopped == {0: "segmentation fault, signal 11"}


def test_the_import_and_the_tasks_each_get_the_time_limit(tmp_path):
    """An import of 1.5 s and a task of 1.5 s with a 2 s limit: each within it, so the answer comes."""
    run = collect(tmp_path, "import time\ntime.sleep(1.5)\n\n\ndef f(x):\n    time.sleep(1.5)\n    return x\n",
                  tasks=[{"x": 3}], time_limit=2)
    assert run.imported is None and run.results == {0: {"got": 3}} and run.stopped == {}
