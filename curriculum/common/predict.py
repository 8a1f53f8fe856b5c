"""Predict-then-run, shared by every predict-then-run exercise: no figure before a committed answer.

How an exercise uses it (ex4_long_run.py is a short example):

    parser = OneLineParser(prog="exercises.ex5_something", description=__doc__, ...)  # curriculum.common.cli
    prediction = ask(parser, "The question, ending in a question mark?", OneOf(["a", "b"]), argv)
    ...measure, with no output before this line...
    verdict(prediction == answer, f"it is {answer}", prediction)   # "Right: it is a." / "Not quite: ..."
    explain("- first thing the numbers show ...", "- second ...")

- `ask` adds `--predict` to the parser. Run bare, the exercise prints the question, the accepted
  answers and how to commit (four lines, no figure) and exits 0: asking is not an error. A
  prediction that does not parse gets one line on stderr that lists the accepted forms, and exit 2.
  Otherwise it returns the parsed prediction.
- The answer forms read predictions the way people type them: `OneOf` (names, any case, '-' or ' '
  for '_'), `Number` (`10000`, `10,000`, `10_000`, `1e4`) and `PerName` (`euler=8, rk4=1`, any
  spacing, any order). Each has `.forms`, the sentence a refusal prints.
- `verdict` and `explain` are the one place that prints the grade and the explanation, after the
  measurement. Keep measured answers out of the module docstring, --help and the question:
  tests/test_docs.py reads them for leaks.
"""

import argparse
import math
import re
import sys
import textwrap
from pathlib import Path


class OneOf:
    """One name from a fixed list: 'Euler', 'semi-implicit', ' RK4 ', 'RK-4' all parse."""

    def __init__(self, names):
        self.names = list(names)
        spelling = "; '-' or a space may stand for '_'" if any("_" in name for name in self.names) else ""
        self.forms = f"one of {', '.join(self.names)} (any case{spelling})"

    def parse(self, text: str) -> str:
        key = _name_key(text)
        key = ALIASES.get(key, key)
        for name in self.names:
            if _name_key(name) == key:
                return name
        raise ValueError(f"{text.strip()!r} is not {self.forms}")


# What people call the integrators and the answers, as the tables and the chapter write them.
ALIASES = {"expliciteuler": "euler", "forwardeuler": "euler", "symplecticeuler": "semiimplicit",
           "semiimpliciteuler": "semiimplicit", "grow": "grows", "stay": "stays", "shrink": "shrinks"}


class Number:
    """One number from a fixed list of choices: 10000, 10,000, 10_000, 10 000 and 1e4 are the same."""

    def __init__(self, choices, unit: str = ""):
        self.choices, self.unit = list(choices), unit
        with_unit = f", with or without '{unit}s'" if unit else ""
        self.forms = (f"one of {', '.join(f'{c:,}' for c in self.choices)}"
                      f" (written 10000, 10,000, 10_000 or 1e4{with_unit})")

    def parse(self, text: str) -> int:
        if self.unit:  # '1000 orbits' is 1000 orbits
            text = re.sub(rf"\s*{re.escape(self.unit)}s?\s*$", "", text, flags=re.IGNORECASE) or text
        try:
            value = _number(text)
        except ValueError:
            value = None
        if value not in self.choices:
            raise ValueError(f"{text.strip()!r} is not {self.forms}")
        return value


class PerName:
    """One value per name: 'euler=8, semi_implicit=4, rk4=1' (any spacing, any order, ':' for '=')."""

    def __init__(self, names, values):
        self.names, self.values = list(names), list(values)
        self.forms = (f"name=value for each of {', '.join(self.names)}, separated by commas,"
                      f" each value one of {', '.join(f'{v:g}' for v in self.values)}"
                      f" ({template(self.names)})")

    def parse(self, text: str) -> dict:
        names, prediction = OneOf(self.names), {}
        # commas or semicolons between items; a space also does, where a value ends and a name begins
        for item in filter(None, (part.strip() for part in re.split(r"[,;]|(?<=\d)\s+(?=[A-Za-z])", text))):
            match = re.fullmatch(r"([^=:]*?)\s*[=:]\s*(.*)", item)
            if not match:
                raise ValueError(f"{item!r} has no '=': expected {self.forms}")
            name_text, value_text = match.groups()
            try:
                name = names.parse(name_text)
            except ValueError:
                raise ValueError(f"in {item!r}, {name_text!r} is not one of {', '.join(self.names)}") from None
            if value_text.strip() in ("?", "..."):
                raise ValueError(f"in {item!r}, put your value where the {value_text.strip()} is:"
                                 f" one of {', '.join(f'{v:g}' for v in self.values)}")
            try:
                value = _number(value_text)
            except ValueError:
                value = None
            if value not in self.values:
                raise ValueError(f"in {item!r}, {value_text.strip()} is not one of"
                                 f" {', '.join(f'{v:g}' for v in self.values)}")
            if name in prediction:
                raise ValueError(f"{name} is given twice")
            prediction[name] = value
        missing = [name for name in self.names if name not in prediction]
        if missing:
            raise ValueError(f"no value for {', '.join(missing)}: expected {self.forms}")
        return {name: prediction[name] for name in self.names}


