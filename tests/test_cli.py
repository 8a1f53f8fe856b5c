"""engine.py and the exercises as a student runs them: the default run, the README's commands, bad input in one
line (exit 2, nothing touched), what was typed coming back escaped and short, a recording that cannot be made."""

import os
import re
import shlex
import subprocess
import sys

import pytest

import engine as chapter
from conftest import REPO, run_engine
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
def test_bad_flag_gets_one_line_exit_2_and_touches_nothing(case, tmp_path, capsys):
    """In this process (engine.main is what `python engine.py` runs; test_outputs.py runs the exit codes whole)."""
    flags, named = BAD_INPUT[case]
    (tmp_path / "metrics.json").write_text("previous\n")
    with pytest.raises(SystemExit) as stop:
        chapter.main([*flags, "--out", str(tmp_path)])
    printed = capsys.readouterr()
    assert stop.value.code == 2 and printed.out == "" and len(printed.err.splitlines()) == 1, printed.err
    assert named in printed.err and "expected one argument" not in printed.err
    assert [p.name for p in tmp_path.iterdir()] == ["metrics.json"]
    assert (tmp_path / "metrics.json").read_text() == "previous\n"


def test_help_states_the_step_limit():
    result = run_engine("--help")
    assert result.returncode == 0 and "10,000,000" in result.stdout


@pytest.mark.slow
def test_long_run_shows_progress_on_stderr_and_smoke_stays_quiet(tmp_path):
    long = run_engine("--integrator", "euler", "--steps", "300000", "--no-rerun", "--out", tmp_path / "long")
    assert long.returncode == 0 and "100% of 300,000 steps" in long.stderr and "euler" in long.stderr
    smoke = run_engine("--smoke", "--no-rerun", "--out", tmp_path / "smoke")
    assert smoke.returncode == 0 and smoke.stderr == ""


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


@pytest.mark.parametrize("exercise", [name for _, name, kind in exercises(REPO / "exercises") if kind == "predict"])
def test_every_exercise_answers_a_mistyped_flag_in_one_line(exercise):
    result = subprocess.run([sys.executable, "-m", f"exercises.{exercise}", "--predcit", "x"], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == (f"exercises.{exercise}: error: unrecognized arguments: --predcit x; did you mean"
                             " --predict? (see --help)\n")


def refused(args, cwd, capsys) -> str:
    """stderr of a refused command: engine.py's main() in this process, the others as students run them."""
    if args[0] == "engine.py":
        with pytest.raises(SystemExit) as stop:
            chapter.main(args[1:])
        code, (out, err) = stop.value.code, capsys.readouterr()
    else:
        result = subprocess.run([sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=60,
                                env={**os.environ, "PYTHONPATH": str(REPO)})
        code, out, err = result.returncode, result.stdout, result.stderr
    assert code == 2 and out == "" and len(err.splitlines()) == 1, err
    return err


LONG = "x" * 5000


@pytest.mark.parametrize("args", [["engine.py", f"--{LONG}"], ["engine.py", LONG], ["engine.py", "--system", LONG],
                                  ["-m", "exercises.check_ex2", f"{LONG}.py"],
                                  ["-m", "exercises.ex3_halve_dt", "--system", LONG, "--predict", "1"],
                                  ["engine.py", "--out", "a\nb\nc"], ["engine.py", "--out", "a\x1b[2Jb"],
                                  ["engine.py", "--sys\x1b[2Jtem", "orbit"], ["engine.py", "--system", "\u202eorbit"],
                                  ["-m", "exercises.check_ex2", "a\x1b[2J.py"]])
def test_what_was_typed_comes_back_short_and_escaped(args, tmp_path, capsys, monkeypatch):
    """Before: one line of 5,057 characters or more; an --out holding a newline gave three lines; escape sequences
    and bidi overrides reached the terminal."""
    monkeypatch.chdir(tmp_path)
    err = refused(args, tmp_path, capsys)
    assert len(err) < 300 and not re.search("[\x00-\x09\x0b-\x1f\u202a-\u202e]", err), err
    assert "xxx...xxx" in err or "\\n" in err or "\\x1b" in err or "\\u202e" in err
    assert list(tmp_path.iterdir()) == []


EXERCISE_RECORDINGS = [("ex5_phase_blob", "euler=grows,semi_implicit=stays,rk4=shrinks"),
                       ("ex7_shadow_energy", "spring=roundoff,orbit=smaller,freefall=roundoff")]


def broken_rerun(tmp_path):
    fake = tmp_path / "site" / "rerun"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("from rerun_bindings import a_name_this_build_lacks\n")  # a half-installed SDK
    return {"PYTHONPATH": str(tmp_path / "site")}


@pytest.mark.parametrize("case, exercise, prediction", [("a control character", *EXERCISE_RECORDINGS[0]),
                                                       ("a control character", *EXERCISE_RECORDINGS[1]),
                                                       ("rerun-sdk broken", *EXERCISE_RECORDINGS[1])])
def test_an_exercises_recording_that_cannot_be_made_is_one_line_before_it_measures(case, exercise, prediction,
                                                                                  tmp_path):
    """Before: a PermissionError or OSError traceback (exit 1), or Rerun's traceback once the exercise had run."""
    rrd = tmp_path / ("blob.rrd" if case == "rerun-sdk broken" else "a\x1b[2J.rrd")  # a long name: DEVELOPING's limits
    env = {**os.environ, **(broken_rerun(tmp_path) if case == "rerun-sdk broken" else {})}
    result = subprocess.run([sys.executable, "-m", f"exercises.{exercise}", "--predict", prediction, "--rrd", rrd],
                            cwd=REPO, capture_output=True, text=True, timeout=120, env=env)
    assert result.returncode == 2 and result.stdout == "" and len(result.stderr.splitlines()) == 1
    assert "Traceback" not in result.stderr and "--no-rerun" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) in ([], ["site"])


@pytest.mark.parametrize("args, files", [(["engine.py", "--smoke", "--out", "{tmp}"], ["metrics.json"]),
                                         (["-m", "exercises.ex7_shadow_energy", "--predict", EXERCISE_RECORDINGS[1][1],
                                           "--rrd", "{tmp}/x.rrd"], [])])
def test_rerun_switched_off_is_no_rerun_with_one_line(args, files, tmp_path):
    """RERUN=off is Rerun's own switch: every Rerun call then only warns, and no recording can be made. Before,
    exercise 7 ran to its end, then printed Rerun's warnings and a traceback (exit 1)."""
    result = subprocess.run([sys.executable, *[arg.format(tmp=tmp_path) for arg in args]], cwd=REPO, timeout=120,
                            capture_output=True, text=True, env={**os.environ, "RERUN": "off"})
    prog = "engine.py" if args[0] == "engine.py" else args[1]
    assert result.returncode == 0 and sorted(p.name for p in tmp_path.iterdir()) == files
    assert result.stderr == f"{prog}: note: RERUN=off is set, so no recording is made (as with --no-rerun)\n"
