"""Exercise 2's checker, both directions: right files pass, the stub and every planted file get the message
that names them (tests/planted/), never a traceback. The student's own exercises/ex2_integrators.py is never
graded here. A planted file that tests the runner (it raises, exits, loops, prints or reaches into the course:
RUNNER) goes through the whole checker and its child; the catalogue's files are judged on tasks run here, once
per step (a step imported from _right.py runs once for all). A quick sample runs by default."""

import ast
import functools
import importlib.util
import json
import re
from types import SimpleNamespace

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


def check(argv, capsys):
    """`python -m exercises.check_ex2 ARGV`, in this process: (exit code, stdout and stderr on one line)."""
    try:
        code = check_ex2.main([str(arg) for arg in argv])
    except SystemExit as stop:  # argparse's exits: --help, a refused argument or file
        code = stop.code
    out = capsys.readouterr()
    return code, one_line(out.out + out.err)


def test_pristine_stub_is_not_solved(capsys):
    code, out = check([PRISTINE], capsys)
    assert code == 1 and out.count("not solved yet. It still raises NotImplementedError") == 2


def test_reference_solution_passes_and_says_no_order(capsys):
    code, out = check([REPO / "exercises" / "solutions" / "ex2_integrators.py"], capsys)
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
    assert [item for item in instructions(PRISTINE.read_text()) if item not in student] == [], \
        "the stub and exercises/support/pristine/ differ in a docstring, a signature or a function"


@pytest.mark.parametrize("function", check_ex2.METHODS)
def test_the_ladders_measure_the_engines_own_order(function):
    engine = check_ex2.Measured(function, check_ex2.engine_answers(function), check_ex2.engine_answers(function))
    assert abs(engine.order("heavy_damped_spring")[2] - check_ex2.METHODS[function][2]) <= 0.25


