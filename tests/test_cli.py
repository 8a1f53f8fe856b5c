"""engine.py and the exercises as a student runs them: the default run, the README's commands, bad input in one
line (exit 2, nothing touched), what was typed coming back escaped and short, a recording that cannot be made."""

import importlib
import os
import re
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


def test_two_smoke_runs_write_identical_bytes_and_say_nothing_on_stderr(tmp_path):
    runs = [run_engine("--smoke", "--no-rerun", "--out", tmp_path / name) for name in ("a", "b")]
    assert [(run.returncode, run.stderr) for run in runs] == [(0, "")] * 2
    assert (tmp_path / "a" / "metrics.json").read_bytes() == (tmp_path / "b" / "metrics.json").read_bytes()


def test_a_name_the_output_encoding_cannot_show_prints_escaped(tmp_path):
    """A terminal or a redirected stdout narrower than UTF-8 (Windows' cp1252 in a file): no UnicodeEncodeError."""
    ascii_only = {**os.environ, "PYTHONIOENCODING": "ascii"}
    result = run_engine("--smoke", "--no-rerun", "--out", tmp_path / "\u0394t", env=ascii_only)
    assert (result.returncode, result.stderr) == (0, "") and "\\u0394t" in result.stdout


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
    "seed of 4,301 nines": (["--seed", "9" * 4301], "got 999999999999999999999999...9999999999999 (see"),
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


def test_help_states_the_step_limit(capsys):
    with pytest.raises(SystemExit) as stop:
        chapter.main(["--help"])
    assert stop.value.code == 0 and "10,000,000" in capsys.readouterr().out


@pytest.mark.slow
def test_a_long_run_shows_progress_on_stderr(tmp_path, capsys):
    assert chapter.main(["--integrator", "euler", "--steps", "300000", "--no-rerun", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().err.splitlines()[-1].split() == ["euler", "100%", "of", "300,000", "steps"]


def test_no_rerun_never_imports_rerun(tmp_path):
    code = ("import sys, engine; engine.main(['--smoke', '--no-rerun', '--out', sys.argv[1]]);"
            "print('rerun imported:', any(m.split('.')[0] == 'rerun' for m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, cwd=REPO)
    assert result.returncode == 0 and result.stdout.strip().endswith("rerun imported: False")


def test_readme_links_point_at_files_that_exist():
    links = re.findall(r"\]\(([^)#]+)\)", (REPO / "README.md").read_text())
    assert "exercises/README.md" in links and "docs/DEVELOPING.md" in links
    for link in links:
        assert (REPO / link).is_file(), link


@pytest.mark.parametrize("exercise", [name for _, name, kind in exercises(REPO / "exercises") if kind == "predict"])
def test_every_exercise_answers_a_mistyped_flag_in_one_line(exercise, capsys):
    with pytest.raises(SystemExit) as stop:
        importlib.import_module(f"exercises.{exercise}").main(["--predcit", "x"])
    assert stop.value.code == 2 and capsys.readouterr() == ("", f"exercises.{exercise}: error: unrecognized arguments:"
                                                                " --predcit x; did you mean --predict? (see --help)\n")


LONG = "x" * 5000
BLOB = "euler=grows,semi_implicit=stays,rk4=shrinks"  # a prediction for exercise 5
SHADOW = "spring=roundoff,orbit=smaller,freefall=roundoff"  # and for exercise 7


@pytest.mark.parametrize("args", [["engine.py", f"--{LONG}"], ["engine.py", LONG], ["check_ex2", f"{LONG}.py"],
                                  ["engine.py", "--out", "a\nb\nc"], ["engine.py", "--out", "a\x1b[2Jb"],
                                  ["engine.py", "--sys\x1b[2Jtem", "orbit"], ["engine.py", "--system", "\u202eorbit"],
                                  ["check_ex2", "a\x1b[2J.py"],
                                  ["ex5_phase_blob", "--predict", BLOB, "--rrd", "a\x1b.rrd"]])
def test_what_was_typed_comes_back_short_and_escaped(args, tmp_path, capsys, monkeypatch):
    """Before: one line of 5,057 characters or more; an --out holding a newline gave three lines; escape sequences
    and bidi overrides reached the terminal. (Each program's main() in this process, as `python -m` runs it.)"""
    monkeypatch.chdir(tmp_path)
    program = chapter if args[0] == "engine.py" else importlib.import_module(f"exercises.{args[0]}")
    with pytest.raises(SystemExit) as stop:
        program.main(args[1:])
    out, err = capsys.readouterr()
    assert stop.value.code == 2 and out == "" and len(err.splitlines()) == 1, err
    assert len(err) < 300 and not re.search("[\x00-\x09\x0b-\x1f\u202a-\u202e]", err), err
    assert "xxx...xxx" in err or "\\n" in err or "\\x1b" in err or "\\u202e" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args", [["engine.py", "--out", "{tmp}/out"],
                                  ["-m", "exercises.ex7_shadow_energy", "--predict", SHADOW, "--rrd", "{tmp}/x.rrd"]])
def test_a_recording_a_broken_rerun_cannot_make_is_one_line_before_the_run(args, tmp_path):
    """Before: Rerun's traceback, once the run had gone to its end."""
    fake = tmp_path / "site" / "rerun"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("from rerun_bindings import a_name_this_build_lacks\n")  # a half-installed SDK
    result = subprocess.run([sys.executable, *[arg.format(tmp=tmp_path) for arg in args]], cwd=REPO, timeout=120,
                            capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(tmp_path / "site")})
    assert (result.returncode, result.stdout, len(result.stderr.splitlines())) == (2, "", 1), result.stderr
    assert "pip install -e ." in result.stderr and "--no-rerun" in result.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["site"]


@pytest.mark.parametrize("args, files", [(["engine.py", "--smoke", "--out", "{tmp}"], ["metrics.json"]),
                                         (["-m", "exercises.ex7_shadow_energy", "--predict", SHADOW,
                                           "--rrd", "{tmp}/x.rrd"], [])])
def test_rerun_switched_off_is_no_rerun_with_one_line(args, files, tmp_path):
    """RERUN=off is Rerun's own switch: every Rerun call then only warns, and no recording can be made. Before,
    exercise 7 ran to its end, then printed Rerun's warnings and a traceback (exit 1)."""
    result = subprocess.run([sys.executable, *[arg.format(tmp=tmp_path) for arg in args]], cwd=REPO, timeout=120,
                            capture_output=True, text=True, env={**os.environ, "RERUN": "off"})
    prog = "engine.py" if args[0] == "engine.py" else args[1]
    assert result.returncode == 0 and sorted(p.name for p in tmp_path.iterdir()) == files
    assert result.stderr == f"{prog}: note: RERUN=off is set, so no recording is made (as with --no-rerun)\n"
