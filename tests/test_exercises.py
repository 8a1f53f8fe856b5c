"""The predict-then-run exercises as a student meets them: the question and no figure, a refusal in one line, a
recording it cannot write refused before it measures; then what exercises 3, 4 and 5 measure. A right prediction's
whole run is ANSWERS.md's (tests/test_docs.py reruns it); exercise 4's full run is marked slow.
"""

import re

import numpy as np
import pytest
from test_docs import answers_with_their_commands

import engine
import engine_referee
from conftest import REPO, run_exercise
from curriculum.common.exercise import exercises
from exercises import ex3_halve_dt, ex4_long_run

FIGURE = re.compile(r"\de[-+]\d|%|\d\.\d{2}")  # a measured number: 3.2e-04, 22.1%, 1.97
PREDICT_THEN_RUN = [module for _, module, kind in exercises(REPO / "exercises") if kind == "predict"]
RECORDING = {"ex5_phase_blob": "euler=grows,semi_implicit=stays,rk4=shrinks",  # those that write a recording
             "ex7_shadow_energy": "spring=roundoff, orbit=smaller, freefall=roundoff"}


def one_line(text):
    return " ".join(text.split())  # undo the terminal wrapping


# --- predict, then run ---


@pytest.mark.parametrize("module", PREDICT_THEN_RUN)
def test_no_prediction_no_figures(module, tmp_path):
    """The question (exercise 7's with its formula), the accepted answers, how to commit; no figure, no file.
    tests/test_docs.py reads the same question, docstring and --help for words that give the answer away."""
    result = run_exercise(module, cwd=tmp_path)
    assert result.returncode == 0 and result.stderr == ""  # asking is not an error
    *question, answers, blank, how = result.stdout.splitlines()
    assert "?" in "\n".join(question) and answers.startswith("Answer with") and blank == ""
    assert how.endswith(f"python -m exercises.{module} --predict ANSWER [--because \"your reason\"]")
    assert not FIGURE.search(result.stdout.replace("dt 0.01", "")), "a figure leaked before the prediction"
    assert list(tmp_path.iterdir()) == []
    assert ("E~ = E - (dt/2) v . grad V(q) = E + (dt/2) v . F(q)" in result.stdout) == (module == "ex7_shadow_energy")


