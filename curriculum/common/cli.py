"""Command-line plumbing every chapter script shares, so the chapter files keep only their own flags.

    from curriculum.common.cli import OneLineParser, positive_finite, int_in, name_arg, progress_printer

Bad input gets one line naming the problem and exit code 2, never a usage block or a traceback.
"""

import argparse
import decimal
import difflib
import math
import sys


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line: `prog: error: what is wrong (see --help)`.

    A mistyped flag is named with the flag it most looks like: `--sytem orbit` gets "did you mean --system?".
    """

    def error(self, message):
        hint = ""
        if message.startswith("unrecognized arguments: "):
            typed = [word.split("=")[0] for word in message.split()[2:] if word.startswith("--")]
            known = [flag for flag in self._option_string_actions if flag.startswith("--")]
            guesses = [match for word in typed for match in difflib.get_close_matches(word, known, n=1, cutoff=0.75)]
            hint = f"; did you mean {' and '.join(guesses)}?" if guesses else ""
        self.exit(2, f"{self.prog}: error: {message}{hint} (see --help)\n")


def name_arg(text: str) -> str:
    """Argument type for a choice of names: 'RK4', 'Semi-Implicit' and ' orbit ' read as rk4, semi_implicit, orbit."""
    return text.strip().lower().replace("-", "_")


def positive_finite(what: str):
    """Argument type: a float that is finite and > 0, e.g. a timestep."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not (math.isfinite(value) and value > 0.0):
            raise argparse.ArgumentTypeError(f"{what} must be a positive, finite number, got {text}")
        return value

    return parse


def int_in(low: int, high: int | None, what: str):
    """Argument type: a whole number from `low` to `high` (no upper bound if high is None).

    Written as people write them: `1000000`, `1,000,000`, `1_000_000`, `1e6`, `2.5e3`.
    """

    def parse(text: str) -> int:
        value = whole_number(text)
        if value is None:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if value < low or (high is not None and value > high):
            bound = f"from {low:,} to {high:,}" if high is not None else f"{low:,} or more"
            got = f"{value:,}" if len(str(abs(value))) <= 24 else text.strip()  # 1e999999 as typed
            raise argparse.ArgumentTypeError(f"{what} must be {bound}, got {got}")
        return value

    return parse


def progress_printer(label: str, total: int, stream=None):
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
        text = f"  {label:<14}{percent:>4}% of {total:,} steps"
        if in_place:
            print("\r" + text, end="\n" if done >= total else "", file=stream, flush=True)
        else:
            print(text, file=stream, flush=True)

    return show


def whole_number(text: str) -> int | None:
    """The whole number `text` spells (`10,000`, `10_000`, `1e4`, `2.5e3`), or None if it spells none."""
    plain = text.replace("_", "").replace(",", "").strip()
    try:
        return int(plain)
    except ValueError:
        pass
    try:
        number = decimal.Decimal(plain)
    except decimal.InvalidOperation:
        return None
    if not number.is_finite() or number != number.to_integral_value() or number.adjusted() > 4300:
        return None  # past 4,300 digits Python will not make it an int (and no flag wants one)
    return int(number)
