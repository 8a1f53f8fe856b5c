"""What a student reads before predicting gives no answer away, every command printed in the READMEs runs, and
the students' pages and the exercises' lessons read short.

Every exercise's answer is read from exercises/solutions/ANSWERS.md ("The graded answer is `...`", checked
against the runs pasted there) by the exercise's own parser, so it comes in its own form (a value per name, a
set of names, one name, a number) and a new exercise is known without an edit here; its section may add the
words that give it away. Searched, for each exercise, is all a student reads before predicting it: README.md
(before exercise 1, up to its request to do it), exercises/README.md, the hints so far, the docstrings, --help
and bare questions so far, the integrators' docstrings, and what every earlier exercise printed after its
prediction (lesson and --more).
"""

import ast
import contextlib
import functools
import importlib
import io
import json
import math
import re
import shlex
import subprocess
import sys
import tokenize
from decimal import Decimal, localcontext

import numpy as np
import pytest

import engine
from conftest import REPO, run, run_engine
from curriculum.common import predict, report
from curriculum.common.exercise import exercises

ANSWERS = (REPO / "exercises" / "solutions" / "ANSWERS.md").read_text()
PRISTINE_STUB = REPO / "exercises" / "support" / "pristine" / "ex2_integrators.py"
EXERCISES = exercises(REPO / "exercises")  # found by file name: a new exercise is read here without an edit
PREDICT_THEN_RUN = [name for _, name, kind in EXERCISES if kind == "predict"]
CHECKERS = [f"check_ex{number}" for number, _, kind in EXERCISES if kind == "code"]
EXERCISE_MODULES = [name for _, name, _ in EXERCISES] + CHECKERS


def section(heading: str) -> str:
    assert f"## {heading}" in ANSWERS, f"exercises/solutions/ANSWERS.md has no '## {heading}' section: write it"
    return ANSWERS.split(f"## {heading}")[1].split("\n## ")[0]


def answers_with_their_commands() -> list:
    """(command, pasted output) for every output block in ANSWERS.md, from the `python ...` line above it."""
    return re.findall(r"`(python [^`]+)`[^`\n]*\n\n```\n(.*?)```", ANSWERS, flags=re.S)


# --- every exercise's answer, whatever its form ---


@functools.cache
def asked(module_name: str, *argv: str) -> tuple:
    """(what `python -m exercises.<module_name> ARGV` prints, run here, and what its ask() declared: {"question",
    "answers"}); bare, a predict-then-run exercise's question; with --help, its help."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        importlib.import_module(f"exercises.{module_name}").main(list(argv))
    return out.getvalue(), dict(predict._asked)


def graded_answers() -> dict:
    """{number: its truth} for every predict-then-run exercise: ANSWERS.md's "The graded answer is `...`", read by
    the exercise's own parser (the `answers` its ask() declares), so it comes in the prediction's own form: a
    value per name, a set of names, a name or a number. Nothing here knows an exercise by its number."""
    answers = {}
    for number, module_name, kind in EXERCISES:
        if kind != "predict":
            continue
        found = re.search(r"The graded answer is `([^`]+)`", section(f"Exercise {number}"))
        assert found, f"ANSWERS.md's exercise {number} says no \"The graded answer is `...`\": the tests read it there"
        answers[number] = asked(module_name)[1]["answers"].parse(found.group(1))
    return answers


def giveaways() -> dict:
    """{number: [regular expression]}: the words that give each exercise's answer away besides the answer itself,
    from the "Giveaways" paragraph of its section of ANSWERS.md."""
    found = {}
    for number, _, _ in EXERCISES:
        paragraph = re.search(r"\nGiveaways .*?(?:\n\n|$)", section(f"Exercise {number}"), flags=re.S)
        found[number] = re.findall(r"`([^`]+)`", " ".join(paragraph.group(0).split("\n"))[1:]) if paragraph else []
    return {number: [p for p in patterns if p != "tests/test_docs.py"] for number, patterns in found.items()}


# A claim the chapter itself makes may be read anywhere: it names semi-implicit Euler's symplectic band.
THE_CHAPTER_SAYS = {("semi_implicit", "stays")}
NEAR = 8  # words: a name and its value this close, in one sentence, is a claim
STOP = set("a an and are as at by compared does each far for from happens how in is it its many much of on one or"
           " than the to under what which with".split())
SPELLED = {16: "sixteen", 32: "thirty-two", 1000: "thousand"}  # "two" and "four" say too much else


def stem(word: str) -> str:
    return word[:5] if len(word) >= 6 else word.rstrip("s")


def words_of(sentence: str) -> list:
    """The sentence's words, lower case, possessives off: 'semi-implicit', 'euler', '2,000', '5.1e-11', 'e~'."""
    return [w.removesuffix("'s") for w in re.findall(r"[a-z0-9_~][\w~.,'/-]*[\w~]|[a-z0-9~]", sentence.lower())]


