"""Predict-then-run, shared by every predict-then-run exercise: no figure before a committed answer.

    prediction = ask(parser, "The question, ending in a question mark?", OneOf(["a", "b"]), argv)
    ...measure, printing nothing before this point...
    verdict(answer, f"it is {answer}")   # "Right: it is a." / "Not quite: you said b, but it is a."
    explain("The lesson, naming the one figure that matters.", more=lambda: ["- the full story ...", ...])

`ask` adds --predict, --because and --more; it records the prediction in the journal before it returns. The
answers (`OneOf`, `Number`, `PerName`, `SomeOf`) are read as people type them, in time linear in the text; one
that does not parse gets one line listing the accepted forms (`.forms`). The lesson is at most 120 words
(tests/test_docs.py counts). Keep measured answers out of the docstring, --help and the question:
tests/test_docs.py reads them for leaks.
"""

import argparse
import atexit
import contextlib
import re
import sys
import textwrap
from pathlib import Path

from curriculum.common import interrupts, journal
from curriculum.common.cli import shown
from curriculum.common.exercise import EXERCISE_FILE

# What people call the integrators and the answers, compared without case, spaces, '_' or '-' (_name_key).
ALIASES = {"expliciteuler": "euler", "forwardeuler": "euler",
           "symplecticeuler": "semiimplicit", "semiimpliciteuler": "semiimplicit", "symplectic": "semiimplicit",
           "impliciteuler": "implicit", "backwardeuler": "implicit",
           "rungekutta": "rk4", "rungekutta4": "rk4", "classicalrungekutta": "rk4",
           "grow": "grows", "stay": "stays", "shrink": "shrinks",
           "band": "stays", "inaband": "stays", "staysinaband": "stays", "stayinaband": "stays", "bounded": "stays",
           "growswiththerun": "grows", "growwiththerun": "grows", "unbounded": "grows"}
LONGEST_NAME = 4  # words: "classical runge kutta 4"
SPELLED = {2: "two", 3: "three", 4: "four", 5: "five"}  # 'all four'
NUMBER = re.compile(r"(\d{1,9})(?:\.0)?(?:e(\d{1,2}))?(k?)")  # 10000, 10000.0, 1e4, 10k; not 1.000 (two readings)


class OneOf:
    """One name from a fixed list: 'Euler', 'semi-implicit', ' RK4 ', 'RK-4', 'backward Euler' all parse."""

    def __init__(self, names):
        self.names = list(names)
        spelling = "; '-' or a space may stand for '_'" if any("_" in name for name in self.names) else ""
        self.forms = f"one of {', '.join(self.names)} (any case{spelling})"

    def find(self, text: str):  # the name `text` means, or None
        key = ALIASES.get(_name_key(text), _name_key(text))
        return next((name for name in self.names if _name_key(name) == key), None)

    def parse(self, text: str):
        found = self.find(text)
        if found is None:
            raise ValueError(f"{_shown(text)} is not {self.forms}")
        return found


class Number(OneOf):
    """One number from a fixed list: 10000, 10,000, 10_000, 10 000, 1e4 and 10k are the same."""

    def __init__(self, choices, unit: str = ""):
        self.names, self.unit = list(choices), unit
        with_unit = f", with or without '{unit}s'" if unit else ""
        self.forms = (f"one of {', '.join(f'{c:,}' for c in self.names)}"
                      f" (written 10000, 10,000, 10_000, 1e4 or 10k{with_unit})")

    def find(self, text: str) -> int | None:
        words = text.lower().split()
        if self.unit and len(words) > 1 and words[-1] in (self.unit, f"{self.unit}s"):
            words = words[:-1]  # '1000 orbits' is 1000 orbits
        found = NUMBER.fullmatch("".join(words).replace(",", "").replace("_", ""))
        value = found and int(found[1]) * 10 ** int(found[2] or 0) * (1000 if found[3] else 1)
        return value if value in self.names else None


