"""The guard a chapter script or exercise installs first (`guard("engine.py")`): from then on SIGINT and SIGTERM end
the process at once (os._exit) with one line, exit 130 or 143, saying what happened to the run's files (`said()`, kept
true by outputs.write_run). Once main() has returned, the last exit handler skips Python's slow shutdown."""

import atexit
import contextlib
import os
import signal
import sys

ENDINGS = {signal.SIGINT: (130, "interrupted"), signal.SIGTERM: (143, "terminated")}
_state = {"prog": None, "said": "no file was written", "code": None}
KEPT = []  # what the program keeps whatever happens next (a prediction in the journal): every one-line message says so


def guard(prog: str) -> None:
    """install(prog) if the caller is the program being run (importing engine.py installs nothing)."""
    if sys._getframe(1).f_globals.get("__name__") == "__main__":
        install(prog)


def install(prog: str) -> None:
    _state["prog"] = prog
    for fd in (0, 1, 2):  # a stream closed at start gets /dev/null, so no file we open takes its number
        try:
            os.fstat(fd)
        except OSError:
            os.open(os.devnull, os.O_RDWR)  # the lowest free number: this one
    sys.stdout, sys.stderr = sys.stdout or open(1, "w", closefd=False), sys.stderr or open(2, "w", closefd=False)
    for number in ENDINGS:
        if signal.getsignal(number) is not signal.SIG_IGN:  # nohup and friends ignore on purpose
            signal.signal(number, _stop)
    atexit.register(_exit_now)  # registered before any library's exit handler, so it runs after all of them


def active() -> bool:  # False when main() is called from a test
    return _state["prog"] is not None


def said(text: str | None = None) -> str:
    """What a signal now would say happened to the run's files; `text` replaces it."""
    if text is not None:
        _state["said"] = text
    return _state["said"]


def one_line() -> str:  # the end of every one-line message: said() and what is kept whatever happens (KEPT)
    return "; ".join([_state["said"], *KEPT])


def exit_code(code: int | None = None) -> int | None:  # what main() returned, once it has (one_line_failures sets it)
    if code is not None:
        _state["code"] = code
    return _state["code"]


def _stop(number, frame):
    code, word = ENDINGS[number]
    _exit(code, f"{word}: {one_line()}\n")


def _exit_now() -> None:
    if _state["code"] is not None:
        _exit(_state["code"])


def _exit(code: int, line: str = "") -> None:
    for stream in (sys.stdout, sys.stderr):  # what was printed reaches its pipe or file before we go
        with contextlib.suppress(OSError, ValueError, AttributeError):
            stream.flush()
    with contextlib.suppress(OSError):
        os.write(2, line.encode(errors="backslashreplace"))  # unbuffered: a signal may land inside a print()
    os._exit(code)
