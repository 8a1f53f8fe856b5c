"""engine.py as a student runs it: the default run, bad input, long runs, Ctrl-C."""

import json
import os
import re
import shlex
import signal
import subprocess
import sys
import time

import pytest

from conftest import ENGINE, REPO, as_nobody, run_engine
from curriculum.common.exercise import exercises


def test_default_run_prints_banner_first_and_wall_clock_last_and_no_noise(tmp_path):
    result = run_engine(cwd=tmp_path)  # exactly `python engine.py`, recording included
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("[ch3.3-engine] tier: free (cpu) | python ") and "numpy" in lines[0]
    assert lines[-1].startswith("wall-clock: ") and lines[-1].endswith(" s")
    assert "energy drift ordering euler >> semi_implicit > rk4: as expected" in result.stdout
    assert result.stderr == ""
    assert "warn" not in result.stdout.lower() and "traceback" not in result.stdout.lower()
    out = tmp_path / "outputs" / "ch3.3-engine"
    assert sorted(p.name for p in out.iterdir()) == ["engine.rrd", "metrics.json"]


def test_two_smoke_runs_write_identical_bytes(tmp_path):
    for name in ("a", "b"):
        assert run_engine("--smoke", "--no-rerun", "--out", tmp_path / name).returncode == 0
    assert (tmp_path / "a" / "metrics.json").read_bytes() == (tmp_path / "b" / "metrics.json").read_bytes()


BAD_INPUT = {
    "zero dt": (["--dt", "0"], "--dt"),
    "negative dt": (["--dt", "-0.01"], "--dt"),
    "nan dt": (["--dt", "nan"], "--dt"),
    "infinite dt": (["--dt", "inf"], "--dt"),
    "text dt": (["--dt", "fast"], "--dt"),
    "zero steps": (["--steps", "0"], "--steps"),
    "too many steps": (["--steps", "10000001"], "--steps"),
    "negative seed": (["--seed", "-1"], "--seed"),
    "unknown system": (["--system", "no_such_system"], "--system"),
    "smoke with its own step count": (["--smoke", "--steps", "50"], "--steps"),
    # numbers the flags read, past what Python turns into an int from text (4,300 digits) or a float holds
    "seed 1e4300": (["--seed", "1e4300"], "--seed must be from 0 to 18,446,744,073,709,551,615, got 1e4300"),
    "seed of 4,301 nines": (["--seed", "9" * 4301], "got 999999999999999999999999999999... (4,301 characters)"),
    "seed of 5,000 digits": (["--seed", "1" * 5000], "--seed must be from 0 to"),
    "ensemble 1e4300": (["--ensemble", "1e4300"], "--ensemble must be from 1 to"),
    "ensemble of 40 million": (["--ensemble", "40000000", "--steps", "1"], "--ensemble must be from 1 to"),
    "damping past the exact solution": (["--system", "damped_spring", "--damping", "2.7e154"], "up to 1e+06"),
    "negative damping": (["--system", "damped_spring", "--damping", "-1"], "--damping must be a positive, finite"),
    "damping without a damper": (["--system", "orbit", "--damping", "3"], "only --system damped_spring has a damper"),
    "implicit without dforce_dv": (["--system", "spring", "--integrator", "implicit"], "declares dforce_dv"),
    "ensemble of 0": (["--ensemble", "0"], "--ensemble must be from 1 to"),
    "negative ensemble": (["--ensemble", "-3"], "--ensemble must be from 1 to"),
    "ensemble in words": (["--ensemble", "many"], "is not a whole number"),
    "ensemble past the memory": (["--ensemble", "100000"], "GB"),
    "dt that overflows the sim time": (["--dt", "1e308"], "more time than a float can hold"),
    "negative infinite dt": (["--dt", "-inf"], "--dt must be a positive, finite number, got -inf"),
    "negative dt in e-notation": (["--dt", "-1e3"], "got -1e3"),
}


