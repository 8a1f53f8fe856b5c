"""Command-line plumbing every chapter script shares, so the chapter files keep only their own flags.

    from curriculum.common.cli import OneLineParser, positive_finite, int_in, progress_printer

Bad input gets one line naming the problem and exit code 2, never a usage block or a traceback.
"""

import argparse
import math
import sys


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line: `prog: error: what is wrong (see --help)`."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


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
    """Argument type: a whole number from `low` to `high` (no upper bound if high is None)."""

    def parse(text: str) -> int:
        try:
            value = int(text.replace("_", "").replace(",", ""))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if value < low or (high is not None and value > high):
            bound = f"from {low:,} to {high:,}" if high is not None else f"{low:,} or more"
            raise argparse.ArgumentTypeError(f"{what} must be {bound}, got {value:,}")
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
