"""Signals from the first instant to the last, in the engine and in every exercise: real processes, real signals.

Each program's first line after `import sys` (or after making the repo importable) is the guard of
curriculum/common/interrupts.py. These tests send SIGINT and SIGTERM at exact moments (a finder on
sys.meta_path sends it from inside an import; an exit handler sends it after main() returned) and at
random moments once the guard is in place (read from the kernel: /proc/PID/status shows SIGTERM caught),
and require one line and exit 130 or 143, never a traceback, never a silent death, never numpy's advice
to reinstall.
"""

import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from conftest import REPO

EXITS = {"SIGINT": (130, "interrupted"), "SIGTERM": (143, "terminated")}


def programs(out: Path) -> dict:
    """Each program as a student runs it, with a prediction, so it runs to the end."""
    return {
        "engine.py": ["engine.py", "--smoke", "--out", str(out)],
        "ex1": ["-m", "exercises.ex1_band", "--predict", "euler=grows,semi_implicit=stays,rk4=grows"],
        "ex3": ["-m", "exercises.ex3_halve_dt", "--predict", "euler=2,semi_implicit=2,rk4=16"],
        "ex4": ["-m", "exercises.ex4_long_run", "--predict", "1000"],
        "ex5": ["-m", "exercises.ex5_phase_blob", "--predict", "euler=grows,semi_implicit=stays,rk4=shrinks",
                "--rrd", str(out / "ex5_blob.rrd")],
        "ex6": ["-m", "exercises.ex6_stiff_damping", "--predict", "implicit"],
    }


# Runs a program as `python engine.py ...` or `python -m exercises...` does, with a signal sent at one moment:
# `import:NAME` from inside the import of NAME, `exit:NAME` from an exit handler registered when NAME is
# imported (after the guard: so it runs after main() returned and before the guard's own last handler),
# `del:NAME` from inside a __del__ run while NAME is imported (where Python swallows what a handler raises).
AT_A_MOMENT = textwrap.dedent("""
    import atexit, os, runpy, signal, sys
    signame, moment, *argv = sys.argv[1:]
    when, module = moment.split(":")
    send = lambda: os.kill(os.getpid(), getattr(signal, signame))
    class Collected:
        def __del__(self):
            send()
    class SignalAt:
        def find_spec(self, name, path=None, target=None):
            if name == module:
                sys.meta_path.remove(self)
                {"import": send, "exit": lambda: atexit.register(send), "del": Collected}[when]()
    sys.meta_path.insert(0, SignalAt())
    if argv[0] == "-m":
        sys.argv = argv[1:]
        runpy.run_module(argv[1], run_name="__main__", alter_sys=True)
    else:
        sys.argv = argv
        runpy.run_path(argv[0], run_name="__main__")
""")


def at_a_moment(signame: str, moment: str, argv: list, timeout: int = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", AT_A_MOMENT, signame, moment, *argv], cwd=REPO, capture_output=True,
                          text=True, timeout=timeout)


def assert_one_line(result, code: int, line: str) -> None:
    assert (result.returncode, result.stderr) == (code, line + "\n")


QUICK = [("engine.py", "SIGINT"), ("ex5", "SIGTERM")]  # the rest of the grid runs in the full suite
EVERY = [(program, signame) for program in ("engine.py", "ex1", "ex3", "ex4", "ex5", "ex6") for signame in EXITS]


def grid(quick):
    return [pytest.param(*case, marks=[] if case in quick else [pytest.mark.slow]) for case in EVERY]


@pytest.mark.parametrize("program, signame", grid(QUICK))
@pytest.mark.parametrize("module", ["argparse", "numpy", "numpy._core._multiarray_umath"])
def test_a_signal_while_the_program_imports_is_one_line(program, signame, module, tmp_path):
    """From the first import after the guard; numpy's compiled core would otherwise turn Ctrl-C into
    'IMPORTANT: PLEASE READ THIS FOR ADVICE ON HOW TO SOLVE THIS ISSUE!' and a reinstall."""
    code, word = EXITS[signame]
    result = at_a_moment(signame, f"import:{module}", programs(tmp_path)[program])
    assert_one_line(result, code, f"{word}: no file was written")
    assert result.stdout == "" and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("signame", EXITS)