def where(words: list, names: predict.OneOf) -> list:
    """[(start, end, what)] for every run of words that one of `names` names, the longest run first."""
    return runs_named(tuple(words), tuple(names.names))


@functools.cache  # the same sentences are searched for every claim of every exercise
def runs_named(words: tuple, names: tuple) -> list:
    find, found, at = predict.OneOf(names).find, [], 0
    while at < len(words):
        for length in range(min(predict.LONGEST_NAME, len(words) - at), 0, -1):
            name = find(" ".join(words[at:at + length]))
            if name is not None:
                found.append((at, at + length, name))
                at += length
                break
        else:
            at += 1
    return found


def key_stems(question: str, names) -> set:
    """What the question asks about, as word stems: the words of its last clause that ends in '?', less names
    and small words."""
    clause = re.split(r"[.:]\s", " ".join(question.split()).rpartition("?")[0])[-1]
    return {stem(w) for w in words_of(clause) if (len(w) > 2 or "~" in w) and w not in STOP and not w[0].isdigit()
            and predict.OneOf(names).find(w) is None}


def claims(truth, answers, question: str):
    """Functions sentence -> bool, one per thing the answer says: a name with its value close by (a value per
    name), an answer's name with the question's own words (a set or a name), a number with its unit or after
    --predict (a number)."""
    def near(a, b):
        return any(abs(x[0] - y[0]) <= NEAR or abs(x[1] - y[1]) <= NEAR for x in a for y in b)

    def number_forms(n):
        return {str(n), f"{n:,}", f"{n:_}", f"{n:.0e}".replace("e+0", "e").replace("e+", "e"), SPELLED.get(n, str(n))}

    if isinstance(truth, dict):
        names = answers.names
        for name, value in truth.items():
            if (name, value) in THE_CHAPTER_SAYS:
                continue
            if isinstance(value, str):
                values, keys = predict.OneOf(answers.values), key_stems(question, names.names)

                def said(sentence, name=name, value=value, values=values, keys=keys):
                    words = words_of(sentence)
                    if {w[2] for w in where(words, values)} == set(values.names):
                        return False  # the choices listed, as the question lists them: no claim
                    return near([w for w in where(words, names) if w[2] == name],
                                [w for w in where(words, values) if w[2] == value]) and \
                        any(stem(w) in keys for w in words)
            else:
                keys, forms = key_stems(question, names.names), number_forms(value)

                def said(sentence, name=name, forms=forms, keys=keys):
                    words = words_of(sentence)
                    return near([w for w in where(words, names) if w[2] == name],
                                [(i, i + 1) for i, w in enumerate(words) if w.split("-")[0] in forms]) and \
                        any(stem(w) in keys for w in words)
            yield f"{name}={value}", said
    elif isinstance(truth, (str, frozenset)):
        names = answers if isinstance(answers, predict.OneOf) else answers.names
        keys = key_stems(question, names.names)
        for name in sorted({truth} if isinstance(truth, str) else truth):
            def said(sentence, name=name, keys=keys):
                words = words_of(sentence)
                named = {w[2] for w in where(words, names)}
                return name in named and named != set(names.names) and \
                    len({stem(w) for w in words} & keys) >= min(3, len(keys))
            yield name, said
    else:
        unit, forms = getattr(answers, "unit", "") or "\0", number_forms(truth)

        def said(sentence, forms=forms):
            flat = " ".join(sentence.lower().split())
            return any(re.search(rf"(?<![\w.,]){re.escape(form)}(?![\w.,]) {unit}|--predict {re.escape(form)}\b",
                                 flat) for form in forms)
        yield f"{truth:,}", said


def sentences(text: str) -> list:
    return [s for s in re.split(r"(?<=[.!?;])\s+|\n\s*[-*] |\n\s*\n", text) if s.strip()]


def measured_figures(number: int) -> set:
    """The figures (three significant digits or more) an exercise's pasted runs print, less its own inputs."""
    blocks = re.findall(r"```\n(.*?)```", section(f"Exercise {number}"), flags=re.S)
    numbers = set(re.findall(r"\d[\d,]*\.\d+(?:e[-+]\d+)?(?![.\d])|\d{1,3}(?:,\d{3})+|\b\d{3,}\b", "".join(blocks)))
    module_name = next(name for n, name, _ in EXERCISES if n == number)
    inputs = " ".join([asked(module_name)[0], asked(module_name, "--help")[0]]) if number in graded_answers() else ""
    def digits(n):  # significant ones: 1.99 and 727 have three, dt 0.25 two, 2,000 steps one
        mantissa = re.sub(r"e.*", "", n)
        return len(re.sub(r"\D|^[0.]+", "", mantissa if "." in mantissa else mantissa.rstrip("0,")))

    return {n for n in numbers if digits(n) >= 3 and not re.search(rf"(?<![\d.,]){re.escape(n)}(?!\d)", inputs)}


