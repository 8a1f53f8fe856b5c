"""The course's harness for students' code (curriculum/common/student_code.py), with real processes and real
signals: isolation from the student's folder, bounded output, files that are not source, and a clean stop on
every path (nothing left running, no scratch folder left) for Ctrl-C and SIGTERM."""

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


def group_alive(pgid):
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


def children_of(pid):
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as stat:
                    fields = stat.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.append((int(entry), int(fields[2])))  # (pid, process group)
    return found


@pytest.mark.parametrize("number, code, word", [(signal.SIGINT, 130, "interrupted"),
                                                 (signal.SIGTERM, 143, "terminated")])
def test_a_signal_stops_the_child_group_removes_the_scratch_and_says_one_line(number, code, word, tmp_path):
    (tmp_path / "spin.py").write_text(SLEEPER + SPIN)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    checker = subprocess.Popen([sys.executable, "-m", "exercises.check_ex2", str(tmp_path / "spin.py")], cwd=REPO,
                               env={**os.environ, "TMPDIR": str(scratch)}, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not (children_of(checker.pid) and len(os.listdir(scratch)) and time.monotonic() > 0):
        assert time.monotonic() < deadline, "the child never started"
        time.sleep(0.1)
    time.sleep(1.0)  # the child is importing, then spinning; its sleeper is started
    groups = {group for _, group in children_of(checker.pid)}
    checker.send_signal(number)
    out, err = checker.communicate(timeout=30)
    assert checker.returncode == code and "Traceback" not in err + out
    assert err.splitlines() == [f"python -m exercises.check_ex2: {word}: your file's run was stopped and its"
                                " scratch folder removed"]
    deadline = time.monotonic() + 5  # SIGKILL was sent; the kernel takes a moment to finish them off
    while any(group_alive(group) for group in groups) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert groups and not any(group_alive(group) for group in groups), "the child or what it started still runs"
    assert os.listdir(scratch) == []


@pytest.mark.parametrize("number, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_during_the_checkers_own_imports_is_one_line(number, code):
    """The moment guard() catches SIGTERM (Python itself never does), numpy and the engine are still loading."""
    checker = subprocess.Popen([sys.executable, "-m", "exercises.check_ex2", "--help"], cwd=REPO,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    caught = 0
    while not caught >> (signal.SIGTERM - 1) & 1 and checker.poll() is None:
        with open(f"/proc/{checker.pid}/status") as status:
            caught = int(next(line for line in status if line.startswith("SigCgt:")).split()[1], 16)
    checker.send_signal(number)
    out, err = checker.communicate(timeout=30)
    assert checker.returncode == code and out == "" and len(err.splitlines()) == 1 and "Traceback" not in err


def test_a_normal_end_reaps_what_the_file_started_and_does_not_wait_for_it(tmp_path):
    """A process and a thread of the file's own outlive its last answer: the checker neither waits nor leaves them."""
    lingering = "import threading, time\nthreading.Thread(target=time.sleep, args=(600,)).start()\n"
    (tmp_path / "sleeper.py").write_text(SLEEPER + lingering + "def f(x):\n    return x\n")
    before = set(children_of(os.getpid()))  # what earlier tests left running is not this test's business
    started = time.monotonic()
    run = student_code.collect(tmp_path / "sleeper.py", "tests.collector_for_tests", [{"x": 1}], "test")
    assert run.results == {0: {"got": 1}} and time.monotonic() - started < 5
    time.sleep(0.2)
    assert not set(children_of(os.getpid())) - before


def test_the_child_is_isolated_a_helper_imports_a_clash_is_named(tmp_path):
    (tmp_path / "threading.py").write_text("raise RuntimeError('the scratch threading.py was imported')\n")
    (tmp_path / "mine_helper.py").write_text("def twice(x):\n    return 2 * x\n")
    (tmp_path / "mine.py").write_text("import threading\nfrom mine_helper import twice\n\n\ndef f(x):\n"
                                      "    return twice(x)\n")
    run = student_code.collect(tmp_path / "mine.py", "tests.collector_for_tests", [{"x": 2}], "test")
    assert run.imported is None and run.results == {0: {"got": 4}}
    assert run.clashes == [("threading.py", "Python's standard module threading")]
    assert "threading.py beside your file has the name of Python's standard module threading" in \
        student_code.clash_sentence(run.clashes)


def test_collect_gives_the_callers_signal_handlers_back(tmp_path):
    """Its handlers (kill the child, remove the scratch folder, exit) hold only while a child may run."""
    (tmp_path / "mine.py").write_text("def f(x):\n    return x\n")
    before = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    student_code.collect(tmp_path / "mine.py", "tests.collector_for_tests", [{"x": 1}], "test")
    assert {number: signal.getsignal(number) for number in before} == before


def test_a_flood_without_newlines_is_kept_bounded(tmp_path):
    (tmp_path / "flood.py").write_text("import sys\nwhile True:\n    sys.stdout.write('x' * 65536)\n")
    run = student_code.collect(tmp_path / "flood.py", "tests.collector_for_tests", [{"x": 1}], "test", time_limit=2)
    assert run.imported == {"stopped": "time limit"}
    assert len(run.printed) == student_code.KEPT_OUTPUT_BYTES and run.printed_bytes > 10 * len(run.printed)


def test_a_forged_answer_is_a_sentence_not_a_traceback(tmp_path):
    (tmp_path / "forge.py").write_text("import os, sys\nos.write(int(sys.argv[1]), b'{not json\\n')\nos._exit(0)\n")
    run = student_code.collect(tmp_path / "forge.py", "tests.collector_for_tests", [{"x": 1}], "test")
    sentence = student_code.failure_sentence(run, [0], lambda i: "", 20)
    assert sentence.startswith("your file's run did not finish: what it sent back could not be read")


def test_what_is_not_a_regular_source_file_gets_a_sentence(tmp_path):
    os.mkfifo(tmp_path / "pipe.py")
    with open(tmp_path / "big.py", "wb") as big:
        big.truncate(200_000_000)  # sparse: 200 MB on paper, nothing on disk
    fifo = student_code.source_problem(tmp_path / "pipe.py")
    assert fifo == (2, f"{tmp_path / 'pipe.py'} is not a regular file (it is a pipe or a device); give the"
                       " .py file itself")
    assert "is not a regular file" in student_code.source_problem(student_code.Path("/dev/zero"))[1]
    assert student_code.source_problem(tmp_path / "big.py") == (2, f"{tmp_path / 'big.py'} is 200 MB; a file of a few"
                                                                  " functions is a few kB. Is it the right file?")


def test_the_checker_says_so_for_a_fifo_with_exit_2(tmp_path):
    os.mkfifo(tmp_path / "pipe.py")
    result = subprocess.run([sys.executable, "-m", "exercises.check_ex2", str(tmp_path / "pipe.py")], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and result.stdout == "" and "is not a regular file" in result.stderr


def test_a_full_temp_folder_is_a_sentence(tmp_path, monkeypatch):
    def full(**kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(tempfile, "mkdtemp", full)
    with pytest.raises(student_code.ScratchProblem, match="No space left on device"):
        student_code.collect(REPO / "tests" / "planted" / "_right.py", "tests.collector_for_tests", [{}], "test")