# Every planted file (.py): the function it gets wrong (None: right; "both": both wrong) and what the checker says.
PLANTED_MESSAGES = {
    "semi_as_explicit": (SEMI, "that is explicit Euler. On the chapter's orbit its energy error reaches 22.1% in"
                               " 2,000 steps. Which velocity should move the position?"),
    "semi_position_first": (SEMI, "the other symplectic Euler, bounded too (on the chapter's orbit its energy error"
                                  " stays within 3.2e-04 over 2,000 steps)"),
    "semi_sign_error": (SEMI, "your velocity changes against the force"),
    "semi_force_ahead": (SEMI, "you take the force a step ahead, where the old velocity would carry the position"),
    "semi_right_only_at_chapter_dt": (SEMI, "that is explicit Euler. On the chapter's orbit"),
    "semi_varies_between_calls": (SEMI, "it returned different numbers on 28 of 28 single steps"),
    "semi_forgot_mass": (SEMI, "It is right whenever m = 1 and wrong on a spring with m = 2.5"),
    "semi_velocity_verlet": (SEMI, "this is velocity Verlet (leapfrog's twin: a half kick, a drift, a half kick)"),
    "semi_leapfrog": (SEMI, "this is the drift-kick-drift leapfrog: halving dt divides its error by 4.0"),
    "semi_taylor": (SEMI, "velocity Verlet's Taylor step. Which velocity moves the position"),
    "semi_new_velocity_without_dt": (SEMI, "adds a velocity without multiplying it by dt"),
    "semi_hardcoded_force": (SEMI, "it never calls force"),
    "semi_in_place": (SEMI, "it changes the q and v it was given (an in-place update)"),
    "semi_sys_exit": (SEMI, "your code ends Python with sys.exit() or exit() (exit code 0) during single steps"),
    "semi_os_exit": (SEMI, "ended by itself (exit code 0) during single steps from fresh states"),
    "semi_returns_none": (SEMI, "returns None: the function ends without returning (q_next, v_next)"),
    "semi_returns_one": (SEMI, "returns one array of shape (3,); it must return 2, (q_next, v_next)"),
    "semi_returns_lists": (SEMI, "returns a list, not a numpy array; a whole run hands each step what the one before"),
    "semi_signature_changed": (SEMI, "you changed its signature to semi_implicit_step(q, v, force, m, dt)"),
    "semi_raises": (SEMI, "it raised NameError: name 'v_nxt' is not defined in semi_implicit_step(), line 9 of"),
    "semi_patches_engine": (SEMI, "that is explicit Euler"),
    "semi_swapped_return": (SEMI, "your numbers are right but returned in the wrong order"),
    "semi_float32": (SEMI, "agree with semi-implicit Euler's to about 7 digits, where the same arithmetic agrees"),
    "semi_aliasing_buffers": (SEMI, "ends in inf or NaN. From step 2 of a run on, the arrays it returns share memory"),
    "semi_defined_twice": (SEMI, "defined 2 times in your file (lines 9, 26): Python keeps the last one, line 26"),
    "semi_force_list": (SEMI, "line 10 of semi_force_list.py: a = force(list(q), v) / m."),
    "semi_force_extra_arg": (SEMI, "it raised TypeError: force() takes 2 positional arguments but 3 were given in"),
    "semi_endless": (SEMI, "stopped after 3 s during single steps from fresh states, without returning"),
    "both_forges_output": ("both", "your file ended Python while it was being imported (exit code 0)"),
    "both_reads_stdin": ("both", "it raised EOFError: EOF when reading a line in <module>(), line 4 of"),
    "both_returns_junk": ("both", "returns a q_next that is not numbers: str"),
    "both_forges_answers": ("both", "your file's run did not finish: what it sent back could not be read"),
    "both_clamp_velocity": ("both", "every single step from a fresh state matches the engine's semi-implicit Euler,"
                                    " but a whole run, each step fed its own output, does not: on the chapter's"
                                    " freefall (m = 1), at dt 0.01, it parts from the engine's at step 204 of 2,000,"
                                    " where the engine's speed is 20.3 m/s, and ends 1.58e+03 m away"),
    "rk4_hardcoded_dt": (RK4, "From the same state, dt = 0.1 and dt = 0.03 give the very same result"),
    "rk4_k4_along_k2": (RK4, "halving dt divides its error by 8.38: order 3.07, where RK4 is order 4"),
    "rk4_dt_twice": (RK4, "every change your step makes is dt times RK4's"),
    "rk4_equal_weights": (RK4, "your four slopes are weighted equally"),
    "rk4_full_step": (RK4, "your midpoint stages are a full dt out"),
    "rk4_k2_without_mass": (RK4, "It is right whenever m = 1"),
    "rk4_stage_velocity_not_passed": (RK4, "your stages never hand their velocity to the force"),
    "rk4_all_slopes_at_start": (RK4, "explicit Euler in disguise"),
    "rk4_midpoint_rk2": (RK4, "this is the midpoint method, RK2: halving dt divides its error by 4.0 on a spring"),
    "rk4_heun": (RK4, "this is Heun's method, slopes at the start and the end averaged: halving dt divides"),
    "rk4_weights_over_5": (RK4, "1.2 times RK4's: the weights of your final blend add up to 1.2, not 1"),
    "rk4_floor_division": (RK4, "every change your step makes is a whole number (0). Is something divided with //?"),
    "rk4_missing_dt": (RK4, "your final update has no dt in it"),
    "rk4_k2_full_step": (RK4, "your k2 is sampled a whole dt out"),
    "rk4_k3_full_step": (RK4, "your k3 is sampled a whole dt out"),
    "rk4_rounded_sixth": (RK4, "close to 1, not 1. Is a fraction written as a rounded decimal?"),
    "rk4_weights_2112": (RK4, "the midpoint ones once: halving dt divides its error by 4.1 on a spring with m = 2.5"),
    "rk4_three_eighths": (RK4, "this is Kutta's 3/8 rule: halving dt divides its error by 16.2 on a spring"),
    "rk4_position_slopes_start": (RK4, "your position slopes are all the starting velocity"),
    "rk4_k3_along_k1": (RK4, "your k3 steps along k1"),
    "rk4_k4_half": (RK4, "your k4 is sampled half a step out"),
    "rk4_stages_at_start_position": (RK4, "your stages step the velocity, but every force is taken at the starting"),
    "rk4_stages_chained": (RK4, "each of your stages steps from the stage before it"),
    "rk4_floor_division_half": (RK4, "as if half a step were 0. Is something divided with //?"),
    "right_prints_every_call": (None, "Your code printed"),
    **{name: (None, "") for name in ("_right", "right_other_order", "right_butcher", "right_stacked", "right_np_add")},
}
RUNNER = {"semi_sys_exit", "semi_os_exit", "semi_signature_changed", "semi_raises", "semi_endless", "semi_force_list",
          "semi_patches_engine", "semi_defined_twice", "semi_force_extra_arg", "both_forges_output", "both_reads_stdin",
          "both_forges_answers", "right_prints_every_call"}
