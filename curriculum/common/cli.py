"""Command-line plumbing every chapter script shares: bad input is one line naming the problem and exit 2.

    from curriculum.common.cli import OneLineParser, positive_finite, int_in, name_arg, progress_printer, shown

What the user typed comes back through shown(): escaped, so a terminal never obeys it, and cut where it is long.
"""

import argparse
import decimal
import difflib
import math
import os
import re
import sys

UNSHOWN = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")  # controls, bidi


def shown(text, most: int | None = 40) -> str:
    """User text as a message quotes it: control characters and bidi overrides escaped (\\x1b, \\n, \\u202e), and
    past `most` characters the start and the end around '...', so a 5,000-character name is one short line."""
    text = str(text)
    if most and len(text) > most:
        text = f"{text[:most - most // 3 - 3]}...{text[-(most // 3):]}"
    return UNSHOWN.sub(lambda match: match.group().encode("unicode_escape").decode(), text)


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line: `prog: error: what is wrong (see --help)`. A mistyped flag is
    named with the flag it most looks like; a value like `-inf` or `-1e3` reaches the flag's type."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-(\d|\.\d|inf|nan)", re.IGNORECASE)

    def error(self, message):
        hint = ""
        if message.startswith("unrecognized arguments: "):
            typed = [word.split("=")[0] for word in message.split()[2:] if word.startswith("--")]
            known = [flag for flag in self._option_string_actions if flag.startswith("--")]
            guesses = [match for word in typed for match in difflib.get_close_matches(word, known, n=1, cutoff=0.75)]
            hint = f"; did you mean {' and '.join(guesses)}?" if guesses else ""
            message = f"unrecognized arguments: {shown(message[24:])}"
        self.exit(2, f"{self.prog}: error: {shown(message, None)}{hint} (see --help)\n")

    def _check_value(self, action, value):
        if action.choices is not None and value not in action.choices:  # quoted short, whatever its length
            raise argparse.ArgumentError(action, f"invalid choice: '{shown(value)}' (choose from"
                                                 f" {', '.join(map(repr, action.choices))})")


def name_arg(text: str) -> str:
    """Argument type for a choice of names: 'RK4', 'Semi-Implicit' and ' orbit ' read as rk4, semi_implicit, orbit."""
    return text.strip().lower().replace("-", "_")


def positive_finite(what: str, high: float | None = None):
    """Argument type: a float that is finite and > 0 (and at most `high`, if given), e.g. a timestep."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{as_typed(text)!r} is not a number") from None
        if not (math.isfinite(value) and value > 0.0):
            raise argparse.ArgumentTypeError(f"{what} must be a positive, finite number, got {as_typed(text)}")
        if high is not None and value > high:
            raise argparse.ArgumentTypeError(f"{what} must be a positive number up to {high:g}, got {as_typed(text)}")
        return value

    return parse


def int_in(low: int, high: int | None, what: str):
    """Argument type: a whole number from `low` to `high` (no bound if None: up to 4,300 digits, the most Python
    turns into text), written as people write them: 1000000, 1,000,000, 1_000_000, 1e6, 2.5e3. Read as a Decimal,
    so a number of any size is compared with the bounds before it becomes an int."""

    def parse(text: str) -> int:
        try:
            value = decimal.Decimal(text.replace("_", "").replace(",", "").strip())
        except (decimal.InvalidOperation, ValueError):
            value = None
        if value is None or not value.is_finite() or value != value.to_integral_value(rounding=decimal.ROUND_DOWN):
            raise argparse.ArgumentTypeError(f"{as_typed(text)!r} is not a whole number") from None
        if value < low or value > (high if high is not None else 10**4300 - 1):
            got = f"{int(value):,}" if value.adjusted() < 24 else as_typed(text)  # 1e999999 as typed
            bound = f"from {low:,} to {high:,}" if high is not None else f"{low:,} or more, with at most 4,300 digits"
            raise argparse.ArgumentTypeError(f"{what} must be {bound}, got {got}")
        return int(value)

    return parse


def as_typed(text: str, most: int = 40) -> str:
    """`text` as the user typed it, cut to `most` characters with its length said."""
    text = text.strip()
    return shown(text if len(text) <= most else f"{text[:most - 10]}... ({len(text):,} characters)", None)


def rerun_switched_off() -> str | None:
    """'RERUN=off' if Rerun's own environment switch (0, false, off, no; any case) turns its logging off."""
    value = os.environ.get("RERUN")
    return f"RERUN={value}" if value is not None and value.strip().lower() in ("0", "false", "off", "no") else None


def recording_wanted(prog: str, asked: bool) -> bool:
    """Whether to make the recording a run asked for: not under RERUN=off, which is said in one line on stderr."""
    switched_off = rerun_switched_off()
    if asked and switched_off:
        print(f"{prog}: note: {switched_off} is set, so no recording is made (as with --no-rerun)", file=sys.stderr)
    return asked and not switched_off


def progress_printer(label: str, total: int, stream=None, unit: str = "steps"):
    """A callback progress(done) that prints `  label  45% of 1,000,000 steps` every 5% at most: redrawn in place
    on a terminal, one line per report in a log. The last report ends the line."""
    stream = stream or sys.stderr
    in_place, last = stream.isatty(), [-1.0]

    def show(done: int) -> None:
        if done < total and done / total < last[0] + 0.05:
            return
        last[0] = done / total
        text = f"  {label:<14}{100 * done // total:>4}% of {total:,} {unit}"  # rounded down: 100% only at the end
        if in_place:
            print("\r" + text, end="\n" if done >= total else "", file=stream, flush=True)
        else:
            print(text, file=stream, flush=True)

    return show
