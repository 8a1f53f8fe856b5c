"""Exercise 2's checker, both directions: right files pass, the stub and every planted file get the message
that names them (tests/planted/), never a traceback. The student's own exercises/ex2_integrators.py is never
graded here. The whole planted collection is slow; a quick sample runs by default."""

import ast
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO
from curriculum.common import student_code
from exercises import check_ex2

PLANTED = REPO / "tests" / "planted"
PRISTINE = REPO / "exercises" / "support" / "pristine" / "ex2_integrators.py"
STUDENT = REPO / "exercises" / "ex2_integrators.py"
SEMI, RK4 = "semi_implicit_step", "rk4_step"


def one_line(text):
    return " ".join(text.split())  # undo the terminal wrapping


def check(path, capsys):
    code = check_ex2.main([str(path)])
    return code, one_line(capsys.readouterr().out)


def test_pristine_stub_is_not_solved(capsys):
    code, out = check(PRISTINE, capsys)
    assert code == 1 and out.count("not solved yet. It still raises NotImplementedError") == 2


def test_reference_solution_passes_and_says_no_order(capsys):
    code, out = check(REPO / "exercises" / "solutions" / "ex2_integrators.py", capsys)
    assert code == 0 and out.count(": solved: the engine's") == 2 and out.endswith("All solved.")
    assert "divide" not in out and not re.search(r"\border \d", out), out  # exercise 3's question


def test_reference_rk4_is_the_engines_rk4_line_for_line():
    def body(source):
        function = next(n for n in ast.walk(ast.parse(source)) if isinstance(n, ast.FunctionDef) and n.name == RK4)
        return [ast.dump(statement) for statement in function.body[1:]]

    solution = (REPO / "exercises" / "solutions" / "ex2_integrators.py").read_text()
    assert body(solution) == body((REPO / "engine.py").read_text())


def instructions(source):
    """What the stub tells the student: module docstring, and each function's name, signature and docstring."""
    tree = ast.parse(source)
    return [ast.get_docstring(tree)] + [(f.name, ast.dump(f.args), ast.get_docstring(f))
                                        for f in tree.body if isinstance(f, ast.FunctionDef)]


def test_the_students_file_still_carries_the_stubs_instructions():
    """Graded is exercises/support/pristine/'s copy; a maintainer who edits the stub edits that copy too. Once a
    student has started (a TODO filled in), their file is theirs and is not compared."""
    if STUDENT.read_text().count("raise NotImplementedError") < 2:
        pytest.skip("exercises/ex2_integrators.py has been worked on: only the untouched stub is compared")
    try:
        student = instructions(STUDENT.read_text())
    except SyntaxError:
        pytest.skip("exercises/ex2_integrators.py does not parse right now: run python -m exercises.check_ex2")
    pristine = instructions(PRISTINE.read_text())
    assert student[0] == pristine[0], "the module docstrings of the stub and exercises/support/pristine/ differ"
    for item in pristine[1:]:
        assert item in student[1:], f"{item[0]}: signature or docstring differ between the stub and its pristine copy"


NOT_MEASURED = ("right_spawns_sleeper.py", "right_chatty.py", "right_prints_every_call.py")  # only their messages
RIGHTS = sorted(p.name for p in PLANTED.glob("right_*.py") if p.name not in NOT_MEASURED) + ["_right.py"]


@pytest.mark.parametrize("name", [pytest.param(n, marks=() if n == "right_np_add.py" else pytest.mark.slow)
                                  for n in RIGHTS])
def test_the_stated_tolerance_holds_for_every_planted_right_file(name):
    """RIGHT_GAP is measured: the planted right files (other roundings of the same arithmetic) stay within it on
    every run, right_np_add.py sets it, and the engine's own order on the ladder sits inside the stated band."""
    tasks = check_ex2.every()
    run = student_code.collect(PLANTED / name, "exercises.support.ex2_cases", tasks, check_ex2.PROG)
    worst = 0.0
    for function in check_ex2.METHODS:
        indices = [i for i, t in enumerate(tasks) if t["function"] == function]
        measured = check_ex2.Measured(function, [run.results[i] for i in indices],
                                      [check_ex2.ex2_cases.collect(check_ex2.ENGINE, tasks[i]) for i in indices])
        worst = max(worst, *(float(np.max(gap)) for gap in measured.gaps))
        order = measured.order("heavy_damped_spring", measured.engine_runs)[2]
        assert abs(order - check_ex2.METHODS[function][2]) <= 0.25, (function, order)  # the ladders measure order
    assert worst <= check_ex2.RIGHT_GAP
    if name == "right_np_add.py":
        assert worst > check_ex2.RIGHT_GAP * 0.99, worst


