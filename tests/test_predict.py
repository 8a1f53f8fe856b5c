"""The one prediction parser (curriculum/common/predict.py): every exercise reads answers the same way,
as people type them, refuses the rest in one line that says what it expected, and does both in time
linear in what was typed."""

import argparse
import os
import re
import subprocess
import sys

import pytest

from conftest import REPO
from curriculum.common.predict import Number, OneOf, PerName, SomeOf, ask

NAMES = ["euler", "semi_implicit", "rk4"]  # the chapter's three, as the exercises ask about them
FOUR = [*NAMES, "implicit"]
FACTORS = [1, 2, 4, 8, 16, 32]
ORBITS = [10, 100, 1_000, 10_000, 100_000]
WORDS = ["grows", "stays", "shrinks"]


def test_names_parse_as_people_type_them():
    one = OneOf(FOUR)
    typed = {"Euler": "euler", "RK4": "rk4", " semi-implicit": "semi_implicit", "Semi Implicit": "semi_implicit",
             "RK-4": "rk4", "explicit Euler": "euler", "forward euler": "euler", "symplectic Euler": "semi_implicit",
             "semi-implicit Euler": "semi_implicit", "Implicit Euler": "implicit", "backward Euler": "implicit",
             "Runge-Kutta 4": "rk4"}
    assert {text: one.parse(text) for text in typed} == typed
    assert OneOf(["grows", "stays"]).forms == "one of grows, stays (any case)"  # no '_' to stand in for
    with pytest.raises(ValueError, match="'backward euler' is not one of euler, semi_implicit, rk4"):
        OneOf(NAMES).parse("backward euler")  # a real name, but not among this question's answers


def test_numbers_parse_as_people_type_them():
    orbits = Number(ORBITS)
    assert {orbits.parse(t) for t in ("10000", "10,000", "10_000", "10 000", "1e4", "1E4", "10000.0",
                                      "10k", "10K", " 10 k ")} == {10_000}
    assert orbits.parse("1k") == 1_000 and orbits.parse("100k") == 100_000
    for bad in ("ten", "1e400", "1.5", "12", "k", "1.5k", ""):
        with pytest.raises(ValueError, match="written 10000, 10,000, 10_000, 1e4 or 10k"):
            orbits.parse(bad)
    with_unit = Number([10, 100, 1_000], unit="orbit")
    assert with_unit.parse("1000 orbits") == with_unit.parse("10 Orbit") * 100 == with_unit.parse("1k orbits")
    for bad in ("orbits", "1000 apples"):
        with pytest.raises(ValueError, match="with or without 'orbits'"):
            with_unit.parse(bad)


@pytest.mark.parametrize("typed", ["1.000", "10.000", "100.000"])
def test_a_number_with_a_dot_for_thousands_says_it_reads_two_ways(typed):
    with pytest.raises(ValueError, match=f"'{typed}' could be read two ways: write it without the dot"):
        Number(ORBITS).parse(typed)
    with pytest.raises(ValueError, match=f"in 'euler={typed}', '{typed}' could be read two ways"):
        PerName(NAMES, FACTORS).parse(f"euler={typed}, semi_implicit=1, rk4=1")


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


@pytest.mark.parametrize("typed, message", [
    ("euler=, semi_implicit=4, rk4=16", "in 'euler=', nothing after the '=': put one of 1, 2, 4, 8, 16, 32 there"),
    ("euler=?, semi_implicit=?, rk4=?", r"in 'euler=\?', put your value where the \? is: one of 1, 2, 4"),
    ("euler=A, semi_implicit=B, rk4=C", "in 'euler=A', put your value where the A is: one of 1, 2, 4"),
    ("euler=3, semi_implicit=2, rk4=16", "in 'euler=3', 3 is not one of 1, 2, 4, 8, 16, 32"),
    ("euler=2", "no value for semi_implicit, rk4: expected name=value for each of euler, semi_implicit, rk4"),
    ("euler 2, semi_implicit=2, rk4=16", "'euler 2' has no '=': expected name=value"),
    ("euler=2, euler=2, rk4=16", "euler is given twice"),
    ("verlet=2, semi_implicit=2, rk4=16", "in 'verlet=2', 'verlet' is not one of euler, semi_implicit, rk4"),
    ("euler=2, semi_implicit=2, rk4=16, 4", "in 'rk4=16, 4', one value per name"),
    ("=2", "'=2' has no name before its '='"),
    ("", "the answer is empty: expected name=value"),
])
def test_a_per_name_answer_that_does_not_read_says_where(typed, message):
    with pytest.raises(ValueError, match=message):
        PerName(NAMES, FACTORS).parse(typed)


