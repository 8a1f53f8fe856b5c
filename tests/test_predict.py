"""The one prediction parser (curriculum/common/predict.py): every exercise reads answers the same way,
as people type them, refuses the rest in one line that says what it expected, and does both in time
linear in what was typed."""

import os
import re
import subprocess
import sys

import pytest

from conftest import REPO
from curriculum.common.predict import Number, OneOf, PerName, SomeOf

NAMES = ["euler", "semi_implicit", "rk4"]  # the chapter's three, as the exercises ask about them
FOUR = [*NAMES, "implicit"]
FACTORS = [1, 2, 4, 8, 16, 32]
ORBITS = [10, 100, 1_000, 10_000, 100_000]
WORDS = ["grows", "stays", "shrinks"]


@pytest.mark.parametrize("answers, typed, answer", [
    (OneOf(FOUR), ["Euler", "explicit Euler", "forward euler"], "euler"),
    (OneOf(FOUR), [" semi-implicit", "Semi Implicit", "symplectic Euler", "semi-implicit Euler"], "semi_implicit"),
    (OneOf(FOUR), ["RK4", "RK-4", "Runge-Kutta 4"], "rk4"),
    (OneOf(FOUR), ["Implicit Euler", "backward Euler"], "implicit"),
    (Number(ORBITS), ["10000", "10,000", "10_000", "10 000", "1e4", "1E4", "10000.0", "10k", "10K", " 10 k "], 10_000),
    (Number(ORBITS), ["1k", "1000"], 1_000),
    (Number([10, 100, 1_000], unit="orbit"), ["1000 orbits", "1k orbits", "1000 Orbit"], 1_000),
])
def test_names_and_numbers_parse_as_people_type_them(answers, typed, answer):
    assert [answers.parse(text) for text in typed] == [answer] * len(typed)


@pytest.mark.parametrize("values, answer", [(FACTORS, {"euler": 2, "semi_implicit": 4, "rk4": 16}),
                                            (WORDS, {"euler": "grows", "semi_implicit": "stays", "rk4": "shrinks"})])
def test_one_value_per_name_reads_every_spacing_and_separator(values, answer):
    """Exercise 3's numbers and exercise 5's words: the same forms, spaces alone between items included."""
    per_name = PerName(NAMES, values)
    e, s, r = (answer[name] for name in NAMES)
    for typed in (f"euler={e},semi_implicit={s},rk4={r}", f"euler={e}, semi_implicit={s}, rk4={r}",
                  f"euler={e} semi_implicit={s} rk4={r}", f"RK4 = {r}; Euler: {e}, semi-implicit={s}",
                  f"euler:{e}; semi implicit = {s}, RK-4={r}", f"euler={e}, rk4 = {r} semi_implicit={s}",
                  f"explicit Euler={e} symplectic euler={s} rk4={r},"):
        assert per_name.parse(typed) == answer, typed
    words = PerName(NAMES, ["grows", "stays"])  # exercise 1's question says "grow with the run, or stay in a band"
    assert words.parse("euler=grows with the run, semi_implicit=stays in a band, rk4=bounded") == \
        {"euler": "grows", "semi_implicit": "stays", "rk4": "stays"}


PER_NAME = PerName(NAMES, FACTORS)


@pytest.mark.parametrize("answers, typed, message", [
    (OneOf(NAMES), "backward euler", "'backward euler' is not one of euler, semi_implicit, rk4"),  # not this question's
    (Number(ORBITS), "1.000", r"'1.000' is not one of 10, 100, 1,000, 10,000, 100,000 \(written 10000, 10,000, 10_0"),
    *((Number(ORBITS), bad, "written 10000, 10,000, 10_000, 1e4 or 10k")
      for bad in ("ten", "1e400", "1.5", "12", "k", "1.5k", "")),
    *((Number([10, 100], unit="orbit"), bad, "with or without 'orbits'") for bad in ("orbits", "1000 apples")),
    (PER_NAME, "euler=, semi_implicit=4, rk4=16", "in 'euler=', nothing after the '=': put one of 1, 2, 4, 8"),
    (PER_NAME, "euler=?, semi_implicit=?, rk4=?", r"in 'euler=\?', put your value where the \? is: one of 1, 2, 4"),
    (PER_NAME, "euler=A, semi_implicit=B, rk4=C", "in 'euler=A', A is not one of 1, 2, 4, 8, 16, 32"),
    (PER_NAME, "euler=3, semi_implicit=2, rk4=16", "in 'euler=3', 3 is not one of 1, 2, 4, 8, 16, 32"),
    (PER_NAME, "euler=1.000, semi_implicit=2, rk4=16", "in 'euler=1.000', 1.000 is not one of 1, 2, 4"),
    (PER_NAME, "euler=2", "no value for semi_implicit, rk4: expected name=value for each of euler, semi_implicit, rk4"),
    (PER_NAME, "euler 2, semi_implicit=2, rk4=16", "'euler 2' has no '=': expected name=value"),
    (PER_NAME, "euler=2, euler=2, rk4=16", "euler is given twice"),
    (PER_NAME, "verlet=2, semi_implicit=2, rk4=16", "in 'verlet=2', 'verlet' is not one of euler, semi_implicit, rk4"),
    (PER_NAME, "euler=2, semi_implicit=2, rk4=16, 4", "in 'rk4=16, 4', 16, 4 is not one of 1, 2"),
    (PER_NAME, "=2", "in '=2', '' is not one of euler"),
    (PER_NAME, "", "the answer is empty: expected name=value"),
    (PerName(NAMES, WORDS), "euler=gr\x1bows", r"gr\\x1bows is not one of"),  # unquoted, escaped all the same
    (SomeOf(FOUR, "the ones that stay bounded", "an integrator"), "none, rk4",
     "'none' goes alone: answer with the ones that stay bounded, from euler"),
    (SomeOf(FOUR, "the ones that stay bounded", "an integrator"), "rk4, verlet",
     "'verlet' is not an integrator here: answer with the ones that stay"),
    (SomeOf(FOUR), " , ", "the answer is empty"),
])
def test_an_answer_that_does_not_read_says_what_was_expected(answers, typed, message):
    with pytest.raises(ValueError, match=message):
        answers.parse(typed)


