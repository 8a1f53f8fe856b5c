"""A run's files written whole or not at all, and a main() whose every failure is one line.

- `folder_problem(out, names)`: before the run, why `out` cannot take the files (it tries a temporary file where
  `out`, or its deepest existing folder, is; it creates nothing), or a link another user planted on the way.
- `write_run(out, {"engine.rrd": data, "metrics.json": text})`: temporary files in `out`, synced, then renamed
  into place in the order given (the index last) while Ctrl-C and SIGTERM wait; writers into one folder take
  turns (flock on the folder). On failure nothing is left behind and the previous files are as they were.
- `@one_line_failures("engine.py")` on a main(): an OutputError, an OSError or a MemoryError is one line.
"""

import contextlib
import errno
import functools
import hashlib
import os
import secrets
import signal
import stat
import sys
import tempfile
import threading
from pathlib import Path

from curriculum.common import interrupts
from curriculum.common.cli import UNSHOWN, shown

try:
    import fcntl
except ImportError:  # Windows: no flock; each file is still replaced atomically
    fcntl = None

NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
KEPT = interrupts.KEPT  # what main() keeps whatever happens next (a prediction in the journal), said in every line


class OutputError(Exception):
    """A run's files could not be written. str() is one line for the user; exit_code is 1 or 2 (bad input)."""

    def __init__(self, message: str, exit_code: int = 1):
        super().__init__(message)
        self.exit_code = exit_code


def content_id(data: bytes | str) -> str:
    """A run identifier made from content, not from a clock: 16 hex digits of SHA-256. metrics.json carries the id
    of its own payload (without the id) and the recording the same id, so anyone can check they belong together."""
    return hashlib.sha256(data.encode() if isinstance(data, str) else data).hexdigest()[:16]


def folder_arg(text: str) -> Path:
    """Argument type for an output folder: not empty (the current folder), no control character or bidi override."""
    import argparse

    if not text.strip():
        raise argparse.ArgumentTypeError("the output folder is empty; name one, e.g. outputs/run1")
    if UNSHOWN.search(text):
        raise argparse.ArgumentTypeError(f"'{shown(text)}' holds a control character; name the folder plainly")
    return Path(text)


def _p(path) -> str:
    return shown(path, 100)


# --- the check before the run ---


def folder_problem(out: Path, names=()) -> str | None:
    """Why `out` cannot take files called `names`, or None if it can. Creates nothing; takes milliseconds."""
    out = existing = Path(out)
    try:
        problem = _planted(out)
        if problem:
            return problem
        while not os.path.lexists(existing) and existing != existing.parent:
            existing = existing.parent
        if not os.path.isdir(existing):
            try:
                info = os.stat(existing)  # a symbolic link that loops raises here (ELOOP)
            except FileNotFoundError:
                return f"{_p(out)} cannot be used: {_p(existing)} is a symbolic link to" \
                       f" {_p(os.readlink(existing))}, which does not exist"
            what = "a file" if stat.S_ISREG(info.st_mode) else "not a folder"
            return f"{_p(out)} cannot hold files: {_p(existing)} is {what}"
        longest = max([*out.parts, *names], key=len, default="")
        if len(os.fsencode(longest)) > 255:
            return f"{_p(out)} cannot be created: a name in it is {len(longest)} characters, longer than the file" \
                   " system allows (255)"
        tempfile.TemporaryFile(dir=existing).close()  # O_TMPFILE where it can: nothing is left, even for a moment
        for name in names:
            if os.path.isdir(out / name):
                return f"{_p(out / name)} is a folder; move it away or choose another output folder"
    except OSError as error:
        if error.errno == errno.ELOOP:
            return f"{_p(out)} cannot be used: it goes through a symbolic link that loops"
        if isinstance(error, FileNotFoundError):  # the folders exist, yet "no such file": /proc and its kind
            return f"cannot create a file in {_p(out)}: {_p(existing)} exists but does not let files or folders be" \
                   " created in it"
        return f"cannot create a file in {_p(out)}: {error.strerror or error}"
    return None


def _planted(out: Path, hops: int = 0) -> str | None:
    """Whether the way to `out` (through links' targets too) follows a symbolic link another user made in a sticky
    folder all may write to (/tmp): the kernel's protected_symlinks rule, which some machines turn off."""
    path = Path(os.path.abspath(out))
    for step in [*reversed(path.parents), path]:
        with contextlib.suppress(OSError):
            if hops < 40 and os.path.islink(step):
                link, folder = os.lstat(step), os.stat(step.parent)
                if folder.st_mode & 0o1002 == 0o1002 and link.st_uid not in (os.geteuid(), folder.st_uid):
                    return f"{_p(out)} goes through {_p(step)}, a symbolic link that user {link.st_uid} made in a" \
                           " sticky folder everyone may write to; choose another output folder"
                return _planted(step.parent / os.readlink(step) / path.relative_to(step), hops + 1)
    return None


def recording_problem(path: Path) -> str | None:
    """Why an exercise's recording cannot go to `path`, or None: an .rrd file in a folder we can write, so that a
    slip such as `--rrd README.md` never overwrites something else."""
    if UNSHOWN.search(str(path)):
        return f"'{_p(path)}' holds a control character; name the file plainly"
    if path.suffix != ".rrd":
        return f"{_p(path)} does not end in .rrd"
    return folder_problem(path.parent, [path.name])


