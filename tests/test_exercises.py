"""The exercises, in both directions: right answers pass; the pristine stub and planted mistakes fail, each
with the message that names its mistake. The student's own exercises/ex2_integrators.py is never graded here,
so a student who solved it in place keeps a green suite.

Quick by default; the whole planted collection and exercise 4's full run are marked slow (pytest -m slow).
"""

import os
import re
import subprocess
import sys

import numpy as np
import pytest

import engine
from conftest import REPO
from curriculum.common.predict import Number, OneOf, PerName
from exercises import ex3_halve_dt, ex4_long_run

PLANTED = REPO / "tests" / "planted"
PRISTINE = REPO / "tests" / "pristine" / "ex2_integrators.py"
STUDENT = REPO / "exercises" / "ex2_integrators.py"
FIGURE = re.compile(r"\de[-+]\d|%|\d\.\d{2}")  # a measured number: 3.2e-04, 22.1%, 1.97


def run_exercise(module, *args, cwd):
    """`python -m exercises.<module> ARGS`, from a scratch folder so that any file written would show."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", f"exercises.{module}", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def one_line(text):
    return " ".join(text.split())  # undo the terminal wrapping


# --- predict, then run ---


@pytest.mark.parametrize("module", ["ex1_runaway", "ex3_halve_dt", "ex4_long_run"])
def test_no_prediction_no_figures(module, tmp_path):
    result = run_exercise(module, cwd=tmp_path)
    assert result.returncode == 0 and result.stderr == ""  # asking is not an error
    question, answers, blank, how = result.stdout.splitlines()  # these four lines and nothing else
    assert question.endswith("?") and answers.startswith("Answer with") and blank == ""
    assert how.endswith(f"python -m exercises.{module} --predict ANSWER")
    assert not FIGURE.search(result.stdout), "a figure leaked before the prediction"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("module, bad, forms", [
    ("ex1_runaway", "verlet", "one of euler, semi_implicit, rk4"),
    ("ex3_halve_dt", "euler=3, semi_implicit=2, rk4=16", "one of 1, 2, 4, 8, 16, 32"),
    ("ex3_halve_dt", "euler=2", "name=value for each of euler, semi_implicit, rk4"),
    ("ex4_long_run", "12", "one of 10, 100, 1,000, 10,000, 100,000 (written 10000, 10,000, 10_000 or 1e4,"),
])
def test_a_refused_prediction_is_one_line_that_lists_the_accepted_forms(module, bad, forms, tmp_path):
    result = run_exercise(module, "--predict", bad, cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == ""
    assert len(result.stderr.splitlines()) == 1 and forms in result.stderr


def test_predictions_parse_as_people_type_them():
    integrators = OneOf(engine.INTEGRATORS)
    assert [integrators.parse(t) for t in ("Euler", "RK4", " semi-implicit", "Semi Implicit")] == [
        "euler", "rk4", "semi_implicit", "semi_implicit"]
    orbits = Number([10, 100, 1_000, 10_000, 100_000])
    assert {orbits.parse(t) for t in ("10000", "10,000", "10_000", "10 000", "1e4", "1E4", "10000.0")} == {10_000}
    factors = PerName(engine.INTEGRATORS, [1, 2, 4, 8, 16, 32])
    expected = {"euler": 2, "semi_implicit": 4, "rk4": 16}
    for typed in ("euler=2,semi_implicit=4,rk4=16", "euler=2, semi_implicit=4, rk4=16",
                  "RK4 = 16; Euler: 2, semi-implicit=4"):
        assert factors.parse(typed) == expected
    for bad in ("ten", "1e400", "1.5", "12"):
        with pytest.raises(ValueError, match="written 10000, 10,000"):
            orbits.parse(bad)
    with_unit = Number([10, 100, 1_000], unit="orbit")
    assert with_unit.parse("1000 orbits") == with_unit.parse("10 Orbit") * 100 == 1_000
    for bad in ("orbits", "1000 apples"):
        with pytest.raises(ValueError, match="with or without 'orbits'"):
            with_unit.parse(bad)
    assert integrators.parse("RK-4") == "rk4" and integrators.parse("explicit Euler") == "euler"
    assert OneOf(["grows", "stays"]).forms == "one of grows, stays (any case)"  # no '_' to stand in for
    assert "(like euler=A, semi_implicit=B, rk4=C, with your value for each letter)" in factors.forms
    with pytest.raises(ValueError, match=r"in 'euler=\?', put your value where the \? is: one of 1, 2, 4"):
        factors.parse("euler=?, semi_implicit=?, rk4=?")  # the template typed as it is shown


def test_the_shell_splits_a_spaced_prediction_and_the_exercise_joins_it(tmp_path):
    result = run_exercise("ex3_halve_dt", "--predict", "euler=2,", "semi_implicit=3,", "rk4=16", cwd=tmp_path)
    assert result.returncode == 2 and "in 'semi_implicit=3', 3 is not one of 1, 2, 4, 8, 16, 32" in result.stderr


def test_predict_given_twice_counts_both_not_the_last_alone(tmp_path):
    twice = run_exercise("ex3_halve_dt", "--predict", "euler=2", "--predict", "semi_implicit=3,rk4=16", cwd=tmp_path)
    assert twice.returncode == 2 and "in 'semi_implicit=3', 3 is not one of" in twice.stderr  # euler=2 was read
    names = run_exercise("ex1_runaway", "--predict", "euler", "--predict", "rk4", cwd=tmp_path)
    assert names.returncode == 2 and "'euler rk4' is not one of euler" in names.stderr  # not graded as rk4


def test_ex1_grades_the_runaway_and_shows_the_evidence(tmp_path):
    wrong = run_exercise("ex1_runaway", "--predict", "RK4", cwd=tmp_path)
    assert wrong.returncode == 0 and "Not quite: you said rk4, but it is euler." in wrong.stdout
    assert "8x (16000 steps)" in wrong.stdout and "22.1%" in wrong.stdout
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_ex1_a_right_prediction_is_graded_right(tmp_path):
    right = run_exercise("ex1_runaway", "--predict", "Euler", cwd=tmp_path)
    assert right.returncode == 0 and "Right: it is euler." in right.stdout


@pytest.mark.parametrize("system_name", ["orbit", "spring"])
def test_ex3_every_rung_is_the_methods_own(system_name):
    """The ladders are chosen so that no factor needs a footnote: each is near its order's 2^p and heads there."""
    errors = ex3_halve_dt.measure(system_name)
    position = {name: ex3_halve_dt.shrink_factors(e, ex3_halve_dt.FLOOR["position"])
                for name, e in errors["position"].items()}
    for name in ("euler", "semi_implicit"):
        assert all(1.9 < f < 2.1 for f in position[name]), (name, position[name])
    assert all(13 < f < 19 for f in position["rk4"]) and abs(position["rk4"][-1] - 16) < 0.5
    gaps = [abs(f - 16) for f in position["rk4"]]
    assert gaps == sorted(gaps, reverse=True)  # RK4 comes to 16 monotonically, from one side
    energy = {name: ex3_halve_dt.shrink_factors(e, ex3_halve_dt.FLOOR["energy"])
              for name, e in errors["energy"].items()}
    assert None not in sum(energy.values(), []) + sum(position.values(), [])  # no rung sinks into round-off
    if system_name == "spring":
        assert all(abs(f - 32) < 1 for f in energy["rk4"])
    else:
        assert energy["rk4"] == sorted(energy["rk4"], reverse=True) and energy["rk4"][0] > 28 > 16 < energy["rk4"][-1]