def spoilers(number: int, figures: bool = True) -> list:
    """[(what it gives away, a function of a sentence or a regular expression)] for one exercise's answer."""
    found = []
    truth = graded_answers().get(number)
    if truth is not None:
        module_name = next(name for n, name, _ in EXERCISES if n == number)
        declared = asked(module_name)[1]
        found += [(f"exercise {number}'s answer {what}", said)
                  for what, said in claims(truth, declared["answers"], declared["question"])]
        if isinstance(truth, dict):  # the answer typed as an answer: name=value
            found += [(f"exercise {number}'s answer {n}={v}", rf"\b{n}\s*[=:]\s*{v}\b") for n, v in truth.items()
                      if (n, v) not in THE_CHAPTER_SAYS]
    found += [(f"exercise {number}'s giveaway /{pattern}/", pattern) for pattern in giveaways()[number]]
    found += [(f"exercise {number}'s measured figure {figure}", rf"(?<![\d.,]){re.escape(figure)}(?![\d])")
              for figure in (measured_figures(number) if figures else ())]
    return found


def leaks_in(text: str, found: list) -> list:
    hits = []
    for what, spoiler in found:
        if callable(spoiler):
            hits += [f"{what}: {s.strip()[:120]!r}" for s in sentences(text) if spoiler(s)]
        else:
            hits += [f"{what}: {m.group(0)!r}" for m in re.finditer(spoiler, text, flags=re.I)]
    return hits


# --- what a student reads before each exercise ---


def without_output_blocks(text: str) -> str:
    """Output blocks (the chapter's drift table, pasted runs) are measurements of the chapter, not answers;
    prose and ```bash blocks are where the old spoilers were."""
    return re.sub(r"```(\w*)\n.*?```", lambda block: block.group(0) if block.group(1) else "", text, flags=re.S)


def by_exercise(text: str, heading: str) -> dict:
    """{number: its section} from `## {heading}N` headings; 0 for what is outside them."""
    parts = re.split(r"^(?=## )", text, flags=re.M)
    split = {}
    for part in parts:
        found = re.match(rf"## {heading}(\d+)\b", part)
        number = int(found.group(1)) if found else 0
        split[number] = split.get(number, "") + part
    return split


def explanations() -> dict:
    """{number: what its runs print after the verdict: the lesson and, under --more, the whole explanation},
    from the runs ANSWERS.md pastes (the slow test below reruns them and compares, and the lesson test checks
    that the default lesson is the one pasted)."""
    told = {}
    for number, _, _ in EXERCISES:
        for block in re.findall(r"```\n(.*?)```", section(f"Exercise {number}"), flags=re.S):
            after = re.split(r"^(?:Right:|Not quite:|All solved\.).*$", block, maxsplit=1, flags=re.M)
            told[number] = told.get(number, "") + (after[1] if len(after) > 1 else "")
    return told


def prose_of(path) -> str:
    """What a reader takes from a source file besides its code: its docstrings and comments."""
    source = path.read_text()
    nodes = [node for node in ast.walk(ast.parse(source)) if isinstance(node, ast.Module | ast.FunctionDef)]
    comments = [t.string for t in tokenize.generate_tokens(io.StringIO(source).readline) if t.type == tokenize.COMMENT]
    return "\n".join([*(ast.get_docstring(node) or "" for node in nodes), *comments])


def read_before(number: int) -> dict:
    """{where: text} for what a student reads before committing to exercise `number`'s prediction, besides what
    the earlier exercises printed: README (before exercise 1, up to its request to do it), the exercises' README,
    the hints up to this exercise, the docstrings, --help and bare questions of this exercise and the earlier
    ones, and engine.py, top to bottom, from the exercise before which the Next lines send the student to it."""
    from curriculum.common.exercise import READ_FIRST

    readme = without_output_blocks((REPO / "README.md").read_text())
    readme = "\n".join(line for line in readme.splitlines() if not line.startswith("|"))  # the chapter's table
    if number == 1 and "do exercise 1" in readme:
        readme = readme[: readme.index("do exercise 1")]
    texts = {"README.md": readme,
             "exercises/README.md": without_output_blocks((REPO / "exercises" / "README.md").read_text())}
    hints = by_exercise((REPO / "exercises" / "HINTS.md").read_text(), "Exercise ")
    texts |= {f"exercises/HINTS.md, exercise {n}": text for n, text in hints.items() if n <= number}
    if any("engine.py" in before and number >= n for n, before in READ_FIRST.items()):
        texts["engine.py's docstrings and comments"] = prose_of(REPO / "engine.py")
    for n, module_name, _ in EXERCISES:
        if n > number:
            continue
        if module_name == PRISTINE_STUB.stem:  # the stub as a student first opens it: the pristine copy
            texts["exercises/ex2_integrators.py docstring"] = ast.get_docstring(ast.parse(PRISTINE_STUB.read_text()))
            checker = f"check_ex{n}"
            texts[f"python -m exercises.{checker} --help"] = asked(checker, "--help")[0]
            texts[f"exercises/{checker}.py docstring"] = importlib.import_module(f"exercises.{checker}").__doc__
            continue
        texts[f"exercises/{module_name}.py docstring"] = importlib.import_module(f"exercises.{module_name}").__doc__
        texts[f"python -m exercises.{module_name} --help"] = asked(module_name, "--help")[0]
        texts[f"python -m exercises.{module_name} (bare question)"] = asked(module_name)[0]
    return texts