def test_a_signal_once_main_loads_numpy_random_is_one_line(signame, tmp_path):
    """numpy.random loads lazily, inside main(): there @one_line_failures answers, in the same words."""
    code, word = EXITS[signame]
    result = at_a_moment(signame, "import:numpy.random", programs(tmp_path)["engine.py"])
    assert_one_line(result, code, f"{word}: no file was written")
    assert result.stdout.startswith("[ch3.3-engine]")  # main() had begun: the banner is its first line


@pytest.mark.parametrize("signame", EXITS)
def test_a_signal_inside_a_del_or_a_weakref_callback_is_one_line(signame, tmp_path):
    """Raised there, Ctrl-C would be printed as "Exception ignored in ..." and the run would go on to exit 0
    (seen once when a Ctrl-C landed in importlib's module-lock callback)."""
    code, word = EXITS[signame]
    result = at_a_moment(signame, "del:numpy.random", programs(tmp_path)["engine.py"])
    assert_one_line(result, code, f"{word}: no file was written")
    assert list(tmp_path.iterdir()) == []


AFTER = {  # what each program has written when main() returns
    "engine.py": "engine.rrd and metrics.json in {out} were written before that",
    "ex5": "ex5_blob.rrd in {out} was written before that",
}


@pytest.mark.parametrize("program, signame", grid([("engine.py", "SIGTERM")]))
def test_a_signal_after_main_returned_says_the_run_had_finished(program, signame, tmp_path):
    """Rerun keeps a process alive ~0.3 s after main() returns; a signal then used to end it silently (-2)."""
    code, word = EXITS[signame]
    result = at_a_moment(signame, "exit:argparse", programs(tmp_path)[program])
    said = AFTER.get(program, "no file was written").format(out=tmp_path)
    assert_one_line(result, code, f"{word} after the run had finished: {said}")
    assert result.stdout.strip(), "the report was printed before the signal and must reach stdout"


def test_the_process_ends_when_main_returns(tmp_path):
    """No 0.3 s of Python's own shutdown (Rerun's threads unloading) after the last line: the last exit
    handler ends the process with main()'s code."""
    run = subprocess.Popen([sys.executable, "engine.py", "--smoke", "--out", str(tmp_path)], cwd=REPO,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for line in run.stdout:
        if line.startswith("wall-clock"):
            printed = time.perf_counter()
    assert run.wait(timeout=120) == 0 and run.stderr.read() == ""
    assert time.perf_counter() - printed < 0.25


def guard_installed(pid: int) -> bool:
    """Whether the process catches SIGTERM yet: Python catches SIGINT from its start, SIGTERM once the guard runs."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return True  # already gone
    caught = int(next(line for line in status.splitlines() if line.startswith("SigCgt:")).split()[1], 16)
    return bool(caught & (1 << (signal.SIGTERM - 1)))


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads the caught signals from Linux's /proc")
@pytest.mark.parametrize("program", ["engine.py", "ex1", "ex4", "ex5"])
def test_a_signal_at_any_moment_after_the_guard_is_one_line(program, tmp_path):
    """30 runs, each signalled at a random moment from the guard's first instant to the process's end."""
    chance = random.Random(program)  # the same moments on every run of the suite
    for trial in range(30):
        signame = chance.choice(list(EXITS))
        code, word = EXITS[signame]
        out = tmp_path / str(trial)
        run = subprocess.Popen([sys.executable, *programs(out)[program]], cwd=REPO, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True)
        while not guard_installed(run.pid):
            time.sleep(0.0005)
        time.sleep(chance.uniform(0.0, 2.5 if program != "ex4" else 5.0))
        run.send_signal(getattr(signal, signame))
        stderr = run.stderr.read()
        returncode = run.wait(timeout=120)
        if returncode == 0:
            assert stderr == ""  # it had finished before the signal came
            continue
        assert returncode == code, (trial, signame, returncode, stderr)
        assert len(stderr.splitlines()) == 1 and stderr.startswith(word), (trial, stderr)
        assert "Traceback" not in stderr and "reinstall" not in stderr


def test_a_program_started_with_sigterm_ignored_keeps_ignoring_it(tmp_path):
    """nohup and `trap '' TERM` ignore on purpose: the guard and main() leave an ignored signal ignored."""
    run = subprocess.Popen([sys.executable, "engine.py", "--smoke", "--out", str(tmp_path)], cwd=REPO,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_IGN))
    assert run.stdout.readline().startswith("[ch3.3-engine]")  # main() is running
    run.terminate()
    stdout, stderr = run.communicate(timeout=120)
    assert run.returncode == 0 and stderr == "" and "wall-clock" in stdout