# --- writing ---


def write_run(folder: Path, files: dict) -> None:
    """Replace the files {name: bytes or str} in `folder` together, creating `folder` if needed.

    Raises OutputError with one line; then no temporary file is left and the previous files are as they were.
    """
    folder, names = Path(folder), list(files)
    kept = _kept(folder, names)
    interrupts.said(kept)  # what a signal would say from here on
    problem = _planted(folder)
    if problem:
        raise OutputError(f"{problem}; {kept}", exit_code=2)
    temps, renamed, current = {}, [], None
    try:
        os.makedirs(folder, exist_ok=True)
        with _locked(folder) as lock, signals_held():
            try:
                for current, data in files.items():
                    temps[current] = folder / f".{current}.{secrets.token_hex(8)}.tmp"
                    fd = os.open(temps[current], os.O_WRONLY | os.O_CREAT | os.O_EXCL | NOFOLLOW, 0o666)  # (umask)
                    with open(fd, "wb") as file:
                        file.write(data.encode() if isinstance(data, str) else data)
                        file.flush()
                        os.fsync(fd)
                for current in names:
                    os.replace(temps[current], folder / current)
                    renamed.append(temps.pop(current) and current)
                interrupts.said(f"{' and '.join(names)} in {_p(folder)} {'were' if len(names) > 1 else 'was'}"
                                " written before that")
                with contextlib.suppress(OSError):
                    os.fsync(lock)  # the renames reach the disk too
            finally:
                for temp in temps.values():
                    with contextlib.suppress(OSError):
                        os.unlink(temp)
    except OSError as error:
        if renamed:
            kept = f"only {' and '.join(renamed)} in {_p(folder)} {'is' if len(renamed) == 1 else 'are'} new"
        raise OutputError(f"cannot write {_p(folder / current if current else folder)}: {error.strerror or error};"
                          f" {kept}") from None


def write_atomic(path: Path, data: bytes | str) -> None:
    """Replace one file atomically and durably (write_run with a single file)."""
    write_run(Path(path).parent, {Path(path).name: data})


def _kept(folder: Path, names) -> str:
    if len(names) == 1:
        return f"{_p(folder / names[0])} was left as it was"
    return f"{' and '.join(names)} in {_p(folder)} were left as they were"


@contextlib.contextmanager
def _locked(folder: Path):
    """The folder open and flocked: writers take turns and no lock file is left. Waiting can be interrupted."""
    fd = os.open(folder, os.O_RDONLY | os.O_CLOEXEC)
    try:
        with contextlib.suppress(OSError, AttributeError):  # no flock (Windows, some file systems): still atomic
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield fd
    finally:
        os.close(fd)  # releases the lock


@contextlib.contextmanager
def signals_held():
    """Hold Ctrl-C and SIGTERM until the block is done, then deliver them (the guard then says what was written).

    The handlers are swapped for one that only notes the signal (blocking the mask would not do: Rerun's threads
    could receive it), and the signal is raised again afterwards."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    arrived, previous = [], {}
    try:
        for number in (signal.SIGINT, signal.SIGTERM):
            previous[number] = signal.signal(number, lambda caught, frame: arrived.append(caught))
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        if arrived:
            signal.raise_signal(arrived[0])


# --- main(): every failure is one line ---


def one_line_failures(prog: str, memory_hint: str = "a shorter run needs less"):
    """Decorate a main(argv) -> int: an OutputError is one line and its exit code; an OSError (print() into a closed
    pipe, too many open files) or a MemoryError is one line and exit 1. Each line says what happened to the run's
    files. Signals are the guard's (interrupts.py): one line, 130 or 143, at any moment."""

    def decorate(main):
        @functools.wraps(main)
        def guarded(*args, **kwargs):
            KEPT.clear()
            interrupts.said("no file was written")
            for stream in (sys.stdout, sys.stderr):  # a path the terminal cannot encode prints escaped
                with contextlib.suppress(AttributeError, ValueError, OSError):
                    stream.reconfigure(errors="backslashreplace")
            code = None
            try:
                code = main(*args, **kwargs)
                sys.stdout.flush()  # the report reaches its pipe or file now, where a failure is still ours to say
            except OutputError as error:
                code = _stop(error.exit_code, f"{prog}: error: {error}")
            except MemoryError:
                code = _stop(1, f"{prog}: error: not enough memory (MemoryError): {memory_hint}, or raise the memory"
                                f" limit; {_said()}")
            except OSError as error:
                code = _stop(1, f"{prog}: error: {error.strerror or error}; {_said()}")
            finally:
                if interrupts.active():
                    interrupts.finished(interrupts.said(), code)
            return code

        return guarded

    return decorate


def _said() -> str:
    return "; ".join([interrupts.said(), *KEPT])


def _stop(code: int, message: str) -> int:
    """Print the one line (after a newline that ends a progress line drawn in place) and return the exit code."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        print(("\n" if sys.stderr.isatty() else "") + message, file=sys.stderr, flush=True)
    return code