@pytest.mark.parametrize("number, module", [(n, m) for n, m, kind in EXERCISES if kind == "predict"])
def test_every_predict_then_run_exercise_has_its_answer_for_teachers(number, module):
    """An exercise is its file, its section in exercises/README.md and its section in ANSWERS.md: this names the
    section that is missing, with the command and the output a teacher reads (pasted from a run)."""
    assert f"## Exercise {number}" in ANSWERS, f"exercises/solutions/ANSWERS.md has no '## Exercise {number}' section"
    commands = [command for command, _ in answers_with_their_commands() if f"-m exercises.{module} " in command]
    assert commands, (f"ANSWERS.md's exercise {number} shows no `python -m exercises.{module} --predict ...` line"
                      " with the output it prints below it")
    assert all("--predict" in command for command in commands)
    truth = graded_answers()[number]  # and its graded answer is what those runs measured: they say "Right"
    for command, pasted in answers_with_their_commands():
        if f"-m exercises.{module} " in command:
            typed = re.search(r"--predict (.+?)(?= --|$)", command).group(1)
            assert asked(module)[1]["answers"].parse(typed) == truth and "\nRight: " in pasted, command


@pytest.mark.parametrize("number", [n for n, _, _ in EXERCISES])
def test_nothing_a_student_reads_first_gives_an_answer_away(number):
    """Exercise `number`'s answer, in any of its forms, in nothing read before it: README, the exercises' README,
    the hints, the docstrings, --help and bare questions, engine.py once the student is sent to it, and the
    lessons and full explanations the exercises before it printed."""
    found = spoilers(number)
    leaks = [f"{where}: {leak}" for where, text in read_before(number).items() for leak in leaks_in(text, found)]
    # An earlier exercise's own figures may be this one's too (exercises 1, 4 and 7 all measure the orbit's
    # semi-implicit band): its explanations are searched for everything else.
    found = spoilers(number, figures=False)
    leaks += [f"what exercise {n} printed after its prediction (ANSWERS.md): {leak}"
              for n, text in explanations().items() if n < number for leak in leaks_in(text, found)]
    assert not leaks, "\n".join(leaks)


def test_readme_shows_the_measurement_then_asks_for_exercise_1():
    """The table, then the request to do exercise 1 with its command; what exercise 1 measures is exercise 1's to
    tell, after the prediction (its --more), and the spoiler test reads the whole README for it."""
    readme = (REPO / "README.md").read_text()
    table, ask = readme.index("rel_final       rel_max"), readme.index("do exercise 1")
    assert table < ask and "python -m exercises.ex1_band" in readme[ask:ask + 400]
    assert "What exercise 1 measures" not in readme


def test_readmes_map_names_code_that_exists_where_it_says():
    """README's "The chapter in the code": every `module.name` and every `file`: `name` it gives is defined there,
    and each of the chapter's five listings has its row."""
    readme = (REPO / "README.md").read_text()
    rows = readme.split("## The chapter in the code")[1].split("\n\n")[1].splitlines()[2:]
    assert len(rows) >= 5 and {"`build_system`", "`simulate`", "`log_rerun`", "`COLORS`"} <= set(re.findall(
        r"`\w+`", " ".join(row.split("|")[1] for row in rows)))
    for row in rows:
        here = row.split("|")[2]
        named = re.findall(r"`(\w+)\.(?!py`)(\w+)`", here) + [(path[:-3].replace("/", "."), name) for path, names in
                                                       re.findall(r"`([\w/]+\.py)`: ([^;|]+)", here)
                                                       for name in re.findall(r"`(\w+)`", names)]
        assert named, row
        for module, name in named:
            assert hasattr(importlib.import_module(module), name), f"README's map: {module} has no {name}"


