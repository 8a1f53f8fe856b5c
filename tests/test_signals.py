"""Ctrl-C and SIGTERM from the guard's first instant to the last, and a stdout closed early: real processes, real
signals. Each program's first line is the guard of curriculum/common/interrupts.py. One line, exit 130 or 143,
never a traceback, never a silent death, never numpy's advice to reinstall; the files whole, new or previous."""

import json
import os
import signal
import subprocess
import sys
import textwrap

import pytest
from test_outputs import PAIR, previous_pair, recording_id

from conftest import REPO

ENGINE = ["engine.py", "--smoke", "--out", "{out}"]
EX5 = ["-m", "exercises.ex5_phase_blob", "--predict", "euler=grows,semi_implicit=stays,rk4=shrinks", "--rrd",
       "{out}/ex5_blob.rrd"]

# Runs a program as `python engine.py ...` or `python -m exercises...` does, with a signal sent at one moment:
# `import:NAME` from inside the import of NAME, `call:NAME` just after the first call of os.NAME, `exit:NAME` from an
# exit handler registered when NAME is imported (after the guard's: so it runs once main() has returned).
AT_A_MOMENT = textwrap.dedent("""
    import atexit, os, runpy, signal, sys
    signame, moment, *argv = sys.argv[1:]
    when, name = moment.split(":")
    send = lambda: os.kill(os.getpid(), getattr(signal, signame))
    class SignalAt:
        def find_spec(self, module, path=None, target=None):
            if module == name:
                sys.meta_path.remove(self)
                {"import": send, "exit": lambda: atexit.register(send)}[when]()
    if when == "call":
        real = getattr(os, name)
        def once(*args):
            setattr(os, name, real)
            real(*args)
            send()
        setattr(os, name, once)
    else:
        sys.meta_path.insert(0, SignalAt())
    sys.argv = argv[1:] if argv[0] == "-m" else argv
    runpy.run_module(argv[1], run_name="__main__", alter_sys=True) if argv[0] == "-m" else \\
        runpy.run_path(argv[0], run_name="__main__")
""")

MOMENTS = [  # program, signal, where it lands, what the one line says
    (EX5, "SIGINT", "import:numpy._core._multiarray_umath", "interrupted: no file was written"),
    (ENGINE, "SIGTERM", "import:numpy.random", "terminated: no file was written"),  # inside main(), before the files
    (ENGINE, "SIGINT", "call:replace", "interrupted: engine.rrd and metrics.json in {out} were written before that"),
    ([*ENGINE, "--no-rerun"], "SIGTERM", "exit:argparse", "terminated: metrics.json in {out} was written before that"),
]


@pytest.mark.parametrize("argv, signame, moment, line", MOMENTS, ids=[row[2] for row in MOMENTS])
def test_a_signal_at_a_moment_is_one_line_and_leaves_the_files_whole(argv, signame, moment, line, tmp_path):
    before = previous_pair(tmp_path)
    argv = [arg.format(out=tmp_path) for arg in argv]
    result = subprocess.run([sys.executable, "-c", AT_A_MOMENT, signame, moment, *argv], cwd=REPO, capture_output=True,
                            text=True, timeout=120)
    code = {"SIGINT": 130, "SIGTERM": 143}[signame]
    assert (result.returncode, result.stderr) == (code, line.format(out=tmp_path) + "\n")
    if "-m" in argv:  # stopped while numpy loads, before the exercise printed anything
        assert result.stdout == ""
    else:  # what was printed before the signal reached stdout: the banner, and the report once main() returned
        assert result.stdout.startswith("[ch3.3-engine]") and ("wall-clock" in result.stdout) == (moment[:4] == "exit")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(PAIR)  # no temporary file left
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    if "written before" not in line:
        assert {name: (tmp_path / name).read_bytes() for name in PAIR} == before
    elif "engine.rrd" in line:
        assert recording_id(tmp_path / "engine.rrd") == metrics["run_id"]


def test_a_program_started_with_sigterm_ignored_keeps_ignoring_it(tmp_path):
    """nohup and `trap '' TERM` ignore on purpose: the guard and main() leave an ignored signal ignored."""
    run = subprocess.Popen([sys.executable, "engine.py", "--smoke", "--no-rerun", "--out", str(tmp_path)], cwd=REPO,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_IGN))
    assert run.stdout.readline().startswith("[ch3.3-engine]")  # main() is running
    run.terminate()
    stdout, stderr = run.communicate(timeout=120)
    assert run.returncode == 0 and stderr == "" and "wall-clock" in stdout


CLOSED = {  # when stdout is closed -> exit code and stderr
    "at start (>&-)": (0, ""),  # the report is lost, and nothing else: no file we open takes its number
    "after the first line (| head -1)": (1, "engine.py: error: Broken pipe; metrics.json in {out} was written before"
                                            " that\n"),
}


@pytest.mark.parametrize("case", CLOSED)
def test_a_closed_stdout_leaves_the_files_whole(case, tmp_path):
    at_start = case.startswith("at start")
    run = subprocess.Popen([sys.executable, "engine.py", "--smoke", "--no-rerun", "--out", str(tmp_path)], cwd=REPO,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=(lambda: os.close(1)) if at_start else None)
    if not at_start:
        assert run.stdout.readline().startswith("[ch3.3-engine]")
    run.stdout.close()
    code, stderr = CLOSED[case]
    assert (run.wait(timeout=120), run.stderr.read()) == (code, stderr.format(out=tmp_path))
    assert json.loads((tmp_path / "metrics.json").read_text())["steps"] == 600