@pytest.mark.parametrize("case", BAD_INPUT)
def test_bad_flag_gets_one_line_exit_2_and_touches_nothing(case, tmp_path):
    flags, named = BAD_INPUT[case]
    out = tmp_path / "out"
    out.mkdir()
    (out / "metrics.json").write_text("previous\n")
    result = run_engine(*flags, "--out", out, cwd=tmp_path)
    assert result.returncode == 2
    assert result.stdout == "" and len(result.stderr.splitlines()) == 1 and named in result.stderr, result.stderr
    assert "Traceback" not in result.stderr and "expected one argument" not in result.stderr
    assert [p.name for p in out.iterdir()] == ["metrics.json"] and (out / "metrics.json").read_text() == "previous\n"


@pytest.mark.parametrize("where", ["is a file", "is under a file"])
def test_out_that_cannot_hold_files_is_refused(where, tmp_path):
    blocker = tmp_path / "blocker"
    blocker.write_text("not a folder\n")
    out = blocker if where == "is a file" else blocker / "sub" / "dir"
    result = run_engine("--smoke", "--no-rerun", "--out", out, cwd=tmp_path)
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1 and "--out" in result.stderr
    assert blocker.read_text() == "not a folder\n" and sorted(p.name for p in tmp_path.iterdir()) == ["blocker"]


def test_help_states_the_step_limit():
    result = run_engine("--help")
    assert result.returncode == 0 and "10,000,000" in result.stdout


@pytest.mark.slow
def test_long_run_shows_progress_on_stderr_and_smoke_stays_quiet(tmp_path):
    long = run_engine("--integrator", "euler", "--steps", "300000", "--no-rerun", "--out", tmp_path / "long")
    assert long.returncode == 0 and "100% of 300,000 steps" in long.stderr and "euler" in long.stderr
    smoke = run_engine("--smoke", "--no-rerun", "--out", tmp_path / "smoke")
    assert smoke.returncode == 0 and smoke.stderr == ""