def test_readmes_pasted_runs_are_what_the_engine_prints(tmp_path):
    """README's two pasted runs, line for line (the default run whole, but for its wall clock; the freefall's table)."""
    readme = (REPO / "README.md").read_text()
    fences = re.findall(r"^```(\w*)\n(.*?)^```$", readme, flags=re.S | re.M)  # (info string, body), in order
    blocks = [body for info, body in fences if not info and "integrator " in body]
    runs = [run_engine(cwd=tmp_path), run_engine("--system", "freefall", "--no-rerun", cwd=tmp_path)]
    for block, result in zip(blocks, runs, strict=True):
        assert result.returncode == 0, result.stderr
        printed = [line for line in result.stdout.splitlines() if not line.startswith(("wall-clock", "[ch3.3"))]
        pasted = [line for line in block.splitlines() if not line.startswith(("wall-clock", "[ch3.3"))]
        start = printed.index(pasted[0]) if pasted[0] in printed else 0
        rows = [line for line in printed if line.split(" ")[0] in engine.INTEGRATORS]  # a new integrator's too
        assert pasted == printed[start:start + len(pasted)] and set(rows) <= set(pasted), (
            "README's pasted run is not what `python engine.py` prints now: paste it again\n" + result.stdout)


def test_exercise_1_explains_what_it_measures():
    """README's "What exercise 1 measures" moves into exercise 1's --more (issue 25): each of its facts is there,
    as exercise 1 prints it (ANSWERS.md pastes the run; the slow test reruns it)."""
    told = " ".join(explanations()[1].split())
    for fact in ["+22.1% after the chapter's run, +62.5% after 16x, its worst excursion always the last step",
                 "never once below E0", "the orbit spirals out",
                 "from -2.198e-04 to +3.203e-04 after the chapter's run, which ends at +9.826e-05: its worst excursion"
                 " is bigger than where it ends",
                 "1.0000003 times as wide", "5.13e-11 of the energy, 6.2e+06 times below the top of semi-implicit",
                 "14.0 times as wide for 16 times the run", "412 of the 1,000 are above E0 at some step (1,000 end"]:
        assert fact in told, fact


def test_the_spoiler_patterns_catch_the_old_leaks():
    """The texts that leaked before this test existed (issues 7 and 25) must be caught, or the test proves nothing."""
    old = {1: ["python -m exercises.ex1_band --predict euler=grows,semi_implicit=stays,rk4=grows",
               "Explicit Euler's worst excursion is its final one: the error only grows, and the orbit spirals out.",
               "Fails on anything that oscillates: it adds energy every step, so orbits spiral out.",
               "Energy wobbles in a band that does not grow; it fails where motion never returns (freefall).",
               "Tiny error per step, but it creeps one way and is never pulled back over long runs.",
               "Which of the three integrators sends the Kepler orbit's energy climbing without bound?",
               "Explicit Euler's energy error grows with every step.", "RK4's error grows, slowly."],
           3: ["python -m exercises.ex3_halve_dt --predict euler=2,semi_implicit=2,rk4=16",
               "the final-position error on the orbit settles at 1.99 (Euler), 1.97 (semi-implicit) and 17.36 (RK4)",
               "RK4's error drops by about sixteen", "Euler's error roughly halves and RK4's drops by 16",
               "Halve dt and RK4's position error shrinks 16-fold."],
           4: ["python -m exercises.ex4_long_run --predict 1,000", "after 727 orbits", "about 1,000 orbits"],
           5: ["semi-implicit Euler keeps the area", "RK4's area shrinks a little every step"],
           6: ["Only RK4 and the implicit step stay bounded at this damping."],
           7: ["With area 1 and a stable step there is a nearby quadratic the step keeps exactly: E~ = E - k dt x v/2.",
               "On the spring E~ changes by round-off only."]}
    for number, texts in old.items():
        for text in texts:
            assert leaks_in(text, spoilers(number)), (number, text)
    assert len(measured_figures(3) | measured_figures(4)) > 40  # the pasted runs' figures are found


def test_the_spoiler_test_knows_an_answer_that_is_one_name():
    """Tried as a new maintainer would (issue 25): an exercise whose answer is a single name. Its question, its
    answer parsed by its own OneOf, and the sentence written into exercises/README.md, which must be caught."""
    answers = predict.OneOf(["euler", "rk4", "yoshida4"])
    question = "Run the orbit for 2000 steps: which of euler, rk4 and yoshida4 ends with the smaller position error?"
    found = list(claims(answers.parse("Yoshida4"), answers, question))
    assert [what for what, _ in found] == ["yoshida4"]
    said = found[0][1]
    assert said("yoshida4 ends with the smaller error, 7.3 times smaller.")
    assert said("Its error ends smaller under Yoshida4 than under the others.")
    assert not said(question)  # the question names every candidate: it says nothing
    assert not said("yoshida4 is a fourth-order method with three force evaluations a step.")


# --- every command printed in the READMEs runs as written, from the repo root ---

YOUR_FILE = ("path/to/your_file.py", "exercises/solutions/ex2_integrators.py")


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