# Every planted file: the function it gets wrong (None: right, both pass; "both": both fail; "any": a
# forgery, which only has to end in a sentence) and what the checker says.
PLANTED_MESSAGES = {
    "semi_as_explicit.py": (SEMI, "that is explicit Euler. On the chapter's orbit its energy error reaches 22.1% in"
                                  " 2,000 steps. Which velocity should move the position?"),
    "semi_position_first.py": (SEMI, "the other symplectic Euler, bounded too (on the chapter's orbit its energy"
                                     " error stays within 3.2e-04 over 2,000 steps)"),
    "semi_sign_error.py": (SEMI, "your velocity changes against the force"),
    "semi_force_ahead.py": (SEMI, "you take the force a step ahead, where the old velocity would carry the position"),
    "semi_right_only_at_chapter_dt.py": (SEMI, "that is explicit Euler. On the chapter's orbit its energy error"
                                               " reaches 22.1% in 2,000 steps"),
    "semi_picks_by_hash.py": (SEMI, "that is explicit Euler"),  # on every run: the child's hash seed is fixed
    "semi_varies_between_calls.py": (SEMI, "its results vary between calls: called twice in a row from the same"
                                           " state, it returned different numbers on 28 of 28 single steps"),
    "semi_forgot_mass.py": (SEMI, "It is right whenever m = 1 and wrong on a spring with m = 2.5"),
    "semi_mass_twice.py": (SEMI, "where does m enter your step?"),
    "semi_times_mass.py": (SEMI, "where does m enter your step?"),
    "semi_velocity_verlet.py": (SEMI, "this is velocity Verlet (leapfrog's twin: a half kick, a drift, a half kick):"
                                      " halving dt divides its error by 4.0 on a spring with m = 2.5"),
    "semi_leapfrog.py": (SEMI, "this is the drift-kick-drift leapfrog: halving dt divides its error by 4.0"),
    "semi_taylor.py": (SEMI, "velocity Verlet's Taylor step. Which velocity moves the position"),
    "semi_new_velocity_without_dt.py": (SEMI, "adds a velocity without multiplying it by dt"),
    "semi_hardcoded_force.py": (SEMI, "it never calls force"),
    "semi_in_place.py": (SEMI, "it changes the q and v it was given (an in-place update)"),
    "semi_sys_exit.py": (SEMI, "your code ends Python with sys.exit() or exit() (exit code 0) during single steps"),
    "semi_os_exit.py": (SEMI, "ended by itself (exit code 0) during single steps from fresh states"),
    "semi_returns_none.py": (SEMI, "returns None: the function ends without returning (q_next, v_next)"),
    "semi_returns_one.py": (SEMI, "returns one array of shape (3,); it must return 2, (q_next, v_next)"),
    "semi_returns_lists.py": (SEMI, "your function returns a list, not a numpy array; a whole run hands each step"
                                    " what the one before returned, then it raised TypeError"),
    "semi_signature_changed.py": (SEMI, "you changed its signature to semi_implicit_step(q, v, force, m, dt)"),
    "semi_raises.py": (SEMI, "it raised NameError: name 'v_nxt' is not defined in semi_implicit_step(), line 9 of"
                             " semi_raises.py"),
    "semi_patches_engine.py": (SEMI, "that is explicit Euler"),
    "semi_swapped_return.py": (SEMI, "your numbers are right but returned in the wrong order"),
    "semi_float32.py": (SEMI, "agree with semi-implicit Euler's to about 7 digits, where the same arithmetic agrees"
                              " to 15"),
    "semi_rounds_outputs.py": (SEMI, "to about 3 digits"),
    "semi_aliasing_buffers.py": (SEMI, "every single step from a fresh state matches the engine's semi-implicit"
                                       " Euler, but a whole run, each step fed its own output, does not: on the"
                                       " chapter's orbit (m = 1), at dt 0.01, it parts from the engine's at step 2 of"
                                       " 2,000, where the engine's speed is 1.01 m/s, and ends in inf or NaN. From"
                                       " step 2 of a run on, the arrays it returns share memory"),
    "semi_defined_twice.py": (SEMI, "not solved yet. It still raises NotImplementedError: fill in its TODO. It is"
                                    " defined 2 times in your file (lines 9, 26): Python keeps the last one, line 26"),
    "semi_force_list.py": (SEMI, "it raised TypeError: can't multiply sequence by non-int of type 'list' in"
                                 " semi_implicit_step(), line 10 of semi_force_list.py: a = force(list(q), v) / m."),
    "semi_force_extra_arg.py": (SEMI, "it raised TypeError: force() takes 2 positional arguments but 3 were given in"
                                      " semi_implicit_step(), line 10 of semi_force_extra_arg.py"),
    "semi_delegates_engine.py": ("any", ""),
    "semi_delegates_solution.py": ("any", ""),
    "rk4_delegates_engine.py": ("any", ""),
    "both_forges_output.py": ("both", "your file ended Python while it was being imported (exit code 0)"),
    "both_reads_stdin.py": ("both", "it raised EOFError: EOF when reading a line in <module>(), line 4 of"
                                    " both_reads_stdin.py"),
    "both_returns_junk.py": ("both", "returns a q_next that is not numbers: str"),
    "both_floods_without_newlines.py": ("both", "importing your file did not finish within 3 s"),
    "both_forges_answers.py": ("both", "your file's run did not finish: what it sent back could not be read"),
    "both_clamp_velocity.py": ("both", "on the chapter's freefall (m = 1), at dt 0.01, it parts from the engine's at"
                                       " step 204 of 2,000, where the engine's speed is 20.3 m/s, and ends 1.58e+03 m"
                                       " away"),
    "rk4_stateful_reuses_slope.py": (RK4, "every single step from a fresh state matches the engine's RK4, but a whole"
                                          " run, each step fed its own output, does not: on an orbit with drag, m ="
                                          " 0.7, at dt 0.01, it parts from the engine's at step 142 of 500"),
    "rk4_hardcoded_dt.py": (RK4, "From the same state, dt = 0.1 and dt = 0.03 give the very same result"),
    "rk4_k4_along_k2.py": (RK4, "halving dt divides its error by 8.38: order 3.07, where RK4 is order 4"),
    "rk4_dt_twice.py": (RK4, "every change your step makes is dt times RK4's"),
    "rk4_stacked_return.py": (RK4, "returns one array of shape (6,); it must return 2, (q_next, v_next)"),
    "rk4_equal_weights.py": (RK4, "your four slopes are weighted equally"),
    "rk4_full_step.py": (RK4, "your midpoint stages are a full dt out"),
    "rk4_forgot_mass.py": (RK4, "It is right whenever m = 1"),
    "rk4_mass_twice.py": (RK4, "It is right whenever m = 1"),
    "rk4_times_mass.py": (RK4, "It is right whenever m = 1"),
    "rk4_k2_without_mass.py": (RK4, "It is right whenever m = 1"),
    "rk4_stage_velocity_not_passed.py": (RK4, "your stages never hand their velocity to the force"),
    "rk4_all_slopes_at_start.py": (RK4, "explicit Euler in disguise"),
    "rk4_midpoint_rk2.py": (RK4, "this is the midpoint method, RK2: halving dt divides its error by 4.0 on a spring"),
    "rk4_heun.py": (RK4, "this is Heun's method, slopes at the start and the end averaged: halving dt divides"),
    "rk4_weights_over_4.py": (RK4, "the weights of your final blend add up to 1.5, not 1"),
    "rk4_weights_over_3.py": (RK4, "the weights of your final blend add up to 2, not 1"),
    "rk4_weights_over_5.py": (RK4, "every change your step makes is 1.2 times RK4's: the weights of your final blend"
                                   " add up to 1.2, not 1"),
    "rk4_floor_division.py": (RK4, "every change your step makes is a whole number (0). Is something divided with"
                                   " //?"),
    "rk4_floor_division_last.py": (RK4, "every change your step makes is a whole number (-1, 0)"),
    "rk4_missing_dt.py": (RK4, "your final update has no dt in it"),
    "rk4_k2_full_step.py": (RK4, "your k2 is sampled a whole dt out"),
    "rk4_k3_full_step.py": (RK4, "your k3 is sampled a whole dt out"),
    "rk4_rounded_sixth.py": (RK4, "close to 1, not 1. Is a fraction written as a rounded decimal?"),
    "rk4_weights_2112.py": (RK4, "your blend counts the end slopes double, the midpoint ones once: halving dt divides"
                                 " its error by 4.1 on a spring with m = 2.5"),
    "rk4_three_eighths.py": (RK4, "this is Kutta's 3/8 rule: halving dt divides its error by 16.2 on a spring"),
    "rk4_position_slopes_start.py": (RK4, "your position slopes are all the starting velocity"),
    "rk4_k3_along_k1.py": (RK4, "your k3 steps along k1"),
    "rk4_k4_half.py": (RK4, "your k4 is sampled half a step out"),
    "rk4_stages_at_start_position.py": (RK4, "your stages step the velocity, but every force is taken at the"
                                             " starting position"),
    "rk4_stages_chained.py": (RK4, "each of your stages steps from the stage before it"),
    "rk4_floor_division_half.py": (RK4, "as if half a step were 0. Is something divided with //?"),
    "rk4_hardcoded_force.py": (RK4, "it never calls force"),
    "rk4_signature_changed.py": (RK4, "you changed its signature to rk4_step(q, v, force, m, dt)"),
    "semi_endless.py": (SEMI, "stopped after 3 s during single steps from fresh states, without returning"),
    "semi_slow.py": (SEMI, "stopped after 3 s during a whole run"),
    "right_other_order.py": (None, ""),
    "right_butcher.py": (None, ""),
    "right_stacked.py": (None, ""),
    "right_np_add.py": (None, ""),
    "right_helper_module.py": (None, ""),
    "right_tableau.py": (None, ""),
    "right_chatty.py": (None, "Your code printed"),
    "right_prints_every_call.py": (None, "Your code printed"),
    "right_spawns_sleeper.py": (None, ""),
    "helper_beside/student.py": (None, ""),
    "clash_threading/student.py": (None, "threading.py beside your file has the name of Python's standard module"
                                         " threading, which Python imports first"),
    "clash_helper/student.py": ("both", "random.py beside your file has the name of Python's standard module random"),
}
QUICK = {"semi_mass_twice.py", "semi_returns_lists.py", "rk4_floor_division.py", "rk4_weights_over_5.py",
         "rk4_stage_velocity_not_passed.py", "rk4_three_eighths.py", "right_stacked.py",
         "rk4_stateful_reuses_slope.py", "semi_aliasing_buffers.py", "both_clamp_velocity.py",
         "clash_threading/student.py", "semi_force_list.py"}


