"""Command-line plumbing every chapter script shares, so the chapter files keep only their own flags.

    from curriculum.common.cli import OneLineParser, positive_finite, int_in, name_arg, progress_printer, shown

Bad input gets one line naming the problem and exit code 2, never a usage block or a traceback. What the user
typed comes back through shown(): escaped, so a terminal never obeys it, and cut where it is long.
"""

import argparse
import decimal
import difflib
import math
import re
import sys


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line: `prog: error: what is wrong (see --help)`.

    A mistyped flag is named with the flag it most looks like: `--sytem orbit` gets "did you mean --system?".
    A value that starts with '-' and reads as a number (`--dt -inf`, `--dt -1e3`) reaches the flag's
    type, which says what is wrong with it, instead of argparse's "expected one argument".
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # argparse takes '-1' and '-.5' for numbers and everything else with a '-' for a flag
        self._negative_number_matcher = re.compile(r"^-(\d|\.\d|inf|nan)", re.IGNORECASE)

    def _print_message(self, message, file=None):
        """argparse drops a failed write silently: --help into a full or closed stdout then exits 0 having said
        nothing. Here that write fails aloud (one_line_failures says it in one line); an error line that
        cannot reach stderr is still dropped, since its exit code 2 says it anyway."""
        file = file or sys.stderr
        if message and file is sys.stdout:
            file.write(message)
        elif message:
            try:
                file.write(message)
            except (AttributeError, OSError):
                pass

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
        """argparse's refusal of a name that is not a choice, quoting it short: a 5,000-character name is no line."""
        if action.choices is not None and value not in action.choices:
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
    """Argument type: a whole number from `low` to `high` (no upper bound if high is None: then up to 4,300 digits,
    the most Python turns into text).

    Written as people write them: `1000000`, `1,000,000`, `1_000_000`, `1e6`, `2.5e3`. However many
    digits it has (Python refuses to make an int of more than 4,300 from text), it is compared with the
    bounds first, so `1e4300` and a 5,000-digit number are "must be from ... to ...", not a traceback.
    """

    def parse(text: str) -> int:
        value = whole_number(text)
        if value is None:
            raise argparse.ArgumentTypeError(f"{as_typed(text)!r} is not a whole number") from None
        top = high if high is not None else 10**4300 - 1
        if value < low or value > top:
            got = f"{int(value):,}" if value.adjusted() < 24 else as_typed(text)  # 1e999999 as typed
            bound = f"from {low:,} to {high:,}" if high is not None else f"{low:,} or more, with at most 4,300 digits"
            raise argparse.ArgumentTypeError(f"{what} must be {bound}, got {got}")
        return int(value)

    return parse


def as_typed(text: str, most: int = 40) -> str:
    """`text` as the user typed it, cut to `most` characters with its length said: a 5,000-digit number fits a line."""
    text = text.strip()
    return shown(text if len(text) <= most else f"{text[:most - 10]}... ({len(text):,} characters)", None)


UNSHOWN = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")  # controls, bidi


def shown(text, most: int | None = 40) -> str:
    """User text (a name, a path, a prediction) as a message quotes it: control characters and bidi overrides
    escaped (\\x1b, \\n, \\u202e), so a terminal shows them instead of obeying them; past `most` characters,
    the start and the end around '...', so a 5,000-character name is still one short line."""
    text = str(text)
    if most and len(text) > most:
        text = f"{text[:most - most // 3 - 3]}...{text[-(most // 3):]}"
    return UNSHOWN.sub(lambda match: match.group().encode("unicode_escape").decode(), text)


def rerun_switched_off() -> str | None:
    """'RERUN=off' if Rerun's own environment switch turns its logging off (then every Rerun call only
    warns and no recording can be made), else None. Rerun reads 0, false and off, in any case."""
    import os

    value = os.environ.get("RERUN")
    return f"RERUN={value}" if value is not None and value.strip().lower() in ("0", "false", "off", "no") else None


def recording_wanted(prog: str, asked: bool) -> bool:
    """Whether to make the recording a run asked for: not where RERUN=off switches Rerun off, which
    is then said in one line on stderr (as if --no-rerun had been given)."""
    switched_off = rerun_switched_off()
    if asked and switched_off:
        print(f"{prog}: note: {switched_off} is set, so no recording is made (as with --no-rerun)", file=sys.stderr)
    return asked and not switched_off


def progress_printer(label: str, total: int, stream=None, unit: str = "steps"):
    """A callback progress(done) that redraws one line, `  label  45% of 1,000,000 steps`, every 5% at most.

    On a terminal the line is redrawn in place; otherwise (a log file, a pipe) each report is its
    own line, so the log stays readable. The last report ends the line.
    """
    stream = stream or sys.stderr
    in_place = stream.isatty()
    shown = [-1.0]  # the fraction last printed: a report comes every 5% at most, and at the end

    def show(done: int) -> None:
        if done < total and done / total < shown[0] + 0.05:
            return
        shown[0] = done / total
        percent = 100 * done // total  # rounded down: 100% only when the last step is done
        text = f"  {label:<14}{percent:>4}% of {total:,} {unit}"
        if in_place:
            print("\r" + text, end="\n" if done >= total else "", file=stream, flush=True)
        else:
            print(text, file=stream, flush=True)

    return show


def whole_number(text: str) -> decimal.Decimal | None:
    """The whole number `text` spells (`10,000`, `10_000`, `1e4`, `2.5e3`) as an exact Decimal, or None.

    A Decimal, not an int, so a number of any size can be compared with a flag's bounds before it
    becomes an int (int() of a 5,000-digit text raises ValueError)."""
    plain = text.replace("_", "").replace(",", "").strip()
    try:
        number = decimal.Decimal(plain)
    except (decimal.InvalidOperation, ValueError):
        return None
    if not number.is_finite():
        return None
    if number.as_tuple().exponent < 0 and number != number.to_integral_value(rounding=decimal.ROUND_DOWN):
        return None  # 1.5, 1e-3 (while 2.5e3 and 1.0e4 are whole)
    return number
