"""Signals from the guard's first instant to the last, in the engine and in an exercise: real processes, real
signals. Each program's first line is the guard of curriculum/common/interrupts.py. A finder on sys.meta_path
sends the signal from inside an import; an exit handler sends it after main() returned. One line, exit 130 or
143, never a traceback, never a silent death, never numpy's advice to reinstall.
"""

import signal
import subprocess
import sys
import textwrap

import pytest

from conftest import REPO

EXITS = {"SIGINT": (130, "interrupted"), "SIGTERM": (143, "terminated")}


def programs(out) -> dict:
    """Each program as a student runs it, with a prediction, so it runs to the end."""
    return {"engine.py": ["engine.py", "--smoke", "--out", str(out)],
            "ex5": ["-m", "exercises.ex5_phase_blob", "--predict", "euler=grows,semi_implicit=stays,rk4=shrinks",
                    "--rrd", str(out / "ex5_blob.rrd")]}


# Runs a program as `python engine.py ...` or `python -m exercises...` does, with a signal sent at one moment:
# `import:NAME` from inside the import of NAME, `exit:NAME` from an exit handler registered when NAME is
# imported (after the guard: so it runs after main() returned and before the guard's own last handler).
AT_A_MOMENT = textwrap.dedent("""
    import atexit, os, runpy, signal, sys
    signame, moment, *argv = sys.argv[1:]
    when, module = moment.split(":")
    send = lambda: os.kill(os.getpid(), getattr(signal, signame))
    class SignalAt:
        def find_spec(self, name, path=None, target=None):
            if name == module:
                sys.meta_path.remove(self)
                {"import": send, "exit": lambda: atexit.register(send)}[when]()
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



MOMENTS = [  # program, signal, where it lands, what the one line says
    ("engine.py", "SIGINT", "import:numpy._core._multiarray_umath", "interrupted: no file was written"),
    ("ex5", "SIGTERM", "import:numpy", "terminated: no file was written"),
    ("engine.py", "SIGTERM", "import:numpy.random", "terminated: no file was written"),  # inside main()
    ("engine.py", "SIGTERM", "exit:argparse", "terminated after the run had finished: engine.rrd and metrics.json in"
                                              " {out} were written before that"),
    ("ex5", "SIGINT", "exit:argparse", "interrupted after the run had finished: ex5_blob.rrd in {out} was written"
                                       " before that"),
]


@pytest.mark.parametrize("program, signame, moment, line", MOMENTS)
def test_a_signal_at_a_moment_is_one_line_saying_what_was_written(program, signame, moment, line, tmp_path):
    result = at_a_moment(signame, moment, programs(tmp_path)[program])
    assert (result.returncode, result.stderr) == (EXITS[signame][0], line.format(out=tmp_path) + "\n")
    if moment == "import:numpy.random":
        assert result.stdout.startswith("[ch3.3-engine]")  # main() had begun: the banner is its first line
    elif moment.startswith("import:"):
        assert result.stdout == "" and list(tmp_path.iterdir()) == []
    else:
        assert result.stdout.strip(), "the report was printed before the signal and must reach stdout"


def test_a_program_started_with_sigterm_ignored_keeps_ignoring_it(tmp_path):
    """nohup and `trap '' TERM` ignore on purpose: the guard and main() leave an ignored signal ignored."""
    run = subprocess.Popen([sys.executable, "engine.py", "--smoke", "--out", str(tmp_path)], cwd=REPO,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_IGN))
    assert run.stdout.readline().startswith("[ch3.3-engine]")  # main() is running
    run.terminate()
    stdout, stderr = run.communicate(timeout=120)
    assert run.returncode == 0 and stderr == "" and "wall-clock" in stdout