def filled(command: str) -> str:
    """The command with ANSWERS.md's values in its placeholders: the prediction its section pastes, its file."""
    predicted = re.search(r"--predict (\S+)", command)
    if predicted and re.search(r"[<?]", predicted[1]):
        module = command.split()[2]
        pasted = [c for c, _ in answers_with_their_commands() if c.startswith(f"python -m {module} --predict ")]
        assert pasted, f"{command}: ANSWERS.md pastes no --predict run of {module} to take a prediction from"
        command = command.replace(predicted[1], re.search(r"--predict (.+?)(?= --|$)", pasted[0])[1])
    return command.replace(*YOUR_FILE)


def run_elsewhere(command: str) -> bool:
    """A bare question is run by tests/test_exercises.py (from a scratch folder, where a file written would show),
    ANSWERS.md's runs by the lesson test (without --more) and by the slow test below (with it)."""
    return command in [f"python -m exercises.{module}" for module in PREDICT_THEN_RUN] + [
        c.replace(" --more", "") for c, _ in answers_with_their_commands()]


def test_the_readmes_print_the_commands_we_expect():
    commands = [c for _, c in printed_commands()]
    for module in [*PREDICT_THEN_RUN, *CHECKERS]:
        assert any(f"python -m exercises.{module}" in c for c in commands), \
            f"exercises/README.md shows no command for {module}: give it a section with its commands"
    assert any(c.startswith("python engine.py") for c in commands)


@pytest.mark.parametrize("readme, command", [
    pytest.param(readme, command, marks=pytest.mark.slow if "engine.py" in command or "--predict" in command else ())
    for readme, command in printed_commands() if not run_elsewhere(filled(command))])
def test_every_printed_command_runs_as_written(readme, command, tmp_path):
    """Placeholders filled from ANSWERS.md; what a run writes goes to scratch (engine's --out, exercise 5's --rrd,
    the hand-in). Slow: the engine's runs and the measuring ones."""
    argv, scratch = shlex.split(filled(command)), []
    if argv[1] == "engine.py" and "--help" not in argv:
        scratch = ["--out", tmp_path / "out"]
    elif "exercises.ex5_phase_blob" in argv or "--handin" in argv:
        scratch = ["--rrd", tmp_path / "blob.rrd"] if "--predict" in argv else ["--out", tmp_path / "handin.zip"]
    result = subprocess.run([sys.executable, *argv[1:], *scratch], cwd=REPO, capture_output=True, text=True,
                            timeout=600)
    expected = {0, 1} if "check_ex2" in command else {0}  # a bare question too: asking is not an error
    assert result.returncode in expected and result.stderr == "", f"{command}\n{result.stdout}\n{result.stderr}"
    assert not scratch or scratch[1].exists(), f"{command}: wrote no {scratch[1].name}"


@pytest.mark.parametrize("module", [*PREDICT_THEN_RUN, *CHECKERS])
@pytest.mark.parametrize("inside", [False, True], ids=["from the root", "from inside exercises"])
def test_every_exercise_runs_as_a_file_too(module, inside):
    """`python exercises/ex1_band.py` from the root, or `cd exercises && python ex1_band.py`: the first
    lines of each file (curriculum.common.exercise.start) make both work."""
    cwd, script = (REPO / "exercises", f"{module}.py") if inside else (REPO, f"exercises/{module}.py")
    result = subprocess.run([sys.executable, script, *(["--help"] if module in CHECKERS else [])], cwd=cwd,
                            capture_output=True, text=True, timeout=60)
    assert result.stderr == ""
    if module in CHECKERS:
        assert result.returncode == 0 and "usage:" in result.stdout
    else:
        assert result.returncode == 0 and f"python {script} --predict ANSWER" in result.stdout


def test_every_answer_block_says_which_command_printed_it():
    assert len(answers_with_their_commands()) == ANSWERS.count("```\n") // 2 >= 5


@pytest.mark.slow
@pytest.mark.parametrize("command, pasted", answers_with_their_commands())
def test_the_answers_are_what_the_commands_print_today(command, pasted):
    """The physics is deterministic, so the teachers' figures must be reproduced to the last digit."""
    result = subprocess.run([sys.executable, *shlex.split(command)[1:]], cwd=REPO, capture_output=True, text=True,
                            timeout=600)
    assert result.stdout == pasted, f"{command}: ANSWERS.md is out of date; paste the new output"


def test_metrics_json_says_0_0_where_developing_says_so():
    """docs/DEVELOPING.md: from --dt 0.004 down RK4's drift "rounds to `0.0` in the file": never `-0.0`."""
    assert "which rounds to `0.0` in the file" in " ".join((REPO / "docs" / "DEVELOPING.md").read_text().split())
    written = json.loads(report.metrics_text(report.rounded({"rel_final": -4.4e-13, "rel_max": [-0.0, 1e-13]})))
    assert written == {"rel_final": 0.0, "rel_max": [0.0, 0.0]}
    assert all(math.copysign(1.0, x) == 1.0 for x in [written["rel_final"], *written["rel_max"]])