def test_every_planted_file_has_its_expected_message():
    planted = {p.relative_to(PLANTED).as_posix() for p in [*PLANTED.glob("*.py"), *PLANTED.glob("*/student.py")]}
    assert planted - {"_right.py"} == set(PLANTED_MESSAGES), (
        "every planted file needs its line in PLANTED_MESSAGES (the words the student must see), and every line its"
        f" file in tests/planted/: files without a line {sorted(planted - {'_right.py'} - set(PLANTED_MESSAGES))},"
        f" lines without a file {sorted(set(PLANTED_MESSAGES) - planted)}")


@pytest.mark.parametrize("planted", [pytest.param(name, marks=() if name in QUICK else pytest.mark.slow)
                                     for name in PLANTED_MESSAGES])
def test_planted_file_gets_the_message_that_names_it(planted, capsys, monkeypatch):
    if planted in ("semi_endless.py", "semi_slow.py", "both_floods_without_newlines.py"):
        monkeypatch.setattr(check_ex2, "TIME_LIMIT", 3.0)  # stopped, not waited for
    wrong, message = PLANTED_MESSAGES[planted]
    code, out = check(PLANTED / planted, capsys)
    assert message in out and "Traceback" not in out
    if wrong is None:
        assert code == 0 and out.endswith("All solved.")
    elif wrong == "both":
        assert code == 1 and ": solved" not in out
    elif wrong != "any":
        other = RK4 if wrong == SEMI else SEMI
        assert code == 1 and f"{other}: solved" in out and f"{wrong}: solved" not in out