@pytest.mark.slow
def test_ctrl_c_leaves_previous_metrics_intact(tmp_path):
    assert run_engine("--smoke", "--no-rerun", "--out", tmp_path).returncode == 0
    before = (tmp_path / "metrics.json").read_bytes()
    proc = subprocess.Popen([sys.executable, str(ENGINE), "--steps", "5000000", "--out", str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # wait until the run is integrating (its first progress report), then press Ctrl-C
    deadline = time.monotonic() + 60
    while proc.stderr.read(1) != "%" and time.monotonic() < deadline:
        pass
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert stderr.strip().splitlines()[-1].startswith("interrupted:") and "Traceback" not in stderr
    assert (tmp_path / "metrics.json").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json"]
    json.loads(before)


def test_no_rerun_never_imports_rerun(tmp_path):
    code = ("import sys, engine; engine.main(['--smoke', '--no-rerun', '--out', sys.argv[1]]);"
            "print('rerun imported:', any(m.split('.')[0] == 'rerun' for m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, cwd=REPO)
    assert result.returncode == 0 and result.stdout.strip().endswith("rerun imported: False")


def readme_commands():
    """Every `python ...` line inside the README's code blocks, comment stripped."""
    text = (REPO / "README.md").read_text()
    blocks = re.findall(r"```bash\n(.*?)```", text, flags=re.S)
    lines = [line.split("#")[0].strip() for block in blocks for line in block.splitlines()]
    return [line.split("&&")[-1].strip() for line in lines if "python " in line]


@pytest.mark.slow
def test_readme_engine_commands_run_as_written(tmp_path):
    commands = [c for c in readme_commands() if c.startswith("python engine.py")]
    assert len(commands) >= 5
    for command in commands:
        result = run_engine(*shlex.split(command)[2:], cwd=tmp_path)  # run from a fresh folder: outputs/ lands there
        assert result.returncode == 0, f"{command}: {result.stderr}"
        assert result.stderr == "", command


def test_readme_links_point_at_files_that_exist():
    links = re.findall(r"\]\(([^)#]+)\)", (REPO / "README.md").read_text())
    assert "exercises/README.md" in links and "docs/DEVELOPING.md" in links
    for link in links:
        assert (REPO / link).is_file(), link


def test_recording_without_rerun_installed_is_one_line_not_a_traceback(tmp_path):
    code = ("import sys; sys.modules['rerun'] = None  # as if rerun-sdk were not installed\n"
            "import engine; sys.exit(engine.main(['--out', sys.argv[1]]))")
    out = tmp_path / "out"
    result = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True, cwd=REPO)
    assert result.returncode == 2 and result.stdout == ""
    assert len(result.stderr.splitlines()) == 1
    assert "pip install -e ." in result.stderr and "--no-rerun" in result.stderr
    assert not out.exists()


def test_twenty_runs_started_together_into_missing_nested_folders_all_succeed(tmp_path):
    """One trial of the full suite's ten (tests/test_outputs.py): 20 processes at one instant, 4 nested new folders."""
    from test_outputs import concurrent_engine_runs

    concurrent_engine_runs(tmp_path, trials=1)


def test_rerun_switched_off_in_the_environment_is_no_rerun_with_one_line(tmp_path):
    """RERUN=off is Rerun's own switch: every Rerun call then only warns, and no recording can be made."""
    result = run_engine("--smoke", "--out", tmp_path, env={**os.environ, "RERUN": "off"})
    assert result.returncode == 0
    assert result.stderr == "engine.py: note: RERUN=off is set, so no recording is made (as with --no-rerun)\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json"]


@pytest.mark.parametrize("name, env, printed", [("r\u00e9sultats", {"PYTHONIOENCODING": "ascii"}, b"r\\xe9sultats"),
                                                (os.fsdecode(b"bad\xffbyte"), {}, b"bad\\udcffbyte")])
def test_a_path_stdout_cannot_encode_prints_escaped_after_the_files_are_written(name, env, printed, tmp_path):
    out = tmp_path / name
    result = subprocess.run([sys.executable, "engine.py", "--smoke", "--no-rerun", "--out", os.fsencode(out)],
                            cwd=REPO, capture_output=True, env={**os.environ, **env}, timeout=120)
    assert result.returncode == 0 and result.stderr == b"", result.stderr
    assert (out / "metrics.json").exists()
    assert b"metrics: " in result.stdout and printed in result.stdout  # escaped, not a UnicodeEncodeError


def test_stdout_closed_from_the_start_is_exit_1_and_nothing_is_run(tmp_path):
    """`python engine.py >&-`: the report would vanish and exit 0 would tell a script that all is well."""
    result = subprocess.run([sys.executable, "engine.py", "--smoke", "--no-rerun", "--out", str(tmp_path / "o")],
                            cwd=REPO, stdout=None, stderr=subprocess.PIPE, text=True, timeout=120,
                            pass_fds=(), preexec_fn=lambda: os.close(1))
    assert result.returncode == 1
    assert result.stderr == ("engine.py: error: standard output is closed, so the report could not be printed;"
                             " nothing was run\n")
    assert not (tmp_path / "o").exists()


def test_stderr_closed_still_gives_the_exit_code_and_no_file_takes_its_place(tmp_path):
    """With fd 2 closed, the next file opened would get number 2 and receive every warning: the guard fills it."""
    result = subprocess.run([sys.executable, "engine.py", "--smoke", "--out", str(tmp_path)], cwd=REPO,
                            stdout=subprocess.PIPE, stderr=None, text=True, timeout=120,
                            preexec_fn=lambda: os.close(2))
    assert result.returncode == 0 and "metrics:" in result.stdout
    json.loads((tmp_path / "metrics.json").read_text())
    bad = subprocess.run([sys.executable, "engine.py", "--dt", "0", "--out", str(tmp_path)], cwd=REPO,
                         capture_output=True, timeout=60, preexec_fn=lambda: os.close(2))
    assert bad.returncode == 2


@pytest.mark.parametrize("exercise", [name for _, name, kind in exercises(REPO / "exercises") if kind == "predict"])
def test_every_exercise_answers_a_mistyped_flag_in_one_line(exercise):
    result = subprocess.run([sys.executable, "-m", f"exercises.{exercise}", "--predcit", "x"], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == (f"exercises.{exercise}: error: unrecognized arguments: --predcit x; did you mean"
                             " --predict? (see --help)\n")


def test_rerun_switched_off_makes_exercise_5_skip_its_recording_in_one_line(tmp_path):
    result = subprocess.run([sys.executable, "-m", "exercises.ex5_phase_blob", "--predict",
                             "euler=grows,semi_implicit=stays,rk4=shrinks", "--rrd", str(tmp_path / "blob.rrd")],
                            cwd=REPO, capture_output=True, text=True, timeout=120, env={**os.environ, "RERUN": "OFF"})
    assert result.returncode == 0 and list(tmp_path.iterdir()) == []
    assert result.stderr == ("exercises.ex5_phase_blob: note: RERUN=OFF is set, so no recording is made"
                             " (as with --no-rerun)\n")


def test_help_into_a_full_stdout_is_exit_1_not_a_silent_0():
    """argparse drops a failed write of --help and exits 0: a script would think the help was shown."""
    with open("/dev/full", "w") as full:
        result = subprocess.run([sys.executable, "engine.py", "--help"], cwd=REPO, stdout=full,
                                stderr=subprocess.PIPE, text=True, timeout=60)
    assert result.returncode == 1
    assert result.stderr == ("engine.py: error: could not print the report (No space left on device: stdout closed"
                             " or full?); no file was written\n")


# --- issue 27: stderr closed, what the terminal is sent, exercises' --rrd ---


def with_stderr_closed(*args, signal_after=None):
    """(exit code, stdout) of `python ARGS` started with stderr closed (`2>&-`) and stdout a pipe."""
    child = subprocess.Popen([sys.executable, *map(str, args)], cwd=REPO, stdout=subprocess.PIPE, text=True,
                             preexec_fn=lambda: os.close(2))
    if signal_after:
        time.sleep(signal_after)
        child.send_signal(signal.SIGINT)
    out, _ = child.communicate(timeout=300)
    return child.returncode, out


@pytest.mark.parametrize("args, code, last", [
    (["engine.py", "--steps", "100000", "--no-rerun"], 0, "wall-clock: "),  # progress on
    (["engine.py", "--ensemble", "100000", "--steps", "10", "--no-rerun"], 0, "wall-clock: "),  # seeds' progress
    (["-m", "exercises.ex4_long_run", "--predict", "10"], 0, "Next: exercise 5"),
])
def test_with_stderr_closed_what_it_would_say_goes_to_stdout(args, code, last, tmp_path):
    """Before: exit 1 and not a word anywhere (progress lines went to a sys.stderr that was None)."""
    returned, out = with_stderr_closed(*args, *(["--out", tmp_path] if args[0] == "engine.py" else []))
    assert returned == code and out.splitlines()[-1].startswith(last) and "Traceback" not in out


@pytest.mark.slow
def test_ctrl_c_with_stderr_closed_says_so_on_stdout(tmp_path):
    returned, out = with_stderr_closed("engine.py", "--steps", "3000000", "--integrator", "euler", "--no-rerun",
                                       "--out", tmp_path, signal_after=3.0)
    assert returned == 130 and out.splitlines()[-1] == "interrupted: no file was written"


LONG = "x" * 5000


@pytest.mark.parametrize("args", [["engine.py", f"--{LONG}"], ["engine.py", LONG], ["engine.py", "--system", LONG],
                                  ["engine.py", "--out", LONG], ["-m", "exercises.check_ex2", f"{LONG}.py"],
                                  ["-m", "exercises.ex3_halve_dt", "--system", LONG, "--predict", "1"]])
def test_a_name_of_5000_characters_comes_back_short(args):
    """Before: one line of 5,057 characters or more, the whole name."""
    result = subprocess.run([sys.executable, *args], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1 and len(result.stderr) < 300
    assert "xxx...xxx" in result.stderr


@pytest.mark.parametrize("args", [["engine.py", "--out", "a\nb\nc"], ["engine.py", "--out", "a\x1b[2Jb"],
                                  ["engine.py", "--sys\x1b[2Jtem", "orbit"], ["engine.py", "--system", "\u202eorbit"],
                                  ["-m", "exercises.check_ex2", "a\x1b[2J.py"]])
def test_what_was_typed_comes_back_escaped(args, tmp_path):
    """An --out holding a newline gave three lines; escape sequences and bidi overrides reached the terminal."""
    args = [ENGINE, *args[1:]] if args[0] == "engine.py" else args
    result = subprocess.run([sys.executable, *args], cwd=tmp_path, capture_output=True, text=True, timeout=60,
                            env={**os.environ, "PYTHONPATH": str(REPO)})
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1 and result.stdout == ""
    assert not re.search("[\x00-\x09\x0b-\x1f\u202a-\u202e]", result.stderr), result.stderr
    assert "\\n" in result.stderr or "\\x1b" in result.stderr or "\\u202e" in result.stderr
    assert list(tmp_path.iterdir()) == []


EXERCISE_RECORDINGS = [("ex5_phase_blob", "euler=grows,semi_implicit=stays,rk4=shrinks"),
                       ("ex7_shadow_energy", "spring=roundoff,orbit=smaller,freefall=roundoff")]


def broken_rerun(tmp_path):
    fake = tmp_path / "site" / "rerun"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("from rerun_bindings import a_name_this_build_lacks\n")  # a half-installed SDK
    return {"PYTHONPATH": str(tmp_path / "site")}


@pytest.mark.parametrize("exercise, prediction", EXERCISE_RECORDINGS)
@pytest.mark.parametrize("case", ["a name too long", "rerun-sdk broken", "a control character"])
def test_an_exercises_recording_that_cannot_be_made_is_one_line_before_it_measures(exercise, prediction, case,
                                                                                  tmp_path):
    """Before: a PermissionError or OSError traceback (exit 1), or Rerun's traceback once the exercise had run."""
    rrd = {"a control character": tmp_path / "a\x1b[2J.rrd"}.get(case, tmp_path / ("x" * 300 + ".rrd"))
    env = {**os.environ, **(broken_rerun(tmp_path) if case == "rerun-sdk broken" else {})}
    if case == "rerun-sdk broken":
        rrd = tmp_path / "blob.rrd"
    started = time.monotonic()
    result = subprocess.run([sys.executable, "-m", f"exercises.{exercise}", "--predict", prediction, "--rrd", rrd],
                            cwd=REPO, capture_output=True, text=True, timeout=120, env=env)
    assert result.returncode == 2 and result.stdout == "" and len(result.stderr.splitlines()) == 1
    assert "Traceback" not in result.stderr and "--no-rerun" in result.stderr
    assert time.monotonic() - started < 5, "refused before the measurement"
    assert sorted(p.name for p in tmp_path.iterdir()) in ([], ["site"])


@pytest.mark.parametrize("exercise, prediction", EXERCISE_RECORDINGS)
def test_an_exercises_recording_in_a_folder_that_cannot_be_searched_is_one_line(exercise, prediction, shared_tmp):
    """As an unprivileged user: the folder can be read and written, but not searched (mode 766)."""
    (shared_tmp / "closed").mkdir()
    (shared_tmp / "closed").chmod(0o766)
    loaded = (f"import runpy, pkgutil, exercises.{exercise}, numpy.random, gettext, locale, shutil, textwrap, json,"
              " fractions, rerun, rerun.blueprint, curriculum.common.recording, exercises.support.shadow_recording")
    code = (f"import sys, warnings; warnings.simplefilter('ignore'); sys.argv = ['x', *sys.argv[1:]];"
            f" runpy.run_module('exercises.{exercise}', run_name='__main__')")
    result = as_nobody(code, "--predict", prediction, "--rrd", shared_tmp / "closed" / "x.rrd", load=loaded)
    assert result.returncode == 2 and result.stdout == "" and len(result.stderr.splitlines()) == 1, result.stderr
    assert "Permission denied" in result.stderr and "Traceback" not in result.stderr


def test_rerun_switched_off_makes_exercise_7_skip_its_recording_in_one_line(tmp_path):
    """Before: exercise 7 ran to its end, then printed Rerun's warnings and a traceback (exit 1)."""
    result = subprocess.run([sys.executable, "-m", "exercises.ex7_shadow_energy", "--predict",
                             EXERCISE_RECORDINGS[1][1], "--rrd", str(tmp_path / "x.rrd")],
                            cwd=REPO, capture_output=True, text=True, timeout=120, env={**os.environ, "RERUN": "off"})
    assert result.returncode == 0 and list(tmp_path.iterdir()) == []
    assert result.stderr == ("exercises.ex7_shadow_energy: note: RERUN=off is set, so no recording is made"
                             " (as with --no-rerun)\n")