def test_ci_builds_its_own_environment_and_leaves_the_students_venv_alone():
    """README tells a student to create .venv; `bash .ci/run` must neither delete nor reuse it."""
    code = [line for line in (REPO / ".ci" / "run").read_text().splitlines() if not line.lstrip().startswith("#")]
    assert not any(re.search(r"(?<![\w/])\.venv\b", line) for line in code), "\n".join(code)
    created = re.search(r"python3 -m venv (\S+)", "\n".join(code)).group(1)
    assert f"{created}/" in (REPO / ".gitignore").read_text().splitlines()
    assert "python3 -m venv .venv" in (REPO / "README.md").read_text()


@pytest.mark.slow
def test_rk4s_round_off_digits_are_what_exact_arithmetic_says():
    """docs/DEVELOPING.md: RK4's -4.5061e-11 and 5.1299e-11 are -4.5066e-11 and 5.1303e-11 with the same steps in
    50 digits."""
    system = engine.build_system("orbit", np.random.default_rng(0))
    with localcontext() as context:
        context.prec = 50
        state, dt = [Decimal(x) for x in [*system["q0"][:2], *system["v0"][:2]]], Decimal(0.01)  # x, y, vx, vy

        def slope(s):  # (v, the pull): r^-3 times -q
            r2 = s[0] * s[0] + s[1] * s[1]
            return [s[2], s[3], -s[0] / (r2 * r2.sqrt()), -s[1] / (r2 * r2.sqrt())]

        def energy(s):
            return (s[2] * s[2] + s[3] * s[3]) / 2 - 1 / (s[0] * s[0] + s[1] * s[1]).sqrt()

        def moved(s, k, h):
            return [x + h * y for x, y in zip(s, k, strict=True)]

        e0, errors = energy(state), []
        for _ in range(2000):
            k1 = slope(state)
            k2 = slope(moved(state, k1, dt / 2))
            k3 = slope(moved(state, k2, dt / 2))
            k4 = slope(moved(state, k3, dt))
            state = [x + dt / 6 * (a + 2 * b + 2 * c + d) for x, a, b, c, d in zip(state, k1, k2, k3, k4, strict=True)]
            errors.append((energy(state) - e0) / abs(e0))
    developing = (REPO / "docs" / "DEVELOPING.md").read_text()
    exact_final, exact_max = float(errors[-1]), float(max(abs(e) for e in errors))
    assert f"give {exact_final:.4e} and {exact_max:.4e}" in " ".join(developing.split())
    drift = engine.energy_drift(run("orbit", "rk4")[2])
    assert f"{drift['rel_final']:.4e}" != f"{exact_final:.4e}" and f"{drift['rel_final']:.2e}" == f"{exact_final:.2e}"


@pytest.mark.slow  # each recomputes what a quick test checks (the orders, the damped ladder, the parity)
@pytest.mark.parametrize("tool, doc", [("orders", "docs/DEVELOPING.md"), ("damped", "docs/damping.md"),
                                       ("parity", "docs/DEVELOPING.md docs/damping.md")])