class PerName:
    """One value per name: 'euler=8, semi_implicit=4, rk4=1' (any spacing, any order, ':' for '=', commas,
    semicolons or just spaces between the items). `values` are numbers, or words such as grows/stays."""

    def __init__(self, names, values):
        self.names, self.values = OneOf(names), list(values)
        self.value = OneOf(self.values) if all(isinstance(v, str) for v in self.values) else Number(self.values)
        what = "value" if isinstance(self.value, Number) else "word"
        self.choices = ", ".join(map(str, self.values))
        like = ", ".join(f"{name}={letter}" for name, letter in zip(self.names.names, "ABCDEFGH", strict=False))
        self.forms = (f"name={what} for each of {', '.join(self.names.names)}, separated by commas,"
                      f" each {what} one of {self.choices} (like {like}, with your {what} for each letter)")

    def parse(self, text: str) -> dict:
        """Split at each '=' or ':'; between two of them, a value, then (after a comma, semicolon or space) a name."""
        pieces = re.split(r"[=:]", text)  # a character class, no repetition: linear in the text
        if len(pieces) == 1:
            raise ValueError(f"{_shown(text)} has no '=': expected {self.forms}" if text.strip(" ,;\t\n") else
                             f"the answer is empty: expected {self.forms}")
        prediction, name = {}, pieces[0]
        for at, piece in enumerate(pieces[1:], 2):
            name = name.strip(" ,;\t\n")
            if "," in name or ";" in name:  # 'euler 8, rk4=1': an item with no '='
                raise ValueError(f"{_shown(re.split('[,;]', name)[0])} has no '=': expected {self.forms}")
            if at == len(pieces):  # the last value: all that is left
                value, following = piece.strip(" ,;\t\n"), ""
            else:  # the value ends at the first comma or semicolon, or else at the first space: 'grows, rk4'
                value, following = re.split(r"[,;]", piece, maxsplit=1) if re.search(r"[,;]", piece) else \
                    piece.strip().partition(" ")[::2]
            value = value.strip()
            item, key = _shown(f"{name}={value}"), self.names.find(name)
            if key is None:
                raise ValueError(f"in {item}, {_shown(name)} is not one of {', '.join(self.names.names)}")
            if key in prediction:
                raise ValueError(f"{key} is given twice")
            prediction[key], name = self.read(item, value), following
        missing = [name for name in self.names.names if name not in prediction]
        if missing:
            raise ValueError(f"no value for {', '.join(missing)}: expected {self.forms}")
        return {name: prediction[name] for name in self.names.names}

    def read(self, item: str, text: str):
        if not text:
            raise ValueError(f"in {item}, nothing after the '=': put one of {self.choices} there")
        if text == "?":  # the README's template, typed as shown
            raise ValueError(f"in {item}, put your value where the ? is: one of {self.choices}")
        value = self.value.find(text)
        if value is None:
            raise ValueError(f"in {item}, {_shown(text, quoted=False)} is not one of {self.choices}")
        return value


class SomeOf:
    """Any number of names from a list, or none, or all: 'rk4, implicit', 'RK4 and implicit Euler',
    'semi-implicit Euler rk4', 'none', 'all of them'. `chosen` says which ones the answer lists."""

    def __init__(self, names, chosen: str = "the ones you pick", kind: str = "one of the names"):
        self.names, self.kind = OneOf(names), kind
        self.forms = f"{chosen}, from {', '.join(self.names.names)}, separated by commas (or 'none', or 'all')"

    def parse(self, text: str) -> frozenset:
        words = [word for word in re.split(r"[\s,;+]+", text.lower()) if word not in ("", "and")]  # one pass
        count = len(self.names.names)  # 'none', 'none of them', 'all', 'all of them', 'all four', 'all 4'
        if words[:1] in (["none"], ["all"]) and words[1:] in ([], ["of", "them"], [str(count)], [SPELLED.get(count)]):
            return frozenset(self.names.names if words[0] == "all" else ())
        if not words:
            raise ValueError(f"the answer is empty: answer with {self.forms}")
        chosen, at = [], 0
        while at < len(words):  # the longest run of words that is one name: "semi implicit euler" before "semi"
            length = next((n for n in range(min(LONGEST_NAME, len(words) - at), 0, -1)
                           if self.names.find(" ".join(words[at:at + n]))), 0)
            if not length:
                word = words[at]
                raise ValueError(f"'{word}' goes alone: answer with {self.forms}" if word in ("none", "all") else
                                 f"{_shown(word)} is not {self.kind} here: answer with {self.forms}")
            chosen.append(self.names.find(" ".join(words[at:at + length])))
            at += length
        return frozenset(chosen)