def test_more_goes_with_a_prediction(tmp_path):
    """--more asks for the whole explanation of a measurement: without --predict there is none to give."""
    result = run_exercise("ex1_band", "--more", cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == "exercises.ex1_band: error: --more goes with --predict: commit to a prediction too\n"


@pytest.mark.parametrize("module, bad, forms", [
    ("ex1_band", "euler=grows", "name=word for each of euler, semi_implicit, rk4"),
    ("ex3_halve_dt", "euler=3, semi_implicit=2, rk4=16", "one of 1, 2, 4, 8, 16, 32"),
    ("ex4_long_run", "12", "one of 10, 100, 1,000, 10,000, 100,000 (written 10000, 10,000, 10_000, 1e4 or 10k,"),
    ("ex5_phase_blob", "euler=grows,euler=grows,rk4=stays", "euler is given twice"),
    ("ex6_stiff_damping", "rk4, verlet", "'verlet' is not an integrator here"),
    ("ex7_shadow_energy", "spring=?,orbit=?,freefall=?", "put your value where the ? is"),
])
def test_a_refused_prediction_is_one_line_that_lists_the_accepted_forms(module, bad, forms, tmp_path):
    """Each exercise, one way to get it wrong (every refusal's wording: tests/test_predict.py)."""
    result = run_exercise(module, "--predict", bad, cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == ""
    assert len(result.stderr.splitlines()) == 1 and forms in result.stderr and "Traceback" not in result.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("module", RECORDING)
@pytest.mark.parametrize("target", ["a_file/x.rrd", "README.md", "exercises"])
def test_a_recording_path_it_cannot_write_is_one_line_before_measuring(module, target, tmp_path):
    """Under a file, or not an .rrd (a file or folder of the repo): one line, exit 2, nothing written."""
    (tmp_path / "a_file").write_text("")
    under_a_file = target.startswith("a_file")
    path = tmp_path / target if under_a_file else REPO / target
    before = path.stat().st_mtime_ns if path.exists() else None
    result = run_exercise(module, "--predict", RECORDING[module], "--rrd", str(path), cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == "" and len(result.stderr.splitlines()) == 1
    assert ("a_file is a file" if under_a_file else "does not end in .rrd") in result.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["a_file"] and (tmp_path / "a_file").read_text() == ""
    assert (path.stat().st_mtime_ns if path.exists() else None) == before


@pytest.mark.parametrize("system_name", ["orbit", "spring"])
def test_ex3_every_factor_shown_is_the_methods_own(system_name):
    """Each factor shown is near its order's 2^p and heads there; only RK4's finest rungs reach the round-off floor
    (where the printed digits would be rounding: 16.18 for an exact 16.16 on the orbit), and once there stay there."""
    errors = ex3_halve_dt.measure(system_name)
    position = {name: ex3_halve_dt.shrink_factors(e, ex3_halve_dt.FLOOR["position"])
                for name, e in errors["position"].items()}
    energy = {name: ex3_halve_dt.shrink_factors(e, ex3_halve_dt.FLOOR["energy"])
              for name, e in errors["energy"].items()}
    for name in ("euler", "semi_implicit"):
        assert all(1.9 < f < 2.1 for f in position[name]), (name, position[name])
        assert None not in position[name] + energy[name]  # the Eulers' errors stay far above rounding
    for factors in (position["rk4"], energy["rk4"]):
        shown = [f for f in factors if f is not None]
        assert len(shown) >= 3 and factors[: len(shown)] == shown  # round-off only at the fine end
    shown = [f for f in position["rk4"] if f is not None]
    assert all(13 < f < 19 for f in shown) and abs(shown[-1] - 16) < 0.5
    gaps = [abs(f - 16) for f in shown]
    assert gaps == sorted(gaps, reverse=True)  # RK4 comes to 16 monotonically, from one side
    shown = [f for f in energy["rk4"] if f is not None]
    if system_name == "spring":
        assert all(abs(f - 32) < 1 for f in shown)
    else:
        assert shown == sorted(shown, reverse=True) and shown[0] > 28 > 16 < shown[-1]
    if system_name == "orbit":  # the two rungs whose printed digits were round-off are not shown
        assert position["rk4"][-1] is None and energy["rk4"][-1] is None


def test_ex3_grades_each_integrator_and_explains_the_system_it_ran(tmp_path):
    wrong = run_exercise("ex3_halve_dt", "--predict", "euler=2,semi_implicit=4,rk4=8", "--system", "spring",
                         "--more", cwd=tmp_path)
    assert "Not quite: you said euler=2, semi_implicit=4, rk4=8, but euler 2, semi_implicit 2, rk4 16." in wrong.stdout
    assert wrong.stdout.count("not quite") == 2
    told = one_line(wrong.stdout.split("What the ladder shows:")[1])
    assert "orbit" not in told and "32 at every rung" in told
    assert "on the spring RK4's stays near 32" in one_line(wrong.stdout)  # the lesson comes first, for this system
    assert list(tmp_path.iterdir()) == []


def test_ex4_crossover_is_measured_through_engine_simulate():
    system = engine.build_system("orbit", np.random.default_rng(0))
    period = engine_referee.kepler_period(system["q0"], system["v0"], system["mu"])
    bands = ex4_long_run.semi_implicit_bands(system, [0.3, 0.01], period)
    crossed, chapter = ex4_long_run.rk4_crossovers(system, [0.3, 0.01], np.array([bands[0], np.inf]))
    assert 3_000 < crossed[0] < 4_500 and crossed[1] == -1  # 3,741 when measured
    assert len(chapter) == ex4_long_run.CHUNK + 1 and chapter[0] == 0 and 0 < chapter[-1] < 1e-9
    assert {"simulate", "rk4_step"} <= set(ex4_long_run.rk4_crossovers.__code__.co_names)  # the engine's loop


def test_ex4_finds_the_crossover_and_grades_the_horizon():
    """Its run as ANSWERS.md pastes it (tests/test_docs.py reruns it to the byte, its lesson test checks it is
    quiet on a pipe): the ladder's rows, more orbits at a smaller dt, the nearest power of ten graded."""
    (pasted,) = [out for command, out in answers_with_their_commands() if "-m exercises.ex4_long_run " in command]
    rows = re.findall(r"^\s*(0\.\d+)\s+(\S+)\s+([\d,]+)\s+([\d,]+)$", pasted, flags=re.M)
    assert [dt for dt, *_ in rows] == ["0.3", "0.25", "0.2"]
    orbits = [int(o.replace(",", "")) for *_, o in rows]
    assert orbits == sorted(orbits) and 316 <= orbits[-1] < 3_162  # nearest power of ten: 1,000
    assert "Right: it is about 1,000 orbits" in pasted and "not a thousand" in one_line(pasted)