def template(names, what: str = "value") -> str:
    """The shape of a per-name answer: 'like euler=A, semi_implicit=B, rk4=C, with your value for each letter'."""
    letters = "ABCDEFGH"[: len(names)]
    return f"like {', '.join(f'{name}={letter}' for name, letter in zip(names, letters, strict=True))}," \
           f" with your {what} for each letter"


def ask(parser: argparse.ArgumentParser, question: str, answers, argv=None):
    """Parse argv and return the parsed prediction; without --predict, ask the question and exit 0.

    `answers` is OneOf, Number or PerName (anything with .parse(text) and .forms). The extra
    arguments an exercise adds to `parser` are in `parser.parsed`, the argparse namespace.
    """
    # nargs="+": `--predict euler=8, rk4=1` reaches us as several words; they are one answer
    parser.add_argument("--predict", metavar="ANSWER", nargs="+", action="extend",  # given twice: both count
                        help=f"your prediction: {answers.forms}")
    args = parser.parse_args(argv)
    parser.parsed = args
    if args.predict is None:
        print(question)
        print(f"Answer with {answers.forms}.")
        print(f"\nCommit to a prediction first, then run:  {how_it_was_run(parser.prog)} --predict ANSWER")
        sys.exit(0)
    try:
        return answers.parse(" ".join(args.predict))
    except ValueError as problem:
        parser.exit(2, f"{parser.prog}: error: --predict: {problem}\n")


def how_it_was_run(module: str) -> str:
    """`python -m exercises.ex1_band`, or `python ex1_band.py` if the student ran the file itself."""
    script = Path(sys.argv[0]) if sys.argv and sys.argv[0] else None
    main_spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    if main_spec is None and script is not None and script.stem == module.rpartition(".")[2]:
        return f"python {sys.argv[0]}"
    return f"python -m {module}"


def verdict(right: bool, answer: str, prediction) -> None:
    """The grade, one line: 'Right: it is euler.' or 'Not quite: you said rk4, but it is euler.'"""
    said = f"{prediction:,}" if isinstance(prediction, int) else prediction
    print(f"Right: {answer}." if right else f"Not quite: you said {said}, but {answer}.")


def explain(*lines: str, width: int = 100) -> None:
    """Print the explanation, each line wrapped for a terminal; a line starting with '- ' is a bullet."""
    for line in lines:
        indent = "  " if line.startswith("- ") else ""
        print(textwrap.fill(line, width=width, subsequent_indent=indent) if line else "")


def _name_key(text: str) -> str:
    """How a name is compared: any case, with spaces, '_' and '-' left out ('RK-4' is rk4)."""
    return re.sub(r"[\s_-]+", "", text.lower())


def _number(text: str) -> int:
    """'10,000' / '10_000' / '10 000' / '1e4' / '10000.0' -> 10000; ValueError if not a whole number."""
    if re.fullmatch(r"\d{1,3}(\.\d{3})+", text.strip()):  # 10.000: ten thousand in much of Europe, ten here
        raise ValueError(f"{text.strip()!r} could be read two ways: write it without the dot")
    cleaned = re.sub(r"(?<=\d)[,_ ](?=\d{3}\b)", "", text.strip())
    try:
        value = float(cleaned)
    except ValueError:
        raise ValueError(f"{text.strip()!r} is not a number") from None
    if not math.isfinite(value) or value != int(value):
        raise ValueError(f"{text.strip()!r} is not a whole number")
    return int(value)