def ask(parser: argparse.ArgumentParser, question: str, answers, argv=None, variant=None, check=None):
    """The parsed prediction, recorded first; without --predict, the question (or what was committed) and exit 0.

    `answers` has .parse(text) and .forms; the exercise's own arguments end up in `parser.parsed`. `variant` names
    the one whose every value is a question of its own (exercise 3's "system"); `check(args)` says why the other
    arguments cannot be used, or None, before anything is recorded."""
    # nargs="+": `--predict euler=8, rk4=1` reaches us as several words; they are one answer
    parser.add_argument("--predict", metavar="ANSWER", nargs="+", action="extend",  # given twice: both count
                        help=f"your prediction: {answers.forms}")
    parser.add_argument("--because", metavar="REASON", nargs="+", action="extend",
                        help="why you predict that, in your words: recorded with your prediction")
    parser.add_argument("--more", action="store_true",
                        help="after the measurement, the full explanation (with any further table) instead of"
                             " the short lesson alone")
    args = parser.parse_args(argv)
    parser.parsed = args
    _asked.update(question=question, answers=answers, more=args.more)  # what was asked, for explain() and the tests
    number = int(EXERCISE_FILE.fullmatch(f"{parser.prog.rpartition('.')[2]}.py")[1])  # exercises.ex3_halve_dt: 3
    value = getattr(args, variant) if variant else None
    asked = f"{variant}={value}" if variant and value != parser.get_default(variant) else ""  # "": the default
    if args.predict is None:
        for flag in ("because", "more"):
            if getattr(args, flag):
                parser.exit(2, f"{parser.prog}: error: --{flag} goes with --predict: commit to a prediction too\n")
        show_question(how_it_was_run(parser.prog) + (f" --{variant} {value}" if asked else ""), question, answers,
                      number, asked)
        sys.exit(0)
    try:
        prediction = answers.parse(" ".join(args.predict))
    except ValueError as problem:
        parser.exit(2, f"{parser.prog}: error: --predict: {problem}\n")
    if check and (problem := check(args)):
        parser.exit(2, f"{parser.prog}: error: {problem}\n")
    _asked.update(prediction=prediction, said=said(prediction, answers), number=number,
                  **record(number, asked, prediction, args))
    if interrupts.active():  # the exercise being run, not a test's main(): its last line
        atexit.register(_say_next, number)
    return prediction


_asked = {}  # what ask() asked, returned and recorded, for verdict(), explain() and tests/test_docs.py


def tries(book, number: int, asked: str) -> list:
    """The predictions of exercise `number`'s question `asked` since its last reset, the first first."""
    return [r for r in book.of(number) if r["kind"] == "predict" and r["question"] == asked]


def show_question(run: str, question: str, answers, number: int, asked: str) -> None:
    """A bare run: the question, then how to commit; or, once committed, what and when (no figure either way)."""
    print(question)
    tried = tries(journal.load(), number, asked)
    if not tried:
        print(f"Answer with {answers.forms}.")
        print(f"\nCommit to a prediction first, then run:  {run} --predict ANSWER [--because \"your reason\"]")
        return
    first = tried[0]
    attempts = f" ({len(tried)} attempts: the first counts)" if len(tried) > 1 else ""
    reason = f", because {first['because']}" if first["because"] else ""
    print(f"You committed {first['typed']} on {journal.when(first['t'])}{reason}{attempts}.")
    print(f"\nTo see the measurement again:  {run} --predict ANSWER (the same answer is a replay, not an attempt)")


def said(prediction, answers) -> str:
    """A prediction as the student would say it: 'euler=grows, rk4=stays', 'rk4, implicit', 'none', '10,000'."""
    if isinstance(prediction, dict):
        return ", ".join(f"{name}={value}" for name, value in prediction.items())
    if isinstance(prediction, frozenset):
        return ", ".join(name for name in answers.names.names if name in prediction) or "none"
    return f"{prediction:,}" if isinstance(prediction, int) else str(prediction)


