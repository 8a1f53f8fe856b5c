"""The exercises, in both directions: right answers pass, untouched stubs and planted mistakes fail."""

import os
import re
import subprocess
import sys

import pytest

from conftest import REPO
from exercises import check_ex2, ex3_halve_dt

PLANTED = REPO / "tests" / "planted"
FIGURE = re.compile(r"\de[-+]\d|%|\d\.\d{2}")  # a measured number: 3.2e-04, 22.1%, 1.97


def run_exercise(module, *args, cwd):
    """`python -m exercises.<module> ARGS`, from a scratch folder so that any file written would show."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", f"exercises.{module}", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("module", ["ex1_runaway", "ex3_halve_dt", "ex4_long_run"])
def test_no_prediction_no_figures(module, tmp_path):
    result = run_exercise(module, cwd=tmp_path)
    assert result.returncode == 2
    question, choices, blank, how = result.stdout.splitlines()  # these four lines and nothing else
    assert question.endswith("?") and "--predict" in how and blank == ""
    assert not FIGURE.search(result.stdout), "a figure leaked before the prediction"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("module, bad", [("ex1_runaway", "verlet"), ("ex3_halve_dt", "euler=3"),
                                         ("ex4_long_run", "12")])
def test_a_prediction_outside_the_choices_is_one_line_and_exit_2(module, bad, tmp_path):
    result = run_exercise(module, "--predict", bad, cwd=tmp_path)
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1 and not FIGURE.search(result.stdout)


def test_ex1_grades_the_runaway_and_shows_the_evidence(tmp_path):
    right = run_exercise("ex1_runaway", "--predict", "euler", cwd=tmp_path)
    assert right.returncode == 0 and "Right: it is euler." in right.stdout
    assert "8x (16000 steps)" in right.stdout and "22.1%" in right.stdout
    wrong = run_exercise("ex1_runaway", "--predict", "rk4", cwd=tmp_path)
    assert "Not quite: you said rk4, but it is euler." in wrong.stdout
    assert list(tmp_path.iterdir()) == []


def test_ex3_ladders_settle_where_the_theory_says():
    errors = ex3_halve_dt.measure("orbit")
    settled = {name: ex3_halve_dt.settled(ex3_halve_dt.shrink_factors(e, ex3_halve_dt.FLOOR["position"]))
               for name, e in errors["position"].items()}
    assert {n: ex3_halve_dt.nearest_power_of_two(f) for n, f in settled.items()} == {
        "euler": 2, "semi_implicit": 2, "rk4": 16}
    # semi-implicit's coarse rungs behave like second order before settling (the exercise explains why)
    semi = ex3_halve_dt.shrink_factors(errors["position"]["semi_implicit"], 1e-10)
    assert semi[0] > 3.5 and abs(semi[-1] - 2) < 0.1
    # RK4's energy error shrinks faster than its position error: ~32 per halving on the spring
    spring = ex3_halve_dt.measure("spring")
    energy = ex3_halve_dt.shrink_factors(spring["energy"]["rk4"], ex3_halve_dt.FLOOR["energy"])
    assert all(abs(f - 32) < 1 for f in energy if f is not None)


def test_ex3_grades_each_integrator(tmp_path):
    right = run_exercise("ex3_halve_dt", "--predict", "euler=2,semi_implicit=2,rk4=16", cwd=tmp_path)
    assert right.returncode == 0 and "3 of 3." in right.stdout
    wrong = run_exercise("ex3_halve_dt", "--predict", "euler=2,semi_implicit=4,rk4=8", cwd=tmp_path)
    assert "1 of 3." in wrong.stdout and wrong.stdout.count("not quite") == 2
    assert list(tmp_path.iterdir()) == []


def test_ex4_finds_the_crossover_and_grades_the_horizon(tmp_path):
    result = run_exercise("ex4_long_run", "--predict", "10000", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    rows = re.findall(r"^\s*(0\.\d+)\s+(\S+)\s+([\d,]+)\s+([\d,]+)$", result.stdout, flags=re.M)
    assert [dt for dt, *_ in rows] == ["0.2", "0.14", "0.1"]
    orbits = [int(o.replace(",", "")) for *_, o in rows]
    assert orbits == sorted(orbits) and 3_162 <= orbits[-1] < 31_623  # nearest power of ten: 10,000
    assert "Right: about 10,000 orbits" in result.stdout and "not a thousand" in result.stdout
    assert "RK4 steps, still inside the band" in result.stderr  # progress while it runs
    assert list(tmp_path.iterdir()) == []


def test_ex2_untouched_stub_is_not_solved(capsys):
    assert check_ex2.main([]) == 1
    out = capsys.readouterr().out
    assert out.count("not solved yet") == 2 and "All solved" not in out


def test_ex2_reference_solution_passes(capsys):
    assert check_ex2.main([str(REPO / "exercises" / "solutions" / "ex2_integrators.py")]) == 0
    out = capsys.readouterr().out
    assert "semi_implicit_step: solved" in out and "rk4_step: solved" in out and "All solved." in out


PLANTED_HINTS = {
    "semi_as_explicit.py": ("semi_implicit_step", "still moves the position with the old velocity: that is explicit"),
    "semi_position_first.py": ("semi_implicit_step", "the other symplectic Euler: valid, and bounded"),
    "semi_sign_error.py": ("semi_implicit_step", "leaves semi-implicit Euler's trajectory on the orbit at step 1"),
    "rk4_equal_weights.py": ("rk4_step", "weighted 1-1-1-1"),
    "rk4_full_step.py": ("rk4_step", "your midpoint stages are a full dt out"),
}


@pytest.mark.parametrize("planted", PLANTED_HINTS)
def test_ex2_planted_mistake_fails_with_the_matching_hint(planted, capsys):
    wrong, hint = PLANTED_HINTS[planted]
    assert check_ex2.main([str(PLANTED / planted)]) == 1
    out = " ".join(capsys.readouterr().out.split())  # undo the line wrapping
    assert hint in out
    other = "rk4_step" if wrong == "semi_implicit_step" else "semi_implicit_step"
    assert f"{other}: solved" in out and f"{wrong}: solved" not in out
