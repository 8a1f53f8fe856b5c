"""The exercises, in both directions: right answers pass; the pristine stub and planted mistakes fail, each
with the message that names its mistake. The student's own exercises/ex2_integrators.py is never graded here,
so a student who solved it in place keeps a green suite.

Quick by default; the whole planted collection and exercise 4's full run are marked slow (pytest -m slow).
"""

import ast
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import engine
from conftest import REPO
from exercises import check_ex2, ex3_halve_dt, ex4_long_run

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


@pytest.mark.parametrize("module", ["ex1_band", "ex3_halve_dt", "ex4_long_run"])
def test_no_prediction_no_figures(module, tmp_path):
    result = run_exercise(module, cwd=tmp_path)
    assert result.returncode == 0 and result.stderr == ""  # asking is not an error
    question, answers, blank, how = result.stdout.splitlines()  # these four lines and nothing else
    assert question.endswith("?") and answers.startswith("Answer with") and blank == ""
    assert how.endswith(f"python -m exercises.{module} --predict ANSWER")
    assert not FIGURE.search(result.stdout), "a figure leaked before the prediction"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("module, bad, forms", [
    ("ex1_band", "euler=grows", "name=word for each of euler, semi_implicit, rk4"),
    ("ex1_band", "euler=grows, semi_implicit=shrinks, rk4=grows", "one of grows, stays"),
    ("ex3_halve_dt", "euler=3, semi_implicit=2, rk4=16", "one of 1, 2, 4, 8, 16, 32"),
    ("ex3_halve_dt", "euler=2", "name=value for each of euler, semi_implicit, rk4"),
    ("ex4_long_run", "12", "one of 10, 100, 1,000, 10,000, 100,000 (written 10000, 10,000, 10_000, 1e4 or 10k,"),
])
def test_a_refused_prediction_is_one_line_that_lists_the_accepted_forms(module, bad, forms, tmp_path):
    result = run_exercise(module, "--predict", bad, cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == ""
    assert len(result.stderr.splitlines()) == 1 and forms in result.stderr


@pytest.mark.slow
def test_ex1_a_right_prediction_is_graded_right(tmp_path):
    right = run_exercise("ex1_band", "--predict", "Euler=grows, semi-implicit=stays, RK4=grows", cwd=tmp_path)
    assert right.returncode == 0 and "Right: euler grows, semi_implicit stays, rk4 grows." in right.stdout


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


def test_ex5_the_needles_area_change_is_the_shoelace_formulas_rounding_not_the_points():
    """At dt 1.05 the points' exact area changes by ~1e-11 (their rounding); the float shoelace says ~5e-9."""
    from exercises import ex5_phase_blob as ex5

    square = np.array([0.0, 1.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0, 1.0])
    assert ex5.exact_area(*square) == 1
    areas, x, v = ex5.run_blob("semi_implicit", ex5.PAST_LIMIT_DT, ex5.PAST_LIMIT_STEPS)
    exact_change = float(ex5.exact_area(x[-1], v[-1]) / ex5.exact_area(x[0], v[0]) - 1)
    assert abs(exact_change) < 1e-10 < 1e-9 < abs(areas[-1] / areas[0] - 1)  # +2.4e-11 and -4.7e-9 when measured


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
    period = engine.kepler_period(system["q0"], system["v0"], system["mu"])
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


# --- exercise 2: the stub, the solution, and the student's file ---


def check(path, capsys):
    code = check_ex2.main([str(path)])
    return code, one_line(capsys.readouterr().out)


def test_ex2_pristine_stub_is_not_solved(capsys):
    code, out = check(PRISTINE, capsys)
    assert code == 1 and out.count("not solved yet. It still raises NotImplementedError") == 2
    assert "All solved" not in out


def test_ex2_reference_solution_passes(capsys):
    code, out = check(REPO / "exercises" / "solutions" / "ex2_integrators.py", capsys)
    assert code == 0 and "semi_implicit_step: solved" in out and "rk4_step: solved" in out
    assert out.endswith("All solved.")
    # exercise 3 asks by what factor halving dt shrinks each error: passing exercise 2 must not say
    assert "divide" not in out and not re.search(r"\border \d", out), out


def test_ex2_reference_rk4_is_the_engines_rk4_line_for_line():
    def body(source):
        function = next(n for n in ast.walk(ast.parse(source))
                        if isinstance(n, ast.FunctionDef) and n.name == "rk4_step")
        return [ast.dump(statement) for statement in function.body[1:]]  # without the docstring

    solution = (REPO / "exercises" / "solutions" / "ex2_integrators.py").read_text()
    assert body(solution) == body((REPO / "engine.py").read_text())


def instructions(source):
    """What the stub tells the student: module docstring, and each function's name, signature and docstring."""
    tree = ast.parse(source)
    return [ast.get_docstring(tree)] + [(f.name, ast.dump(f.args), ast.get_docstring(f))
                                        for f in tree.body if isinstance(f, ast.FunctionDef)]


def test_ex2_the_students_file_still_carries_the_stubs_instructions():
    """The pristine copy is what the tests grade, so it must stay the stub a student starts from: a maintainer
    who edits the stub edits tests/pristine/ too. Once a student has started (a TODO filled in), their file is
    theirs, docstring or not, and is not judged here."""
    if STUDENT.read_text().count("raise NotImplementedError") < 2:
        pytest.skip("exercises/ex2_integrators.py has been worked on: only the untouched stub is compared")
    try:
        student = instructions(STUDENT.read_text())
    except SyntaxError:
        pytest.skip("exercises/ex2_integrators.py does not parse right now: run python -m exercises.check_ex2")
    pristine = instructions(PRISTINE.read_text())
    assert student[0] == pristine[0], "the module docstrings of the stub and tests/pristine/ differ"
    for item in pristine[1:]:
        assert item in student[1:], f"{item[0]}: signature or docstring differ between the stub and tests/pristine/"


# Every planted file: the function it gets wrong (None: a right file, both must pass) and what the checker says.
PLANTED_MESSAGES = {
    "semi_as_explicit.py": ("semi_implicit_step", "still moves the position with the old velocity: that is explicit"
                                                  " Euler. On the orbit its energy error is 22.1% after the chapter's"
                                                  " 2,000 steps"),
    "semi_position_first.py": ("semi_implicit_step", "That is the other symplectic Euler: valid, and bounded"),
    "semi_sign_error.py": ("semi_implicit_step", "not semi-implicit Euler yet, and not one of the usual mistakes."
                                                 " What the checker measured: It differs from semi-implicit Euler on"
                                                 " every system, the chapter's spring included."),
    "semi_forgot_mass.py": ("semi_implicit_step", "you forgot to divide by m"),
    "semi_mass_twice.py": ("semi_implicit_step", "you divide the force by m twice"),
    "semi_times_mass.py": ("semi_implicit_step", "you multiply the force by m where the acceleration is force / m"),
    "semi_velocity_verlet.py": ("semi_implicit_step", "this is a second-order method (velocity Verlet, leapfrog"),
    "semi_leapfrog.py": ("semi_implicit_step", "this is a second-order method (velocity Verlet, leapfrog"),
    "semi_taylor.py": ("semi_implicit_step", "you move the position by v dt + a dt^2 / 2, the Taylor step"),
    "semi_new_velocity_without_dt.py": ("semi_implicit_step", "adds the new velocity without multiplying it by dt"),
    "semi_hardcoded_force.py": ("semi_implicit_step", "it never calls force"),
    "semi_in_place.py": ("semi_implicit_step", "it changes the q array it was given"),
    "semi_sys_exit.py": ("semi_implicit_step", "your code calls sys.exit() or exit() (exit code 0) in"
                                               " semi_implicit_step(), semi_sys_exit.py line 9: sys.exit(0)."),
    "semi_os_exit.py": ("semi_implicit_step", "the checker's run of your file ended by itself (exit code 0) during"
                                              " one step on"),
    "semi_endless.py": ("semi_implicit_step", "without returning. Is there a loop that never ends"),
    "semi_slow.py": ("semi_implicit_step", "every single step returned, but the thousands of steps of a whole run did"
                                           " not finish in time"),
    "semi_returns_none.py": ("semi_implicit_step", "returns None: the function ends without `return q_next, v_next`"),
    "semi_returns_one.py": ("semi_implicit_step", "returns one array of shape (3,); it must return two"),
    "semi_signature_changed.py": ("semi_implicit_step", "you changed its signature to"
                                                        " semi_implicit_step(q, v, force, m, dt)"),
    "semi_delegates_engine.py": ("semi_implicit_step", "it hands the work to engine.semi_implicit_step"),
    "semi_delegates_solution.py": ("semi_implicit_step", "it hands the work to exercises/solutions/ex2_integrators.py"),
    "semi_raises.py": ("semi_implicit_step", "it raised NameError: name 'v_nxt' is not defined in semi_implicit_step(),"
                                             " semi_raises.py line 9: return q + v_nxt * dt"),
    "semi_patches_engine.py": ("semi_implicit_step", "that is explicit Euler"),
    "semi_swapped_return.py": ("semi_implicit_step", "your numbers are right but returned in the wrong order"),
    "semi_float32.py": ("semi_implicit_step", "they agree to about 7 digits, where the same arithmetic agrees to 15"),
    "rk4_dt_twice.py": ("rk4_step", "every change your step makes is dt times RK4's: dt multiplies your update twice"),
    "rk4_stacked_return.py": ("rk4_step", "returns one array of shape (6,); it must return two, (q_next, v_next)"
                                          " (for a stacked state y, return y[:3], y[3:])"),
    "rk4_equal_weights.py": ("rk4_step", "your four slopes are weighted 1-1-1-1"),
    "rk4_full_step.py": ("rk4_step", "your midpoint stages are a full dt out"),
    "rk4_forgot_mass.py": ("rk4_step", "you forgot to divide by m"),
    "rk4_mass_twice.py": ("rk4_step", "you divide the force by m twice"),
    "rk4_times_mass.py": ("rk4_step", "you multiply the force by m"),
    "rk4_stage_velocity_not_passed.py": ("rk4_step", "your stages never hand their velocity to the force"),
    "rk4_all_slopes_at_start.py": ("rk4_step", "that is explicit Euler in disguise"),
    "rk4_midpoint_rk2.py": ("rk4_step", "this is the midpoint method, RK2"),
    "rk4_heun.py": ("rk4_step", "this is Heun's method, a second-order Runge-Kutta"),
    "rk4_weights_over_4.py": ("rk4_step", "the weights of your final blend add up to 1.5, not 1"),
    "rk4_weights_over_3.py": ("rk4_step", "the weights of your final blend add up to 2, not 1"),
    "rk4_missing_dt.py": ("rk4_step", "your final update has no dt in it"),
    "rk4_k2_full_step.py": ("rk4_step", "your k2 is sampled a whole dt out; it is a midpoint slope"),
    "rk4_k3_full_step.py": ("rk4_step", "your k3 is sampled a whole dt out; it is a midpoint slope"),
    "rk4_rounded_sixth.py": ("rk4_step", "close to 1, but not 1. Is a fraction written as a rounded decimal"),
    "rk4_weights_2112.py": ("rk4_step", "comes out second order (halving dt divides its error by 4.1 on a spring): the"
                            " slopes are probably fine and the blend is not"),
    "rk4_three_eighths.py": ("rk4_step", "this is Kutta's 3/8 rule: a fourth-order method"),
    "rk4_position_slopes_start.py": ("rk4_step", "your position slopes are all the starting velocity"),
    "rk4_k3_along_k1.py": ("rk4_step", "your k3 steps along k1 instead of k2"),
    "rk4_k4_half.py": ("rk4_step", "your k4 is sampled half a step out"),
    "rk4_hardcoded_force.py": ("rk4_step", "it never calls force"),
    "rk4_k2_without_mass.py": ("rk4_step", "not RK4 yet, and not one of the usual mistakes. What the checker measured:"
                                           " It is right whenever m = 1 and wrong when m is 2.5 or 0.7"),
    "rk4_signature_changed.py": ("rk4_step", "you changed its signature to rk4_step(q, v, force, m, dt)"),
    "rk4_delegates_engine.py": ("rk4_step", "it hands the work to engine.rk4_step"),
    "right_other_order.py": (None, ""),
    "right_butcher.py": (None, ""),
    "right_stacked.py": (None, ""),
    "right_np_add.py": (None, ""),
    "right_helper_module.py": (None, ""),
    "right_chatty.py": (None, "Your code printed"),
}
# A quick sample (mass, velocity, a fourth-order impostor, an unanticipated slip, a right variant); pytest -m slow
# runs them all.
QUICK = {"semi_forgot_mass.py", "rk4_stage_velocity_not_passed.py", "rk4_three_eighths.py", "rk4_k2_without_mass.py",
         "right_stacked.py"}


def test_every_planted_file_has_its_expected_message():
    planted = {p.name for p in PLANTED.glob("*.py") if not p.name.startswith("_")}
    assert planted == set(PLANTED_MESSAGES)


@pytest.mark.parametrize("planted", [pytest.param(name, marks=() if name in QUICK else pytest.mark.slow)
                                     for name in PLANTED_MESSAGES])
def test_ex2_planted_file_gets_the_message_that_names_it(planted, capsys, monkeypatch):
    if planted in ("semi_endless.py", "semi_slow.py"):
        monkeypatch.setattr(check_ex2, "TIME_LIMIT", 4.0)  # the loop is stopped, not waited for
    wrong, message = PLANTED_MESSAGES[planted]
    code, out = check(PLANTED / planted, capsys)
    assert message in out
    assert "Traceback" not in out
    if wrong is None:
        assert code == 0 and out.endswith("All solved.")
    else:
        other = "rk4_step" if wrong == "semi_implicit_step" else "semi_implicit_step"
        assert code == 1 and f"{other}: solved" in out and f"{wrong}: solved" not in out


@pytest.mark.slow
def test_ex2_a_step_that_never_returns_is_stopped_and_the_other_still_judged(capsys, monkeypatch):
    monkeypatch.setattr(check_ex2, "TIME_LIMIT", 2.0)
    code, out = check(PLANTED / "semi_endless.py", capsys)
    assert code == 1 and "semi_implicit_step: stopped after 2 s during one step on" in out
    assert "rk4_step: solved" in out


@pytest.mark.slow
def test_ex2_a_file_whose_import_never_ends_is_stopped_once_for_both(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(check_ex2, "TIME_LIMIT", 2.0)
    (tmp_path / "slow_import.py").write_text("import time\n\ntime.sleep(600)  # a trial run left at the top level\n")
    code, out = check(tmp_path / "slow_import.py", capsys)
    assert code == 1 and out.count("importing your file did not finish within 2 s") == 2


def test_ex2_the_students_code_cannot_decide_the_exit_code(tmp_path):
    """Through the real command: a file that patches engine at import time is judged by an engine it cannot reach
    (sys.exit(0) and os._exit(0) are in the planted collection)."""
    for planted in ("semi_patches_engine.py",):
        result = subprocess.run([sys.executable, "-m", "exercises.check_ex2", str(PLANTED / planted)], cwd=REPO,
                                capture_output=True, text=True, timeout=120)
        assert result.returncode == 1 and "Not solved yet" in result.stdout and result.stderr == "", planted


# --- exercise 2: files that are not steps at all; never a traceback ---


BROKEN = {
    "indented.py": (b"def semi_implicit_step(q, v, m, force, dt):\nreturn q, v\n",
                    "indented.py, line 2: IndentationError: expected an indented block after function definition on"
                    " line 1. The lines of one block must start in the same column"),
    "tabs.py": (b"def semi_implicit_step(q, v, m, force, dt):\n    a = 1\n\treturn q, v\n",
                "tabs.py, line 3: TabError: inconsistent use of tabs and spaces in indentation. Indent with spaces"),
    "syntax.py": (b"def rk4_step(q, v, m, force, dt)\n    return q, v\n",
                  "syntax.py, line 1: SyntaxError: expected ':'. def rk4_step(q, v, m, force, dt) ^"),
    "latin1.py": (b"# caf\xe9\ndef rk4_step(q, v, m, force, dt):\n    return q, v\n",
                  "latin1.py, line 1: this line is not valid utf-8 text (byte 0xe9); save the file as UTF-8. # caf"),
    "nul.py": (b"def rk4_step(q, v, m, force, dt):\n    return q,\x00 v\n",
               "nul.py, line 2: the file contains a null byte (\\0), which Python source cannot hold"),
}


@pytest.mark.parametrize("name", BROKEN)
def test_ex2_a_file_that_does_not_compile_gets_file_line_and_the_line(name, tmp_path, capsys):
    source, message = BROKEN[name]
    (tmp_path / name).write_bytes(source)
    code, out = check(tmp_path / name, capsys)
    assert code == 1 and message in out and "Traceback" not in out


@pytest.mark.parametrize("name, message", [
    ("solution.txt", "solution.txt is not a Python file: the checker imports your steps"),
    ("sol.PY", "sol.PY ends in .PY: Python imports only files ending in .py"),
    ("missing.py", "there is no file"),
    ("a_folder", "is a folder; give the .py file that defines semi_implicit_step and rk4_step"),
])
def test_ex2_what_is_not_a_python_file_gets_a_sentence_and_exit_2(name, message, tmp_path):
    if name == "a_folder":
        (tmp_path / name).mkdir()
    elif name != "missing.py":
        (tmp_path / name).write_text("def rk4_step(q, v, m, force, dt):\n    return q, v\n")
    result = subprocess.run([sys.executable, "-m", "exercises.check_ex2", str(tmp_path / name)], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and result.stdout == "" and message in result.stderr
    assert len(result.stderr.splitlines()) == 1


def test_ex2_help_works_and_extra_arguments_are_refused():
    run = [sys.executable, "-m", "exercises.check_ex2"]
    shown = subprocess.run([*run, "--help"], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert shown.returncode == 0 and "usage:" in shown.stdout and "child process" not in shown.stderr
    extra = subprocess.run([*run, "a.py", "b.py"], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert extra.returncode == 2 and "unrecognized arguments: b.py" in extra.stderr
    assert len(extra.stderr.splitlines()) == 1


def test_ex2_the_students_folder_is_importable_and_an_exception_names_the_line(tmp_path, capsys):
    (tmp_path / "helpers.py").write_text("def accel(force, q, v, m):\n    return force(q, v) / m\n")
    (tmp_path / "mine.py").write_text(
        "from helpers import accel\n\n\n"
        "def semi_implicit_step(q, v, m, force, dt):\n"
        "    v_next = v + dt * accel(force, q, v, m)\n"
        "    return q + dt * v_next, v_next\n\n\n"
        "def rk4_step(q, v, m, force, dt):\n"
        "    return force(q) / m, v\n")
    code, out = check(tmp_path / "mine.py", capsys)
    assert code == 1 and "semi_implicit_step: solved" in out
    assert ("rk4_step: it raised TypeError:" in out and "missing 1 required positional argument: 'v'" in out
            and "in rk4_step(), mine.py line 10: return force(q) / m, v." in out)