def test_the_per_name_forms_show_the_template():
    assert "(like euler=A, semi_implicit=B, rk4=C, with your value for each letter)" in PerName(NAMES, FACTORS).forms
    words = PerName(NAMES, WORDS).forms
    assert words.startswith("name=word for each of euler, semi_implicit, rk4")
    assert "each word one of grows, stays, shrinks" in words


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


def test_some_of_refuses_in_words_that_name_the_problem():
    some = SomeOf(FOUR, "the ones that stay bounded", "an integrator")
    with pytest.raises(ValueError, match="'none' goes alone: answer with the ones that stay bounded, from euler"):
        some.parse("none, rk4")
    with pytest.raises(ValueError, match="'verlet' is not an integrator here: answer with the ones that stay"):
        some.parse("rk4, verlet")
    with pytest.raises(ValueError, match="the answer is empty"):
        some.parse(" , ")


MEGABYTE = 1_000_000


@pytest.mark.parametrize("answers, typed", [
    (Number(ORBITS, unit="orbit"), " " * MEGABYTE + "x"), (PerName(NAMES, FACTORS), "a" + " " * MEGABYTE + "b"),
    (PerName(NAMES, WORDS), "a" + " " * MEGABYTE + "b"), (OneOf(NAMES), "a" + " " * MEGABYTE + "b"),
    (SomeOf(FOUR), "a" + " " * MEGABYTE + "b"), (PerName(NAMES, FACTORS), "euler=" + " " * MEGABYTE + "2"),
    (PerName(NAMES, WORDS), "=" * MEGABYTE), (PerName(NAMES, FACTORS), "euler=2 " * (MEGABYTE // 8)),
    (Number(ORBITS), "1" + ",000" * (MEGABYTE // 4)), (Number(ORBITS), "1" + ".000" * (MEGABYTE // 4)),
    (SomeOf(FOUR), "semi " * (MEGABYTE // 5)),
])
def test_a_megabyte_answer_is_refused_in_one_short_line(answers, typed):
    """Every parser is linear in its input: the regular expressions that took 10-20 s on 40,000 spaces are gone,
    and a quadratic parse of a megabyte would take hours (no clock is read: such a run would not end)."""
    with pytest.raises(ValueError) as refused:
        answers.parse(typed)
    assert len(str(refused.value)) < 400 and "\n" not in str(refused.value), "quotes a little of it, not all"


def exercise(module, *args):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", f"exercises.{module}", *args], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("argv, refusal", [
    (["a" + " " * 130_000 + "b"], "'a b' has no '='"),  # one argument stays under Linux's 128 KiB
    (["euler=2,", "semi_implicit=3,", "rk4=16"], "in 'semi_implicit=3', 3 is not one of 1, 2, 4, 8, 16, 32"),
    (["euler=2", "--predict", "semi_implicit=3,rk4=16"], "in 'semi_implicit=3', 3 is not one of")])
def test_the_shell_passes_a_prediction_in_many_words_and_the_exercise_reads_them_as_one(argv, refusal):
    """A long one, one the shell split at its spaces, and --predict given twice (both count, not the last)."""
    result = exercise("ex3_halve_dt", "--predict", *argv)
    assert result.returncode == 2 and result.stdout == "" and len(result.stderr.splitlines()) == 1
    assert refusal in result.stderr and len(result.stderr) < 600


def test_ask_reads_a_megabyte_in_many_words_at_once(capsys):
    parser = argparse.ArgumentParser(prog="exercises.exN")
    with pytest.raises(SystemExit) as exited:
        ask(parser, "Which?", PerName(NAMES, FACTORS), ["--predict", *["a" + " " * 1000] * 1000, "b"])
    assert exited.value.code == 2
    assert len(capsys.readouterr().err.splitlines()) == 1


RAW = re.compile("[\x00-\x08\x0b-\x1f\x7f\u202a-\u202e\u2066-\u2069]")  # what a terminal would obey


@pytest.mark.parametrize("module, typed", [
    ("ex1_band", "euler=\x1b[31mgrows,semi_implicit=stays,rk4=grows"), ("ex3_halve_dt", "rk4=\u202e1"),
    ("ex5_phase_blob", "euler=grows,semi_implicit=st\x1b]0;x\x07ays,rk4=grows"), ("ex5_phase_blob", "\u202eeuler=x"),
])
def test_a_prediction_holding_escape_sequences_or_bidi_overrides_comes_back_escaped(module, typed):
    """Before, exercises 1, 3 and 5 echoed the value of a per-name answer raw: the terminal obeyed it."""
    result = exercise(module, "--predict", typed)
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1
    assert not RAW.search(result.stderr) and ("\\x1b" in result.stderr or "\\u202e" in result.stderr)


def test_an_unquoted_value_in_a_refusal_is_escaped_too():
    with pytest.raises(ValueError) as refused:
        PerName(NAMES, WORDS).parse("euler=gr\x1bows")
    assert "gr\\x1bows is not one of" in str(refused.value)
