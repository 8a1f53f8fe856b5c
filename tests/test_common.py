"""curriculum/common: the machinery every chapter script shares, tested on its own."""

import argparse
import io

import pytest

from curriculum.common.cli import OneLineParser, int_in, name_arg, progress_printer, shown
from curriculum.common.device import wall_clock


def test_a_mistyped_flag_is_named_with_the_flag_it_looks_like(capsys):
    parser = OneLineParser(prog="chapter.py")
    for flag in ("--system", "--steps", "--seed", "--out"):
        parser.add_argument(flag)
    for typed, says in [
        (["--sytem", "orbit"], "--sytem orbit; did you mean --system?"),
        (["--sytem=orbit", "--stpes", "5"], "--sytem=orbit --stpes 5; did you mean --system and --steps?"),
        (["--foo"], "--foo"),  # nothing close: no guess
    ]:
        with pytest.raises(SystemExit):
            parser.parse_args(typed)
        assert capsys.readouterr().err == f"chapter.py: error: unrecognized arguments: {says} (see --help)\n"


def test_names_are_read_in_any_case_with_hyphens_for_underscores():
    typed = ("RK4", " Semi-Implicit ", "damped-spring")
    assert [name_arg(t) for t in typed] == ["rk4", "semi_implicit", "damped_spring"]


def test_int_in_reads_numbers_as_people_write_them():
    parse = int_in(1, 10_000_000, "--steps")
    assert parse("10,000") == parse("10_000") == parse("10000") == parse("1e4") == parse(" 1.0e4 ") == 10_000
    assert parse("2.5e3") == 2_500
    for bad in ("1.5", "1.5e0", "", "ten", "nan", "inf", "1e-3", "0x10"):
        with pytest.raises(argparse.ArgumentTypeError, match="not a whole number"):
            parse(bad)
    with pytest.raises(argparse.ArgumentTypeError, match="from 1 to 10,000,000, got 0$"):
        parse("0")
    with pytest.raises(argparse.ArgumentTypeError, match="got 12,000,000$"):
        parse("1.2e7")
    with pytest.raises(argparse.ArgumentTypeError, match="got 1e4000$"):  # as typed, not 4,001 digits
        parse("1e4000")
    with pytest.raises(argparse.ArgumentTypeError, match="got 1e999999$"):  # a whole number, past the bound
        parse("1e999999")
    with pytest.raises(argparse.ArgumentTypeError, match=r"got 1{24}\.\.\.1{13}$"):
        parse("1" * 5000)  # Python makes no int of 5,000 digits from text: compared first, it is simply too large


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_redraws_in_place_on_a_terminal_and_prints_lines_in_a_log():
    tty = Terminal()
    show = progress_printer("rk4", 200, stream=tty)
    show(100)
    show(200)
    assert tty.getvalue() == "\r  rk4             50% of 200 steps\r  rk4            100% of 200 steps\n"
    log = io.StringIO()
    show = progress_printer("rk4", 200, stream=log)
    show(100)
    show(200)
    assert log.getvalue().splitlines() == ["  rk4             50% of 200 steps", "  rk4            100% of 200 steps"]
    line = wall_clock(0.0, stream=log)
    assert line.startswith("wall-clock: ") and line.endswith(" s") and log.getvalue().endswith(line + "\n")


def test_importing_a_script_installs_no_guard():
    """guard() acts only in the program being run: an exercise importing engine.py, or a test, keeps its handlers."""
    import signal

    from curriculum.common import interrupts

    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    interrupts.guard("imported.py")  # called from this module, which is not __main__
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before
    assert not interrupts.active()


def test_rounded_keeps_a_huge_numpy_float_finite():
    """numpy's round(x, 12) multiplies by 1e12 first: from 1.8e296 a float64 became inf, which strict JSON refuses
    (engine.py --system damped_spring --dt 1e12 --steps 3 computed, then could not write metrics.json)."""
    import numpy as np

    from curriculum.common.report import metrics_text, rounded

    assert rounded({"work": [np.float64(9.99e302), np.float64(-3.0e76)]}) == {"work": [9.99e302, -3.0e76]}
    assert type(rounded(np.float64(0.25))) is float and rounded(np.float64(-1e-13)) == 0.0
    metrics_text(rounded({"work": np.float64(1e308)}))  # no ValueError


def test_padded_gives_a_range_even_when_nothing_is_finite():
    """An ensemble whose every error is the log10 of an exact zero left the recording nothing to unpack."""
    import numpy as np

    from curriculum.common.recording import padded

    assert padded([np.full(4, -np.inf), np.array([np.nan])]) == (-1.0, 1.0)
    assert padded(np.array([0.0, 1.0])) == (-0.05, 1.05)


def test_shown_escapes_what_a_terminal_obeys_and_cuts_long_text():
    assert shown("a\x1b[2Jb\u202ec\nd\x85é\udcff") == "a\\x1b[2Jb\\u202ec\\nd\\x85é\\udcff"  # \udcff: the byte 0xff
    assert shown("x" * 5000) == "x" * 24 + "..." + "x" * 13 and shown("x" * 5000, None) == "x" * 5000
