"""The guard every chapter script and exercise installs on its first line, so that it never ends in a traceback.

    import sys

    from curriculum.common.interrupts import guard

    guard("engine.py")  # from here on, Ctrl-C or SIGTERM ends in one line, exit 130 or 143

From that line to the process's last instant, SIGINT and SIGTERM end the program with one line and exit
130 or 143. Until main() takes over nothing has been written, so the line says that. While main() runs,
@one_line_failures (outputs.py) installs its own handlers, which clean up the run's files; when main()
returns it hands the signals back here with what was written (`finished()`), so a Ctrl-C while the exit
handlers run says the truth: "interrupted after the run had finished: ...". The guard's own exit handler
runs last and ends the process with main()'s code: Python's shutdown after it (~0.3 s once Rerun is
loaded) would run with the signal handlers reset, where a Ctrl-C ends the process without a word.

The guard also answers what can go wrong before main(): an import that runs out of memory under a
memory limit (ulimit -v) gets "not enough memory", never a library's advice to reinstall. Any other
error keeps its traceback: that is a bug to report.

It acts only in the program being run (the module calling it is __main__): importing engine.py from an
exercise or a test installs nothing. Loads nothing heavy: atexit, os, signal and sys are built in.
With stderr closed (`2>&-`) and stdout open, what would go to stderr goes to stdout (say() and sys.stderr).
"""

import atexit
import os
import signal
import sys

EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}
WORDS = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}

# What a signal arriving now would have to say; one_line_failures' main() updates it as it finishes.
_state = {"prog": None, "said": "no file was written", "code": None, "err": 2}


def guard(prog: str) -> None:
    """Make SIGINT/SIGTERM end the program with one line (130/143), and memory errors one line, from now on."""
    if sys._getframe(1).f_globals.get("__name__") == "__main__":  # not when imported (by an exercise, a test)
        install(prog)


def install(prog: str) -> None:
    """guard() without its check of who calls it: for a helper that made that check for its own caller."""
    _state["prog"] = prog
    closed = _keep_standard_streams()
    if 2 in closed and 1 not in closed:  # stderr closed, stdout open: the lines go to stdout, not nowhere
        _state["err"], sys.stderr = 1, sys.stdout
    for number in EXIT_CODES:
        if signal.getsignal(number) is not signal.SIG_IGN:  # nohup and friends ignore on purpose
            signal.signal(number, _stop)
    sys.excepthook = _one_line_hook(sys.excepthook)
    atexit.register(_exit_now)  # registered before any library's exit handler, so it runs after all of them


def active() -> bool:
    """Whether this process's program installed the guard (False when main() is called from a test)."""
    return _state["prog"] is not None


def exit_code() -> int | None:
    """What main() returned, once it has (None before, or if it raised)."""
    return _state["code"]


def finished(said: str, code: int | None) -> None:
    """main() has ended: from now on a signal says `said` (what was written) and that the run had finished.
    `code` is what main() returned (None if it raised: Python then ends the process its own way)."""
    _state["said"] = f"after the run had finished: {said}"
    _state["code"] = code


def _exit_now() -> None:
    """The last exit handler: end the process with main()'s exit code once every other handler has run (see
    the module's docstring). The run's files were written and synced; the streams are flushed here."""
    code = _state["code"]
    if code is None:
        return
    try:
        if sys.stdout is not None:
            sys.stdout.flush()  # what is still buffered (--help's text, say) goes out now, or we say it could not
    except (OSError, ValueError) as error:
        if code == 0:
            why = getattr(error, "strerror", None) or str(error)
            say(f"{_state['prog']}: error: could not print the report ({why}: stdout closed or full?)")
            code = 1
    try:
        if sys.stderr is not None:
            sys.stderr.flush()
    except (OSError, ValueError):
        pass
    os._exit(code)


def say(line: str) -> None:
    """Write one line to stderr (to stdout if only stderr was closed at start), now and unbuffered; never raises."""
    try:
        os.write(_state["err"], f"{line}\n".encode(errors="backslashreplace"))
    except OSError:
        pass


def _stop(number, frame):
    """End at once: nothing is half-done outside main() (main() installs its own handlers)."""
    said = _state["said"]
    line = f"{WORDS[number]} {said}" if said.startswith("after") else f"{WORDS[number]}: {said}"
    try:
        if sys.stdout is not None:
            sys.stdout.flush()  # a report already printed reaches its pipe before we go
    except (OSError, ValueError):
        pass
    say(line)
    os._exit(EXIT_CODES[number])


def _keep_standard_streams() -> list:
    """A standard stream closed when we start (`>&-`) gets /dev/null in its place; returns the closed ones.

    Otherwise the next file we open takes its number, and whatever writes to that stream (a library's
    warning, our own report) would write into one of the run's files. sys.stdout stays None, so
    one_line_failures still knows the report has nowhere to go.
    """
    closed = []
    for fd in (0, 1, 2):  # stdin, stdout, stderr
        try:
            os.fstat(fd)
        except OSError:
            closed.append(fd)
            try:
                devnull = os.open(os.devnull, os.O_RDWR)
                if devnull != fd:
                    os.dup2(devnull, fd)
                    os.close(devnull)
            except OSError:
                pass
    return closed


def memory_problem(error: BaseException) -> str | None:
    """If `error` (or what caused it) is the system refusing memory, its words: else None.

    Under a memory limit Python raises MemoryError, and a library loading its compiled part fails with
    "failed to map segment from shared object" or "Cannot allocate memory" (numpy then adds advice to
    reinstall, which would be wrong: nothing is broken).
    """
    for link in chain(error):
        if isinstance(link, MemoryError):
            return "MemoryError"
        text = str(link)
        for words in ("failed to map segment", "Cannot allocate memory", "cannot allocate memory"):
            if isinstance(link, (ImportError, OSError)) and words in text:
                return words
    return None


def signal_in(error: BaseException) -> int | None:
    """SIGINT or SIGTERM if `error` is, or was raised while handling, a Ctrl-C or a SIGTERM (else None).

    A Ctrl-C that lands inside a library's import can come out as that library's ImportError.
    """
    for link in chain(error):
        if isinstance(link, KeyboardInterrupt):
            return signal.SIGINT
        if type(link).__name__ == "Terminated":  # outputs.Terminated, without importing outputs here
            return signal.SIGTERM
    return None


def chain(error: BaseException):
    seen = set()
    while error is not None and id(error) not in seen:
        seen.add(id(error))
        yield error
        error = error.__cause__ or error.__context__


def _one_line_hook(previous):
    def hook(kind, error, traceback):
        number = signal_in(error)
        if number is not None:
            line, code = f"{WORDS[number]}: {_state['said']}", EXIT_CODES[number]
        elif memory_problem(error):
            line, code = (f"{_state['prog']}: error: not enough memory to start ({memory_problem(error)}); "
                          "raise the memory limit (ulimit -v) or close other programs, and run it again"), 1
        else:
            previous(kind, error, traceback)  # a bug: its traceback is what a report needs
            return
        say(line)
        os._exit(code)

    return hook
