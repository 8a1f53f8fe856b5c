"""What a student reads before predicting gives no answer away, and every command printed in the READMEs runs.

The answers are read from exercises/solutions/ANSWERS.md (pasted from runs), so when the physics changes the
test follows; the texts searched are README.md, exercises/README.md, exercises/HINTS.md, every exercise's
--help, module docstring and bare question.
"""

import ast
import contextlib
import importlib
import io
import re
import shlex
import subprocess
import sys

import pytest

from conftest import REPO
from curriculum.common.exercise import exercises

ANSWERS = (REPO / "exercises" / "solutions" / "ANSWERS.md").read_text()
PRISTINE_STUB = REPO / "tests" / "pristine" / "ex2_integrators.py"
EXERCISES = exercises(REPO / "exercises")  # found by file name: a new exercise is read here without an edit
PREDICT_THEN_RUN = [name for _, name, kind in EXERCISES if kind == "predict"]
CHECKERS = [f"check_ex{number}" for number, _, kind in EXERCISES if kind == "code"]
EXERCISE_MODULES = [name for _, name, _ in EXERCISES] + CHECKERS


def section(heading: str) -> str:
    return ANSWERS.split(f"## {heading}")[1].split("\n## ")[0]


def graded_answers() -> dict:
    """The answers that score, as ANSWERS.md shows them scoring."""
    ex1 = re.search(r"Right: it is (\w+)\.", section("Exercise 1")).group(1)
    ex3 = re.search(r"--predict (\S+)`", section("Exercise 3")).group(1)
    assert "3 of 3." in section("Exercise 3")
    ex4 = int(re.search(r"Right: it is about ([\d,]+) orbits", section("Exercise 4")).group(1).replace(",", ""))
    ex5 = re.search(r"The graded answer is `([^`]+)`", section("Exercise 5")).group(1)
    return {"ex1": ex1, "ex3": dict(item.split("=") for item in ex3.split(",")), "ex4": ex4,
            "ex5": dict(item.strip().split("=") for item in ex5.split(","))}


def measured_figures() -> set:
    """Every measured number exercises 3 and 4 print (ladder factors, bands, crossover steps, orbit counts)."""
    blocks = re.findall(r"```\n(.*?)```", section("Exercise 3") + section("Exercise 4"), flags=re.S)
    numbers = set(re.findall(r"\d[\d,]*\.\d+(?:e[-+]\d+)?|\d{1,3}(?:,\d{3})+|\b\d{3,}\b", "".join(blocks)))
    inputs = {"2000", "2,000", "1,000", "10,000", "100,000"}  # the chapter's run and the choices: not answers
    significant = {n for n in numbers if len(re.sub(r"e.*|\D|^[0.]+", "", n)) >= 3}  # 1.99, 727; not dt 0.25
    return significant - inputs


def spoilers() -> list:
    """(pattern, what it would give away)."""
    answers = graded_answers()
    ex4 = answers["ex4"]
    patterns = [
        (rf"--predict\s+{answers['ex1']}\b(?!\s*=)", "exercise 1's answer as a --predict example"),
        (rf"\bit is {answers['ex1']}\b|\b{answers['ex1']} (runs away|is the one)", "exercise 1's answer"),
        (rf"--predict\s+(1e{len(str(ex4)) - 1}|{ex4:,}|{ex4}|{ex4:_})\b", "exercise 4's answer as a --predict example"),
        (rf"\b({ex4:,}|{ex4}) orbits", "exercise 4's orbit count"),
        (r"(shrinks?|divides?|drops?|falls?)( \w+){0,4} by (about |roughly )?(2|4|16|32|sixteen|two)\b",
         "a shrink factor"),
        (r"\bfactors? (of )?(2|16|32)\b", "a shrink factor"),
        (r"\b(millions|thousands) of (orbits|times)", "exercise 4's scale"),
    ]
    for name, factor in answers["ex3"].items():
        patterns.append((rf"\b{name}\s*=\s*{factor}\b", "exercise 3's graded factor"))
    for name, word in answers["ex5"].items():
        patterns.append((rf"\b{name}\s*[=:]\s*{word}\b", "exercise 5's graded answer"))
    patterns.append((r"\b(keeps?|preserves?|conserves?) (the |its )?(phase[- ]space )?area|area[- ]preserving",
                     "exercise 5's answer for semi-implicit Euler"))
    for figure in measured_figures():
        patterns.append((rf"(?<![\d.,]){re.escape(figure)}(?![\d])", f"the measured figure {figure}"))
    return patterns