def test_the_figures_a_maintainer_prints_by_hand_come_from_tools_and_are_the_docs(tool, doc, tmp_path):
    """What is run by hand sits in tools/ (tests/ holds tests and the modules they import); each figure it
    prints is pasted in the page that quotes it."""
    if tool == "parity":
        pytest.importorskip("mujoco", reason="needs the 'mujoco' extra")
    result = subprocess.run([sys.executable, str(REPO / "tools" / "figures.py"), tool], cwd=tmp_path,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    pages = "".join((REPO / page).read_text() for page in doc.split())
    figures = [line for line in result.stdout.splitlines() if "orders" in line or "|q_ours" in line]
    assert figures and not [line for line in figures if line not in pages]


# --- the students' pages read short, and every exercise answers with a short lesson (issue 25) ---
# Pages measured as ../shared/tools/prose-metrics measures them: words of prose (outside code blocks, tables and
# pictures), each paragraph's numerals per sentence, the longest sentence. Each exercise, run as ANSWERS.md runs
# it but without --more: after its verdict a lesson of at most LESSON_WORDS words, the one ANSWERS.md pastes (so
# the spoiler test reads it), then the Next line, last.

NUMERAL = r"(?<![\w.])[-+]?\d[\d,]*(?:\.\d+)?(?:e[-+]?\d+)?%?"  # 2,000, 0.032%, 5.1e-11; not RK4, not "four"
WORD = r"[A-Za-z0-9][\w'.,%/-]*"
LESSON_WORDS = 120


def prose(text: str) -> str:
    """The page without its code blocks, tables and pictures."""
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    return "\n".join(line for line in text.splitlines()
                     if not line.lstrip().startswith("|") and not line.startswith("!["))


def measure(text: str) -> dict:
    """{words, densest: (numerals per sentence, paragraph), longest: (words, sentence)}, as prose-metrics counts."""
    text = prose(text)
    densest, longest = (0.0, ""), (0, "")
    for paragraph in re.split(r"\n\s*\n", text):
        if not paragraph.strip() or paragraph.strip().startswith("#"):
            continue
        flat = paragraph.replace("\n", " ")
        sentences = [s for s in re.split(r"(?<=[.!?:])\s+(?=[A-Z(`*])", flat) if len(s.split()) > 3]
        if not sentences:
            continue
        density = len(re.findall(NUMERAL, flat)) / len(sentences)
        densest = max(densest, (density, flat[:80]))
        longest = max(longest, *((len(s.split()), s[:80]) for s in sentences))
    return {"words": len(re.findall(WORD, text)), "densest": densest, "longest": longest}


def test_the_measure_counts_as_the_issue_does():
    page = ("# Title\n\nOne two three four five. The run took 2,000 steps of 0.01 s: RK4 kept 5.1e-11.\n\n"
            "```bash\npython engine.py --steps 123\n```\n\n| a | 1 |\n|---|---|\n\n![a picture](x.png)\n")
    measured = measure(page)
    assert measured["words"] == 1 + 5 + 11  # the heading counts; the code, the table and the picture do not
    # 3 numerals in 2 sentences: "RK4 kept 5.1e-11." is too short to count as one, and its numeral counts
    assert measured["densest"][0] == 1.5 and measured["longest"][0] == 8


def test_the_measure_is_the_issues_tool_where_it_is_installed():
    """The course's machines keep the issue's own tool beside the checkout (../shared/tools/prose-metrics)."""
    tool = REPO.parent / "shared" / "tools" / "prose-metrics"
    if not tool.is_file():
        pytest.skip(f"{tool} is not on this machine: test_the_measure_counts_as_the_issue_does stands for it")
    pages = ["README.md", "exercises/README.md"]
    said = subprocess.run([sys.executable, str(tool), *pages], cwd=REPO, capture_output=True, text=True,
                          timeout=60).stdout.splitlines()
    for page, line in zip(pages, said, strict=True):
        measured = measure((REPO / page).read_text())
        assert line == (f"{page}: {measured['words']} words; densest paragraph {measured['densest'][0]:.1f}"
                        f" numerals/sentence; longest sentence {measured['longest'][0]} words")


@pytest.mark.parametrize("page, most_words", [
    ("README.md", 900),
    ("exercises/README.md", 800)])
def test_a_students_page_reads_short(page, most_words):
    """At most `most_words` words of prose, every paragraph at most 2 numerals a sentence on average, no sentence
    over 40 words."""
    measured = measure((REPO / page).read_text())
    assert measured["words"] <= most_words, f"{page}: {measured['words']} words of prose, over {most_words}"
    density, paragraph = measured["densest"]
    assert density <= 2.0, f"{page}: {density:.1f} numerals a sentence in the paragraph {paragraph!r}"
    words, sentence = measured["longest"]
    assert words <= 40, f"{page}: a sentence of {words} words: {sentence!r}"


@pytest.mark.slow  # each run measures for seconds, as the --more rerun above does
@pytest.mark.parametrize("command, pasted", answers_with_their_commands())
def test_each_exercise_answers_with_a_short_lesson_then_the_next_line(command, pasted):
    """Without --more: the verdict, a lesson of at most LESSON_WORDS words (the same lesson --more starts with,
    pasted in ANSWERS.md) and the Next line, last. Exercise 2's checker says "All solved." (then, for a file that is not
    the exercise's own, which one the board reads) and then Next."""
    argv = [word for word in shlex.split(command)[1:] if word != "--more"]
    result = subprocess.run([sys.executable, *argv], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    lines = result.stdout.rstrip("\n").splitlines()
    assert lines[-1].startswith("Next: "), f"{command}: the run does not end with its Next line"
    if "check_ex" in command:
        assert "All solved." in lines[-3:-1], command
        return
    verdict = max(i for i, line in enumerate(lines) if line.startswith(("Right: ", "Not quite: ")))
    lesson = lines[verdict + 1:-1]
    words = len(re.findall(WORD, "\n".join(lesson)))
    assert words <= LESSON_WORDS, f"{command}: a lesson of {words} words, over {LESSON_WORDS}"
    assert lesson[-1] == predict.MORE and "--more" in command  # where the rest is, and ANSWERS.md pastes the rest
    shown = "\n".join(lines[: verdict + 1] + lesson[:-1])
    assert pasted.startswith(shown + "\n"), f"{command}: ANSWERS.md pastes another lesson than the run prints"
