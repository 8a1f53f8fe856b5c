"""The guard a chapter script or exercise installs first (`guard("engine.py")`): from then on SIGINT and SIGTERM end
the process at once (os._exit) with one line, exit 130 or 143, saying what happened to the run's files (`said()`,
kept true by outputs.write_run; outputs.signals_held() holds a signal until its files are whole). When main()
returns, the last exit handler ends the process with its exit code, skipping Python's slow shutdown."""

import atexit
import contextlib
import os
import signal
import sys

EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}
WORDS = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}
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
    for number in EXIT_CODES:
        if signal.getsignal(number) is not signal.SIG_IGN:  # nohup and friends ignore on purpose
            signal.signal(number, _stop)
    atexit.register(_exit_now)  # registered before any library's exit handler, so it runs after all of them


def active() -> bool:  # False when main() is called from a test
    return _state["prog"] is not None


def exit_code() -> int | None:  # what main() returned, once it has
    return _state["code"]


def said(text: str | None = None) -> str:
    """What a signal now would say happened to the run's files; `text` replaces it."""
    if text is not None:
        _state["said"] = text
    return _state["said"]


def finished(text: str, code: int | None) -> None:
    _state["said"], _state["code"] = f"after the run had finished: {text}", code


def say(line: str) -> None:
    """Write one line to stderr, now and unbuffered; never raises."""
    with contextlib.suppress(OSError):
        os.write(2, f"{line}\n".encode(errors="backslashreplace"))


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            stream.flush()


def _stop(number, frame):
    _flush()  # a report already printed reaches its pipe before we go
    text = "; ".join([_state["said"], *KEPT])
    say(f"{WORDS[number]}{' ' if text.startswith('after') else ': '}{text}")
    os._exit(EXIT_CODES[number])


def _exit_now() -> None:
    if _state["code"] is not None:
        _flush()
        os._exit(_state["code"])