def exercise_texts() -> dict:
    """{where: text} for everything a student reads before committing to a prediction."""
    # Output blocks (the chapter's drift table, the exercises' timings) are measurements of the chapter, not
    # answers; prose and ```bash blocks are where the old spoilers were.
    def without_output_blocks(text):
        return re.sub(r"```(\w*)\n.*?```", lambda block: block.group(0) if block.group(1) else "", text, flags=re.S)

    texts = {name: without_output_blocks((REPO / name).read_text())
             for name in ("README.md", "exercises/README.md", "exercises/HINTS.md")}
    for module_name in EXERCISE_MODULES:  # the stub as a student first opens it: the pristine copy, not their edits
        if module_name == PRISTINE_STUB.stem:
            texts["exercises/ex2_integrators.py docstring"] = ast.get_docstring(ast.parse(PRISTINE_STUB.read_text()))
            continue
        module = importlib.import_module(f"exercises.{module_name}")
        texts[f"exercises/{module_name}.py docstring"] = module.__doc__
    for module_name in [*PREDICT_THEN_RUN, *CHECKERS]:
        module = importlib.import_module(f"exercises.{module_name}")
        for argv, what in ((["--help"], "--help"), ([], "bare question")):
            if module_name in CHECKERS and not argv:
                continue  # bare, the checker checks: it asks nothing
            out = io.StringIO()
            with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
                module.main(argv)
            texts[f"python -m exercises.{module_name} {' '.join(argv)} ({what})"] = out.getvalue()
    return texts


def test_the_answers_are_where_teachers_find_them():
    answers = graded_answers()
    assert answers["ex1"] in ("euler", "semi_implicit", "rk4") and set(answers["ex3"]) == {"euler", "semi_implicit",
                                                                                          "rk4"}
    assert len(measured_figures()) > 40
    assert "python -m exercises.ex4_long_run --predict" in section("Exercise 4")


@pytest.mark.parametrize("number, module", [(n, m) for n, m, kind in EXERCISES if kind == "predict"])
def test_every_predict_then_run_exercise_has_its_answer_for_teachers(number, module):
    """An exercise is its file, its section in exercises/README.md and its section in ANSWERS.md: this names the
    section that is missing, with the command and the output a teacher reads (pasted from a run)."""
    assert f"## Exercise {number}" in ANSWERS, f"exercises/solutions/ANSWERS.md has no '## Exercise {number}' section"
    commands = [command for command, _ in answers_with_their_commands() if f"-m exercises.{module} " in command]
    assert commands, (f"ANSWERS.md's exercise {number} shows no `python -m exercises.{module} --predict ...` line"
                      " with the output it prints below it")
    assert all("--predict" in command for command in commands)


def test_nothing_a_student_reads_first_gives_an_answer_away():
    leaks = []
    for where, text in exercise_texts().items():
        for pattern, what in spoilers():
            for match in re.finditer(pattern, text, flags=re.I):
                line = text[: match.start()].count("\n") + 1
                leaks.append(f"{where}, line {line}: {what}: {match.group(0)!r}")
    assert not leaks, "\n".join(leaks)


def test_the_spoiler_patterns_catch_the_old_leaks():
    """The texts that leaked before this test existed (issue 7) must be caught, or the test proves nothing."""
    old = ["python -m exercises.ex1_runaway --predict euler    # commit, then see the evidence",
           "python -m exercises.ex3_halve_dt --predict euler=2,semi_implicit=2,rk4=16",
           "the final-position error on the orbit settles at 1.99 (Euler), 1.97 (semi-implicit) and 17.36 (RK4)",
           "RK4's error drops by about sixteen", "Euler's error roughly halves and RK4's drops by 16",
           "python -m exercises.ex4_long_run --predict 1,000", "after 727 orbits", "about 1,000 orbits"]
    for text in old:
        assert any(re.search(pattern, text, flags=re.I) for pattern, _ in spoilers()), text


# --- every command printed in the READMEs runs as written, from the repo root ---

PLACEHOLDERS = {"<integrator>": "rk4", "<orbits>": "10", "=?": "=1", "=<word>": "=stays",
                "path/to/your_file.py": "tests/planted/right_stacked.py"}