def test_no_message_quotes_the_answers_code():
    """The catalogue names methods and asks questions; it never prints a line of the reference solution."""
    solution = (REPO / "exercises" / "solutions" / "ex2_integrators.py").read_text()
    lines = {one_line(line.split("#")[0]) for line in solution.splitlines() if "=" in line or "return" in line}
    texts = [message for *_, message, _ in check_ex2.MISTAKES]
    assert not [line for line in lines for text in texts if line in text]


def test_the_checker_keeps_the_budget_its_docs_state():
    stated = re.search(r"chapter's part, .{0,80} stays at most ([\d,]+) lines",
                       one_line((REPO / "docs" / "DEVELOPING.md").read_text()))
    files = [REPO / "exercises" / "check_ex2.py", *(REPO / "exercises" / "support").glob("ex2_*.py")]
    lines = sum(path.read_bytes().count(b"\n") for path in files)  # as wc -l counts
    assert stated and lines <= int(stated[1].replace(",", "")), f"{lines} lines in {[p.name for p in files]}"


BROKEN = {
    "indented.py": (b"def semi_implicit_step(q, v, m, force, dt):\nreturn q, v\n",
                    "indented.py, line 2: IndentationError: expected an indented block"),
    "tabs.py": (b"def semi_implicit_step(q, v, m, force, dt):\n    a = 1\n\treturn q, v\n",
                "tabs.py, line 3: TabError: inconsistent use of tabs and spaces in indentation."),
    "syntax.py": (b"def rk4_step(q, v, m, force, dt)\n    return q, v\n",
                  "syntax.py, line 1: SyntaxError: expected ':'. def rk4_step(q, v, m, force, dt) ^"),
    "latin1.py": (b"# caf\xe9\ndef rk4_step(q, v, m, force, dt):\n    return q, v\n",
                  "latin1.py, line 1: this line is not valid text (byte 0xe9); save the file as UTF-8."),
    "nul.py": (b"def rk4_step(q, v, m, force, dt):\n    return q,\x00 v\n", "nul.py, line 2: the file contains a null"),
}


