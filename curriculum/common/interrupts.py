"""The guard every chapter script and exercise installs on its first line, so that a signal ends it in one line.

    import sys

    from curriculum.common.interrupts import guard

    guard("engine.py")  # from here on, Ctrl-C or SIGTERM ends in one line, exit 130 or 143

From that line on, SIGINT and SIGTERM end the process at once (os._exit) with one line saying what happened to
the run's files: nothing is half-written outside outputs.signals_held(), which holds a signal until its files are
whole. outputs.write_run keeps the line true (`said()`); when main() returns, its exit code is kept and the
guard's last exit handler ends the process with it, skipping Python's shutdown (~0.3 s once Rerun is loaded).
It acts only in the program being run (the caller is __main__): importing engine.py installs nothing.
"""

import atexit
import os
import signal
import sys

EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}
WORDS = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}
_state = {"prog": None, "said": "no file was written", "code": None}
KEPT = []  # what the program keeps whatever happens next (a prediction in the journal): every one-line message says so


def guard(prog: str) -> None:
    """Make SIGINT/SIGTERM end the program with one line (130/143) from now on, if the caller is the program."""
    if sys._getframe(1).f_globals.get("__name__") == "__main__":  # not when imported (by an exercise, a test)
        install(prog)


def install(prog: str) -> None:
    """guard() without its check of who calls it."""
    _state["prog"] = prog
    for fd in (0, 1, 2):  # a stream closed at start gets /dev/null, so no file we open takes its number
        try:
            os.fstat(fd)
        except OSError:
            os.open(os.devnull, os.O_RDWR)  # the lowest free number: this one
    sys.stdout, sys.stderr = sys.stdout or open(1, "w", closefd=False), sys.stderr or open(2, "w", closefd=False)
    for number in EXIT_CODES:
        if signal.getsignal(number) is not signal.SIG_IGN:  # nohup and friends ignore on purpose
            signal.signal(number, _stop)
    atexit.register(_exit_now)  # registered before any library's exit handler, so it runs after all of them


def active() -> bool:
    """Whether this process's program installed the guard (False when main() is called from a test)."""
    return _state["prog"] is not None


def exit_code() -> int | None:
    """What main() returned, once it has (None before, or if it raised)."""
    return _state["code"]


def said(text: str | None = None) -> str:
    """What a signal now would say happened to the run's files; `text` replaces it."""
    if text is not None:
        _state["said"] = text
    return _state["said"]


def finished(text: str, code: int | None) -> None:
    """main() has ended with `code`: a signal from now on says the run had finished, and `text`."""
    _state["said"], _state["code"] = f"after the run had finished: {text}", code


def say(line: str) -> None:
    """Write one line to stderr, now and unbuffered; never raises."""
    try:
        os.write(2, f"{line}\n".encode(errors="backslashreplace"))
    except OSError:
        pass


def _stop(number, frame):
    try:
        sys.stdout.flush()  # a report already printed reaches its pipe before we go
    except (OSError, ValueError, AttributeError):
        pass
    text = "; ".join([_state["said"], *KEPT])
    say(f"{WORDS[number]}{' ' if text.startswith('after') else ': '}{text}")
    os._exit(EXIT_CODES[number])


def _exit_now() -> None:
    """The last exit handler: end with main()'s exit code once every other handler has run."""
    if _state["code"] is None:
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):
            pass
    os._exit(_state["code"])