# Quick: the bare questions and the checker. Slow (-m slow): the engine runs (test_cli.py runs those bare) and
# the measuring runs, whose output tests/test_exercises.py checks with other predictions.
SLOW = ("engine.py", "--predict")


def printed_commands() -> list:
    """Every `python ...` line in a ```bash block of the two READMEs, comment and `cd`/`pip ... &&` prefixes off."""
    commands = []
    for readme in ("README.md", "exercises/README.md"):
        for block in re.findall(r"```bash\n(.*?)```", (REPO / readme).read_text(), flags=re.S):
            for line in block.splitlines():
                command = re.sub(r"\s+#.*$", "", line).split("&&")[-1].strip()
                if command.startswith("python "):
                    commands.append((readme, command))
    return commands


def test_the_readmes_print_the_commands_we_expect():
    commands = [c for _, c in printed_commands()]
    for module in [*PREDICT_THEN_RUN, *CHECKERS]:
        assert any(f"python -m exercises.{module}" in c for c in commands), \
            f"exercises/README.md shows no command for {module}: give it a section with its commands"
    assert any(c.startswith("python engine.py") for c in commands)


@pytest.mark.parametrize("readme, command", [
    pytest.param(*rc, marks=pytest.mark.slow if any(s in rc[1] for s in SLOW) else ())
    for rc in printed_commands()])
def test_every_printed_command_runs_as_written(readme, command, tmp_path):
    """Placeholders get a value; engine runs write to a scratch --out (test_cli.py runs them quick and bare)."""
    for placeholder, value in PLACEHOLDERS.items():
        command = command.replace(placeholder, value)
    argv = shlex.split(command)
    if argv[1] == "engine.py" and "--help" not in argv:
        argv += ["--out", str(tmp_path / "out")]
    if "exercises.ex5_phase_blob" in argv and "--predict" in argv:
        argv += ["--rrd", str(tmp_path / "ex5_blob.rrd")]  # its recording goes to scratch too
    result = subprocess.run([sys.executable, *argv[1:]], cwd=REPO, capture_output=True, text=True, timeout=600)
    expected = {0, 1} if "check_ex2" in command else {0}  # a bare question too: asking is not an error
    assert result.returncode in expected, f"{readme}: {command}\n{result.stdout}\n{result.stderr}"
    assert "Traceback" not in result.stdout + result.stderr and "Error" not in result.stderr


@pytest.mark.parametrize("module", [*PREDICT_THEN_RUN, *CHECKERS])
@pytest.mark.parametrize("inside", [False, True], ids=["from the root", "from inside exercises"])
def test_every_exercise_runs_as_a_file_too(module, inside):
    """`python exercises/ex1_runaway.py` from the root, or `cd exercises && python ex1_runaway.py`: the first
    lines of each file (curriculum.common.exercise.start) make both work."""
    cwd, script = (REPO / "exercises", f"{module}.py") if inside else (REPO, f"exercises/{module}.py")
    result = subprocess.run([sys.executable, script, *(["--help"] if module in CHECKERS else [])], cwd=cwd,
                            capture_output=True, text=True, timeout=60)
    assert result.stderr == ""
    if module in CHECKERS:
        assert result.returncode == 0 and "usage:" in result.stdout
    else:
        assert result.returncode == 0 and f"python {script} --predict ANSWER" in result.stdout


def answers_with_their_commands() -> list:
    """(command, pasted output) for every output block in ANSWERS.md, from the `python ...` line above it."""
    pairs = re.findall(r"`(python [^`]+)`[^`\n]*\n\n```\n(.*?)```", ANSWERS, flags=re.S)
    return [(command, output) for command, output in pairs]


def test_every_answer_block_says_which_command_printed_it():
    assert len(answers_with_their_commands()) == ANSWERS.count("```\n") // 2 >= 5


@pytest.mark.slow
@pytest.mark.parametrize("command, pasted", answers_with_their_commands())
def test_the_answers_are_what_the_commands_print_today(command, pasted):
    """The physics is deterministic, so the teachers' figures must be reproduced to the last digit."""
    result = subprocess.run([sys.executable, *shlex.split(command)[1:]], cwd=REPO, capture_output=True, text=True,
                            timeout=600)
    assert result.stdout == pasted, f"{command}: ANSWERS.md is out of date; paste the new output"