@pytest.mark.slow
def test_ex3_a_right_prediction_scores_three_and_the_orbit_story_is_told(tmp_path):
    right = run_exercise("ex3_halve_dt", "--predict", "euler=2, semi_implicit=2, rk4=16", cwd=tmp_path)
    assert right.returncode == 0 and "3 of 3." in right.stdout
    assert "slides towards 16" in one_line(right.stdout)


def test_ex3_grades_each_integrator_and_explains_the_system_it_ran(tmp_path):
    wrong = run_exercise("ex3_halve_dt", "--predict", "euler=2,semi_implicit=4,rk4=8", "--system", "spring",
                         cwd=tmp_path)
    assert "1 of 3." in wrong.stdout and wrong.stdout.count("not quite") == 2
    told = one_line(wrong.stdout.split("What the ladder shows:")[1])
    assert "orbit" not in told and "32 at every rung" in told
    assert list(tmp_path.iterdir()) == []


def test_ex4_crossover_is_measured_through_engine_simulate():
    system = engine.build_system("orbit", np.random.default_rng(0))
    period = ex4_long_run.orbit_period(system)
    bands = ex4_long_run.semi_implicit_bands(system, [0.3, 0.01], period)
    crossed, chapter = ex4_long_run.rk4_crossovers(system, [0.3, 0.01], np.array([bands[0], np.inf]))
    assert 3_000 < crossed[0] < 4_500 and crossed[1] == -1  # 3,741 when measured
    assert len(chapter) == ex4_long_run.CHUNK + 1 and chapter[0] == 0 and 0 < chapter[-1] < 1e-9
    assert {"simulate", "rk4_step"} <= set(ex4_long_run.rk4_crossovers.__code__.co_names)  # the engine's loop


@pytest.mark.slow
def test_ex4_finds_the_crossover_and_grades_the_horizon(tmp_path):
    result = run_exercise("ex4_long_run", "--predict", "1,000", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    rows = re.findall(r"^\s*(0\.\d+)\s+(\S+)\s+([\d,]+)\s+([\d,]+)$", result.stdout, flags=re.M)
    assert [dt for dt, *_ in rows] == ["0.3", "0.25", "0.2"]
    orbits = [int(o.replace(",", "")) for *_, o in rows]
    assert orbits == sorted(orbits) and 316 <= orbits[-1] < 3_162  # nearest power of ten: 1,000
    assert "Right: it is about 1,000 orbits" in result.stdout and "not a thousand" in one_line(result.stdout)
    assert result.stderr == ""  # piped: no progress line redrawn with '\r' into a log (it shows on a terminal)
    assert list(tmp_path.iterdir()) == []
