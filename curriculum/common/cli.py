"""Command-line plumbing every chapter script shares: bad input is one line naming the problem and exit 2, and what
the user typed comes back through shown(): escaped, so a terminal never obeys it, and cut where it is long."""

import argparse
import decimal
import difflib
import math
import os
import re
import sys

# control characters, bidi overrides, and the stand-ins for bytes that are not text in the file system's encoding
UNSHOWN = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069\ud800-\udfff]")


def shown(text, most: int | None = 40) -> str:
    """User text as a message quotes it: what UNSHOWN matches escaped (\\x1b, \\n, \\u202e), and past `most`
    characters the start and the end around '...', so a 5,000-character name is one short line."""
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


def name_arg(text: str) -> str:
    """Argument type for a choice of names: 'RK4', 'Semi-Implicit' and ' orbit ' read as rk4, semi_implicit, orbit."""
    return text.strip().lower().replace("-", "_")


def positive_finite(what: str, high: float | None = None):
    """Argument type: a float that is finite and > 0 (and at most `high`, if given), e.g. a timestep."""

    def parse(text: str) -> float:
        typed = shown(text.strip())
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{typed!r} is not a number") from None
        if not (math.isfinite(value) and value > 0.0):
            raise argparse.ArgumentTypeError(f"{what} must be a positive, finite number, got {typed}")
        if high is not None and value > high:
            raise argparse.ArgumentTypeError(f"{what} must be a positive number up to {high:g}, got {typed}")
        return value

    return parse


def int_in(low: int, high: int, what: str):
    """Argument type: a whole number from `low` to `high`, written as people write them: 1000000, 1,000,000,
    1_000_000, 1e6, 2.5e3. Read as a Decimal, so a number of any size is compared with the bounds before it becomes
    an int (Python turns no more than 4,300 digits of text into one)."""

    def parse(text: str) -> int:
        typed = shown(text.strip())
        try:
            value = decimal.Decimal(text.replace("_", "").replace(",", "").strip())
        except (decimal.InvalidOperation, ValueError):
            value = None
        if value is None or not value.is_finite() or value != value.to_integral_value(rounding=decimal.ROUND_DOWN):
            raise argparse.ArgumentTypeError(f"{typed!r} is not a whole number") from None
        if not low <= value <= high:
            got = f"{int(value):,}" if value.adjusted() < 24 else typed  # 1e999999 as typed
            raise argparse.ArgumentTypeError(f"{what} must be from {low:,} to {high:,}, got {got}")
        return int(value)

    return parse


def recording_wanted(prog: str, asked: bool) -> bool:
    """Whether to make the recording asked for: not under Rerun's own switch RERUN=off (or 0, false, no), said once."""
    switched_off = os.environ.get("RERUN", "").strip().lower() in ("0", "false", "off", "no")
    if asked and switched_off:
        print(f"{prog}: note: RERUN={os.environ['RERUN']} is set, so no recording is made (as with --no-rerun)",
              file=sys.stderr)
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
        print("\r" + text if in_place else text, end="" if in_place and done < total else "\n", file=stream, flush=True)

    return show