QUICK = {"semi_forgot_mass", "semi_returns_lists", "rk4_floor_division", "rk4_weights_over_5", "rk4_three_eighths",
         "rk4_stage_velocity_not_passed", "right_stacked", "right_np_add", "semi_aliasing_buffers", "semi_raises",
         "both_clamp_velocity", "semi_force_list"}


def test_every_planted_file_has_its_expected_message():
    planted = {p.relative_to(PLANTED).with_suffix("").as_posix() for p in PLANTED.rglob("*.py")}
    assert planted == set(PLANTED_MESSAGES) and RUNNER <= planted, (
        "every planted file needs its line in PLANTED_MESSAGES (the words the student must see), and every line its"
        f" file in tests/planted/: files without a line {sorted(planted - set(PLANTED_MESSAGES))}, lines without a"
        f" file {sorted(set(PLANTED_MESSAGES) - planted)}, RUNNER's names without a file {sorted(RUNNER - planted)}")


@functools.cache
def collected(step, index: int) -> dict:
    """Task `index`'s answer from one step function, as it arrives from the child (a JSON line)."""
    task = check_ex2.every()[index]
    with np.errstate(all="ignore"):
        return json.loads(json.dumps(check_ex2.ex2_cases.collect(SimpleNamespace(**{task["function"]: step}), task)))