@pytest.mark.parametrize("name", BROKEN)
def test_a_file_that_does_not_compile_gets_file_line_and_the_line(name, tmp_path, capsys):
    source, message = BROKEN[name]
    (tmp_path / name).write_bytes(source)
    code, out = check(tmp_path / name, capsys)
    assert code == 1 and message in out and "Traceback" not in out


def test_a_frame_in_the_course_is_not_the_students_even_at_the_default_place(tmp_path, capsys):
    """The student's file at exercises/: the TypeError raised inside the course's force names the student's line."""
    copy = REPO / "exercises" / "_test_copy_of_a_student_file.py"
    copy.write_text((PLANTED / "semi_force_list.py").read_text())
    try:
        code, out = check(copy, capsys)
    finally:
        copy.unlink()
    assert code == 1 and "line 10 of _test_copy_of_a_student_file.py: a = force(list(q), v) / m." in out
    assert "ex2_cases" not in out and "engine.py" not in out


def test_a_malformed_result_is_a_sentence():
    run = student_code.Run(results={0: {"outputs": "junk"}})
    solved, message = check_ex2.judge(SEMI, PLANTED / "right_stacked.py", run, [0] + list(range(1, 9)))
    assert not solved and "your file's run did not finish" in message


def test_help_works_and_extra_arguments_are_refused():
    run = [sys.executable, "-m", "exercises.check_ex2"]
    shown = subprocess.run([*run, "--help"], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert shown.returncode == 0 and "usage:" in shown.stdout
    extra = subprocess.run([*run, "a.py", "b.py"], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert extra.returncode == 2 and "unrecognized arguments: b.py" in extra.stderr
    assert len(extra.stderr.splitlines()) == 1


def test_runs_as_a_file_from_its_folder():
    result = subprocess.run([sys.executable, "check_ex2.py", str(PRISTINE)], cwd=REPO / "exercises",
                            capture_output=True, text=True, timeout=120, env={**os.environ, "PYTHONPATH": ""})
    assert result.returncode == 1 and "NotImplementedError" in result.stdout and result.stderr == ""