def test_the_forms_show_the_template():
    assert OneOf(["grows", "stays"]).forms == "one of grows, stays (any case)"  # no '_' to stand in for
    assert PerName(NAMES, WORDS).forms == ("name=word for each of euler, semi_implicit, rk4, separated by commas, each"
                                           " word one of grows, stays, shrinks (like euler=A, semi_implicit=B, rk4=C,"
                                           " with your word for each letter)")


@pytest.mark.parametrize("typed, answer", [
    ("rk4, implicit", {"rk4", "implicit"}), ("Implicit and RK4", {"rk4", "implicit"}),
    ("RK 4 and implicit Euler", {"rk4", "implicit"}), ("rk4 + backward Euler", {"rk4", "implicit"}),
    ("backward euler", {"implicit"}), ("semi-implicit Euler rk4", {"semi_implicit", "rk4"}),
    ("rk-4, semi-implicit Euler", {"semi_implicit", "rk4"}), ("euler semi-implicit rk4", set(NAMES)),
    ("explicit Euler", {"euler"}), ("none", set()), ("none of them", set()), ("all", set(FOUR)),
    ("all four", set(FOUR)), ("All of them", set(FOUR)),
])
def test_some_of_reads_names_of_several_words_and_lists_as_typed(typed, answer):
    assert SomeOf(FOUR).parse(typed) == answer


MEGABYTE = 1_000_000


@pytest.mark.parametrize("answers, typed", [
    (Number(ORBITS, unit="orbit"), " " * MEGABYTE + "x"), (PerName(NAMES, FACTORS), "a" + " " * MEGABYTE + "b"),
    (PerName(NAMES, WORDS), "a" + " " * MEGABYTE + "b"), (OneOf(NAMES), "a" + " " * MEGABYTE + "b"),
    (SomeOf(FOUR), "a" + " " * MEGABYTE + "b"), (PerName(NAMES, FACTORS), "euler=" + " " * MEGABYTE + "2"),
    (PerName(NAMES, WORDS), "=" * MEGABYTE), (PerName(NAMES, FACTORS), "euler=2 " * (MEGABYTE // 8)),
    (Number(ORBITS), "1" + ",000" * (MEGABYTE // 4)), (Number(ORBITS), "1" + ".000" * (MEGABYTE // 4)),
    (SomeOf(FOUR), "semi " * (MEGABYTE // 5)), (PerName(NAMES, WORDS), "euler=" + "grows " * (MEGABYTE // 6)),
])
def test_a_megabyte_answer_is_refused_in_one_short_line(answers, typed):
    """Every parser is linear in its input: a quadratic parse of a megabyte would take hours (no clock is read:
    such a run would not end)."""
    with pytest.raises(ValueError) as refused:
        answers.parse(typed)
    assert len(str(refused.value)) < 400 and "\n" not in str(refused.value), "quotes a little of it, not all"


def exercise(module, *args):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", f"exercises.{module}", *args], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=60)


RAW = re.compile("[\x00-\x08\x0b-\x1f\x7f\u202a-\u202e\u2066-\u2069]")  # what a terminal would obey


@pytest.mark.parametrize("module, argv, refusal", [
    ("ex3_halve_dt", ["a" + " " * 130_000 + "b"], "'a b' has no '='"),  # one argument stays under Linux's 128 KiB
    ("ex3_halve_dt", ["euler=2,", "semi_implicit=3,", "rk4=16"], "in 'semi_implicit=3', 3 is not one of 1, 2, 4, 8"),
    ("ex3_halve_dt", ["euler=2", "--predict", "semi_implicit=3,rk4=16"], "in 'semi_implicit=3', 3 is not one of"),
    ("ex1_band", ["euler=\x1b[31mgrows,semi_implicit=stays,rk4=grows"], "\\x1b"),
    ("ex3_halve_dt", ["rk4=\u202e1"], "\\u202e"), ("ex5_phase_blob", ["\u202eeuler=x"], "\\u202e"),
    ("ex5_phase_blob", ["euler=grows,semi_implicit=st\x1b]0;x\x07ays,rk4=grows"], "\\x1b"),
])
def test_an_exercise_reads_a_prediction_in_many_words_as_one_and_refuses_it_escaped(module, argv, refusal):
    """A long one, one the shell split at its spaces, --predict given twice (both count, not the last); escape
    sequences and bidi overrides come back escaped (before, exercises 1, 3 and 5 echoed a value raw)."""
    result = exercise(module, "--predict", *argv)
    assert result.returncode == 2 and result.stdout == "" and len(result.stderr.splitlines()) == 1
    assert refusal in result.stderr and len(result.stderr) < 600 and not RAW.search(result.stderr)
