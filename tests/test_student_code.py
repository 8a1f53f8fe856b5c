"""The course's harness for students' code (curriculum/common/student_code.py), with real processes and real
signals: isolation from the student's folder, bounded output, files that are not source, and a clean stop on
every path (nothing left running, no scratch folder left) for Ctrl-C and SIGTERM."""

import contextlib
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
# a process in a session of its own, and a daemon (forked twice, in a new session): no process group holds them
ESCAPERS = ("import os, subprocess, sys, time\n"
            "subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(601)'], start_new_session=True)\n"
            "if os.fork() == 0:\n    os.setsid()\n    if os.fork() == 0:\n        time.sleep(602)\n    os._exit(0)\n")


def group_alive(pgid):
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


def left_behind(scratch):
    """Processes whose working folder is in `scratch` (the checker's TMPDIR: its children start in a folder there,
    and what they start inherits it, even once removed): what a checker run left running."""
    found = []
    for entry in filter(str.isdigit, os.listdir("/proc")):
        with contextlib.suppress(OSError):
            if os.readlink(f"/proc/{entry}/cwd").startswith(f"{scratch}/"):
                found.append(int(entry))
    return found


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


SIGNALS = [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated"), (signal.SIGHUP, 129, "hung up"),
           (signal.SIGQUIT, 131, "quit"), (signal.SIGKILL, -9, None)]


@pytest.mark.parametrize("number, code, word", [pytest.param(*case, marks=() if case[0] == signal.SIGKILL
                                                             else pytest.mark.slow) for case in SIGNALS])
@pytest.mark.parametrize("escapers", [False, True])
def test_however_the_checker_ends_nothing_of_the_file_runs_on_and_no_scratch_is_left(number, code, word, escapers,
                                                                                     tmp_path):
    """The checker is signalled while the file loops, after it started an ordinary child, or a process in a
    session of its own and a daemon. SIGHUP and SIGQUIT left the child spinning with parent 1 and its scratch
    folder; so did SIGKILL, which no handler sees (the keeper does, when its pipe closes); escapers outlived all."""
    (tmp_path / "spin.py").write_text((ESCAPERS if escapers else SLEEPER) + SPIN)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    checker = subprocess.Popen([sys.executable, "-m", "exercises.check_ex2", str(tmp_path / "spin.py")], cwd=REPO,
                               env={**os.environ, "TMPDIR": str(scratch)}, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while len(left_behind(scratch)) < (4 if escapers else 3):  # the keeper, the child, and what the file started
        assert time.monotonic() < deadline and checker.poll() is None, "the child never started"
        time.sleep(0.1)
    time.sleep(0.5)  # spinning now
    checker.send_signal(number)
    out, err = checker.communicate(timeout=30)
    assert checker.returncode == code and "Traceback" not in err + out
    if word:
        assert err.splitlines() == [f"python -m exercises.check_ex2: {word}: your file's run was stopped and its"
                                    " scratch folder removed"]
    deadline = time.monotonic() + 5  # "not outlive its parent by more than a few seconds"
    while (left_behind(scratch) or os.listdir(scratch)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert left_behind(scratch) == [] and os.listdir(scratch) == []


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


def test_a_normal_end_reaps_what_the_file_started_and_does_not_wait_for_it(tmp_path, monkeypatch):
    """Processes (in the file's group, in a session of their own, a daemon) and a thread of the file's own outlive
    its last answer: the checker neither waits nor leaves them."""
    lingering = "import threading, time\nthreading.Thread(target=time.sleep, args=(600,)).start()\n"
    (tmp_path / "sleeper.py").write_text(SLEEPER + ESCAPERS + lingering + "def f(x):\n    return x\n")
    before = set(children_of(os.getpid()))  # what earlier tests left running is not this test's business
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    started = time.monotonic()
    run = student_code.collect(tmp_path / "sleeper.py", "tests.collector_for_tests", [{"x": 1}], "test")
    assert run.results == {0: {"got": 1}} and time.monotonic() - started < 5
    time.sleep(0.2)
    assert not set(children_of(os.getpid())) - before and left_behind(tmp_path / "tmp") == []


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
    with pytest.raises(student_code.OutputError, match="No space left on device") as refused:
        student_code.collect(REPO / "tests" / "planted" / "_right.py", "tests.collector_for_tests", [{}], "test")
    assert refused.value.exit_code == 2


def test_the_import_and_the_tasks_each_get_the_time_limit(tmp_path):
    """An import of 1.5 s and a task of 1.5 s with a 2 s limit: each within it, so the answer comes. Before, the
    import's time counted as the task's: 'stopped after 2 s during ...'."""
    (tmp_path / "slow.py").write_text("import time\ntime.sleep(1.5)\n\n\ndef f(x):\n    time.sleep(1.5)\n"
                                      "    return x\n")
    run = student_code.collect(tmp_path / "slow.py", "tests.collector_for_tests", [{"x": 3}], "test", time_limit=2)
    assert run.imported is None and run.results == {0: {"got": 3}} and run.stopped == {}


@pytest.mark.parametrize("limit", range(6, 11))
def test_too_few_file_descriptors_is_one_line(limit):
    """ulimit -n 6 to 10: the checker cannot open its pipes. Before: a traceback (OSError: Too many open files)."""
    import resource

    result = subprocess.run([sys.executable, "-m", "exercises.check_ex2", "exercises/solutions/ex2_integrators.py"],
                            cwd=REPO, capture_output=True, text=True, timeout=60,
                            preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_NOFILE, (limit, limit)))
    assert result.returncode == 1 and len(result.stderr.splitlines()) == 1 and "Traceback" not in result.stderr
    assert "Too many open files" in result.stderr and "ulimit -n" in result.stderr


def test_the_checker_with_stdout_closed_or_full_says_so_in_one_line():
    """Before: exit 0 with nothing said (closed), a traceback (full)."""
    checker = [sys.executable, "-m", "exercises.check_ex2", "exercises/solutions/ex2_integrators.py"]
    closed = subprocess.run(checker, cwd=REPO, stderr=subprocess.PIPE, text=True, timeout=60,
                            preexec_fn=lambda: os.close(1))
    assert closed.returncode == 1 and closed.stderr == ("python -m exercises.check_ex2: error: standard output"
                                                        " is closed, so the report could not be printed; nothing was"
                                                        " run\n")
    with open("/dev/full", "w") as full:
        filled = subprocess.run(checker, cwd=REPO, stdout=full, stderr=subprocess.PIPE, text=True, timeout=60)
    assert filled.returncode == 1 and filled.stderr.startswith("python -m exercises.check_ex2: error: could not print"
                                                               " the report (No space left on device")
    assert len(filled.stderr.splitlines()) == 1


def test_what_the_file_prints_and_raises_reaches_the_terminal_escaped(tmp_path):
    """A student's escape sequences and bidi overrides are shown, not obeyed by the terminal."""
    (tmp_path / "loud.py").write_text("print('\\x1b[2J\\u202ecleared')\n\n\ndef semi_implicit_step(q, v, m, force, dt):"
                                      "\n    raise ValueError('\\x1b[31mred')\n\n\nrk4_step = semi_implicit_step\n")
    result = subprocess.run([sys.executable, "-m", "exercises.check_ex2", str(tmp_path / "loud.py")], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 1 and "\x1b" not in result.stdout and "\u202e" not in result.stdout
    assert "  | \\x1b[2J\\u202ecleared" in result.stdout and "ValueError: \\x1b[31mred" in result.stdout