def judged_here(path, monkeypatch) -> tuple[dict, list, student_code.Run]:
    """check_ex2.check(path) on tasks run in this process: for the catalogue's files, which only return numbers."""
    monkeypatch.syspath_prepend(str(PLANTED))  # for `from _right import ...`
    spec = importlib.util.spec_from_file_location("student", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    tasks = check_ex2.every()
    run = student_code.Run(results={i: collected(getattr(module, t["function"], None), i) for i, t in enumerate(tasks)})
    return check_ex2.check(path, run)


def worst_gap(run: student_code.Run) -> float:
    """The largest gap of the file's whole runs from the engine's, relative to each run's size."""
    tasks = check_ex2.every()
    measured = [check_ex2.Measured(name, [run.results[i] for i, t in enumerate(tasks) if t["function"] == name],
                                   check_ex2.engine_answers(name)) for name in check_ex2.METHODS]
    return max(float(np.max(gap)) for one in measured for gap in one.gaps)


@pytest.mark.parametrize("planted", [pytest.param(name, marks=() if name in QUICK else pytest.mark.slow)
                                     for name in PLANTED_MESSAGES])
def test_planted_file_gets_the_message_that_names_it(planted, capsys, monkeypatch):
    """A right file also measures RIGHT_GAP: other roundings stay within it on every run; right_np_add.py sets it."""
    wrong, message = PLANTED_MESSAGES[planted]
    if planted in RUNNER:
        monkeypatch.setattr(check_ex2, "TIME_LIMIT", 3.0)  # stopped, not waited for
        code, out = check([PLANTED / f"{planted}.py"], capsys)
    else:
        parts, messages, run = judged_here(PLANTED / f"{planted}.py", monkeypatch)
        code, out = int(not all(parts.values())), one_line(" ".join(messages))
        assert wrong is not None or worst_gap(run) <= check_ex2.RIGHT_GAP
        assert planted != "right_np_add" or worst_gap(run) > check_ex2.RIGHT_GAP * 0.99
    assert message in out and "Traceback" not in out
    solved = {name for name in check_ex2.METHODS if f"{name}: solved" in out}
    assert (code, solved) == ((0, set(check_ex2.METHODS)) if wrong is None else (1, set()) if wrong == "both"
                              else (1, set(check_ex2.METHODS) - {wrong})), out


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


UNCHECKABLE = {  # a file given to the checker (bytes, or a folder, or nothing there): exit code, what it says
    "indented.py": (b"def f(q):\nreturn q\n", 1, "indented.py, line 2: IndentationError: expected an indented block"),
    "tabs.py": (b"def f(q):\n    a = 1\n\treturn q\n", 1, "tabs.py, line 3: TabError: inconsistent use of tabs and"
                " spaces in indentation. Indent with spaces only"),
    "syntax.py": (b"def f(q)\n    return q\n", 1, "syntax.py, line 1: SyntaxError: expected ':'. def f(q) ^"),
    "latin1.py": (b"x = 'caf\xe9'\n", 1, "latin1.py, line 1: SyntaxError: (unicode error) 'utf-8' codec can't decode"),
    "nul.py": (b"x = 1,\x00 2\n", 1, "nul.py: SyntaxError: source code string cannot contain null bytes."),
    "folder.py": ("folder", 2, "folder.py is a folder; give the .py file itself"),
    "steps.txt": (b"", 2, "steps.txt is not a Python file: the checker imports it, so it must end in .py"),
    "missing.py": (None, 2, "there is no file"),
}


@pytest.mark.parametrize("name", UNCHECKABLE)
def test_a_file_that_cannot_be_checked_gets_one_sentence_and_none_of_it_runs(name, tmp_path, capsys):
    content, expected, message = UNCHECKABLE[name]
    if content == "folder":
        (tmp_path / name).mkdir()
    elif content is not None:
        (tmp_path / name).write_bytes(content)
    code, out = check([tmp_path / name], capsys)
    assert code == expected and message in out and "Traceback" not in out


def test_a_frame_in_the_course_is_not_the_students_even_at_the_default_place(capsys):
    """The student's file at exercises/: the TypeError raised inside the course's force names the student's line."""
    copy = REPO / "exercises" / "_test_copy_of_a_student_file.py"
    copy.write_text((PLANTED / "semi_force_list.py").read_text())
    try:
        code, out = check([copy], capsys)
    finally:
        copy.unlink()
    assert code == 1 and "line 10 of _test_copy_of_a_student_file.py: a = force(list(q), v) / m." in out
    assert "ex2_cases" not in out and "engine.py" not in out


def test_a_malformed_result_is_a_sentence():
    run = student_code.Run(results={0: {"outputs": "junk"}})
    solved, message = check_ex2.judge(SEMI, PLANTED / "right_stacked.py", run, [0] + list(range(1, 9)))
    assert not solved and "your file's run did not finish" in message


def test_help_works_and_extra_arguments_are_refused_in_one_line(capsys):
    code, out = check(["--help"], capsys)
    assert code == 0 and out.startswith("usage: python -m exercises.check_ex2")
    with pytest.raises(SystemExit) as refused:
        check_ex2.main(["a.py", "b.py"])
    err = capsys.readouterr().err
    assert refused.value.code == 2 and "error: unrecognized arguments: b.py" in err and len(err.splitlines()) == 1