def record(number: int, asked: str, prediction, args) -> dict:
    """The prediction in the journal before any figure, or a replay of the same answer: {id, note for verdict()}."""
    answer, tried = sorted(prediction) if isinstance(prediction, frozenset) else prediction, []

    def make(book):
        tried.extend(tries(book, number, asked))
        same = next((r for r in tried if r["answer"] == answer), None)
        if same:
            return {"kind": "replay", "ex": number, "question": asked, "prediction": same["chain"]}
        return {"kind": "predict", "ex": number, "question": asked, "answer": answer,
                "typed": " ".join(args.predict)[:200], "because": " ".join(args.because or [])[:1000],
                "attempt": len(tried) + 1}

    kept = f"your prediction is recorded in {journal.shown(journal.where() or Path())}"
    written = journal.append(make, kept)
    if written is None:
        if journal.where() is None and sys.stderr.isatty():  # to the student, as progress is
            print(f"note: recording is off ({journal.SETTING}=off): this prediction is not recorded", file=sys.stderr)
        return {"id": None, "note": ""}
    if written["kind"] == "replay":
        same = next(r for r in tried if r["chain"] == written["prediction"])
        return {"id": same["chain"], "note": f"The same answer as your attempt {same['attempt']}"
                f" ({journal.when(same['t'])}): a replay, not a new attempt."}
    note = f"This was attempt {written['attempt']}: your first prediction, {journal.when(tried[0]['t'])}, is the" \
           " one that counts." if tried else ""
    return {"id": written["chain"], "note": note}


def _say_next(number: int) -> None:
    if interrupts.exit_code() == 0:
        with contextlib.suppress(OSError, ValueError):  # stdout closed: the guard says so, once
            print(journal.next_line(number), flush=True)  # the board's: the first exercise not done


def how_it_was_run(module: str) -> str:
    """`python -m exercises.ex1_band`, or `python ex1_band.py` if the student ran the file itself."""
    main = sys.modules.get("__main__")
    if getattr(main, "__spec__", None) is None and Path(sys.argv[0]).stem == module.rpartition(".")[2]:
        return f"python {sys.argv[0]}"
    return f"python -m {module}"


def verdict(truth, answer: str | None = None) -> None:
    """'Right: it is euler.' or 'Not quite: you said rk4, but it is euler.', and the marks in the journal. `truth`
    has the prediction's form; `answer` says it in words (by default 'euler grows, rk4 stays')."""
    prediction = _asked["prediction"]
    answer = answer or ", ".join(f"{name} {value}" for name, value in truth.items())
    print(f"Right: {answer}." if prediction == truth else f"Not quite: you said {_asked['said']}, but {answer}.")
    items = [prediction[name] == truth[name] for name in truth] if isinstance(truth, dict) else [prediction == truth]
    if _asked["id"]:
        journal.append(lambda book: None if any(r["kind"] == "marks" and r["prediction"] == _asked["id"]
                                                for r in book.records) else
                       {"kind": "marks", "ex": _asked["number"], "prediction": _asked["id"],
                        "right": sum(items), "items": len(items)})
    if _asked["note"]:
        print(_asked["note"])


MORE = "The same command with --more explains every figure."


def explain(*lines: str, more=None, width: int = 100) -> None:
    """Print the lines wrapped ('- ' a bullet, four spaces code, as it is). With `more`, they are the lesson:
    under --more, more()'s lines follow (measured only then); without, MORE says they exist."""
    for line in lines:
        indent = "  " if line.startswith("- ") else ""
        wrapped = textwrap.fill(line, width=width, subsequent_indent=indent, break_on_hyphens=False)  # semi-implicit
        print(line if line.startswith("    ") else wrapped)
    if more is not None and _asked.get("more"):
        print()
        explain(*more(), width=width)
    elif more is not None:
        print(MORE)


def _name_key(text: str) -> str:
    """How a name is compared: any case, with spaces, '_' and '-' left out ('RK-4' is rk4)."""
    return "".join(ch for ch in text.lower() if not (ch.isspace() or ch in "_-"))


def _shown(text: str, limit: int = 40, quoted: bool = True) -> str:
    """How a refusal quotes what was typed: spaces run together, and at most `limit` characters of it."""
    text = " ".join(text.split())
    text = text if len(text) <= limit else f"{text[:limit - 3]}..."
    return repr(text) if quoted else shown(text, None)  # repr escapes; unquoted, shown() does
