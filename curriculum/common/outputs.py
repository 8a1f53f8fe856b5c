"""A run's files written whole or not at all (temporary files in the folder, synced, then os.replace'd while
signals wait; the previous files kept on any failure), the check of --out before the run, and a main() whose every
failure is one line."""

import argparse
import contextlib
import functools
import hashlib
import os
import secrets
import signal
import stat
import sys
import tempfile
from pathlib import Path

from curriculum.common import interrupts
from curriculum.common.cli import UNSHOWN, shown

fcntl = None if os.name == "nt" else __import__("fcntl")  # Windows: no flock; each file is still replaced atomically

NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
KEPT = interrupts.KEPT  # what main() keeps whatever happens next (a prediction in the journal), said in every line


class OutputError(Exception):
    """A run's files could not be written. str() is one line for the user; exit_code is 1 or 2 (bad input)."""

    def __init__(self, message: str, exit_code: int = 1):
        super().__init__(message)
        self.exit_code = exit_code


def content_id(data: bytes | str) -> str:
    """16 hex digits of SHA-256: metrics.json carries the id of its own payload, and the recording the same id."""
    return hashlib.sha256(data.encode() if isinstance(data, str) else data).hexdigest()[:16]


def folder_arg(text: str) -> Path:
    """Argument type for an output folder: not empty, no control character or bidi override."""
    if not text.strip():
        raise argparse.ArgumentTypeError("the output folder is empty; name one, e.g. outputs/run1")
    if UNSHOWN.search(text):
        raise argparse.ArgumentTypeError(f"'{shown(text)}' holds a control character; name the folder plainly")
    return Path(text)


def _p(path) -> str:
    return shown(path, 100)


def folder_problem(out: Path, names=()) -> str | None:
    """Why `out` cannot take files called `names`, or None if it can. Creates nothing."""
    out = existing = Path(out)
    try:
        problem = planted(out)
        if problem:
            return problem
        while not os.path.lexists(existing) and existing != existing.parent:
            existing = existing.parent
        if not os.path.isdir(existing):
            what = "a file" if os.path.isfile(existing) else "not a folder" if os.path.exists(existing) else \
                "a symbolic link that leads nowhere or loops"
            return f"{_p(out)} cannot hold files: {_p(existing)} is {what}"
        tempfile.TemporaryFile(dir=existing).close()  # O_TMPFILE where it can: nothing is left, even for a moment
        for name in names:
            if os.path.isdir(out / name):
                return f"{_p(out / name)} is a folder; move it away or choose another output folder"
    except OSError as error:
        if isinstance(error, FileNotFoundError):  # the folders exist, yet "no such file": /proc and its kind
            return f"cannot create a file in {_p(out)}: {_p(existing)} exists but does not let files or folders be" \
                   " created in it"
        return f"cannot create a file in {_p(out)}: {error.strerror or error}"
    return None


def planted(out: Path, hops: int = 0) -> str | None:
    """Whether the way to `out` (links' targets too) follows another user's link in a sticky world-writable folder,
    or `out` is another user's file there: the kernel's protected_symlinks and protected_regular rules, which some
    machines turn off and root's renames do not meet."""
    path = Path(os.path.abspath(out))
    for step in [*reversed(path.parents), path]:
        with contextlib.suppress(OSError):
            mine, folder, link = os.lstat(step), os.stat(step.parent), os.path.islink(step)
            if folder.st_mode & 0o1002 == 0o1002 and mine.st_uid not in (os.geteuid(), folder.st_uid) and (
                    link or step == path and stat.S_ISREG(mine.st_mode)):
                where = f"goes through {_p(step)}, a symbolic link" if link else "is a file"
                return f"{_p(out)} {where} that user {mine.st_uid} made in a sticky folder everyone may write to," \
                       " never used"
            if hops < 40 and link:
                return planted(step.parent / os.readlink(step) / path.relative_to(step), hops + 1)
    return None


def recording_problem(path: Path) -> str | None:
    """Why an exercise's recording cannot go to `path` (an .rrd file in a folder we can write), or None."""
    if UNSHOWN.search(str(path)):
        return f"'{_p(path)}' holds a control character; name the file plainly"
    if path.suffix != ".rrd":
        return f"{_p(path)} does not end in .rrd"
    return folder_problem(path.parent, [path.name])


def write_run(folder: Path, files: dict) -> None:
    """Replace the files {name: bytes or str} in `folder` together, in the order given, creating `folder` if
    needed; writers into one folder take turns. OutputError: one line, no temporary file left, the previous kept."""
    folder, names = Path(folder), list(files)
    kept = f"{_p(folder / names[0])} was left as it was" if len(names) == 1 else \
        f"{' and '.join(names)} in {_p(folder)} were left as they were"
    interrupts.said(kept)  # what a signal would say from here on
    problem = planted(folder)
    if problem:
        raise OutputError(f"{problem}; {kept}", exit_code=2)
    temps, renamed, current, lock = {}, [], None, None
    try:
        os.makedirs(folder, exist_ok=True)
        lock = os.open(folder, os.O_RDONLY | os.O_CLOEXEC)  # flocked: writers take turns, and no lock file is left
        with contextlib.suppress(OSError, AttributeError):  # no flock (Windows, some file systems): still atomic
            fcntl.flock(lock, fcntl.LOCK_EX)
        with signals_held():
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
    finally:
        if lock is not None:
            os.close(lock)  # releases the lock


def write_atomic(path: Path, data: bytes | str) -> None:
    write_run(Path(path).parent, {Path(path).name: data})


@contextlib.contextmanager
def signals_held():
    """Hold SIGINT and SIGTERM, then raise them again (a swapped handler: Rerun's threads ignore a signal mask)."""
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


def one_line_failures(prog: str, memory_hint: str = "a shorter run needs less"):
    """Decorate a main(argv) -> int: an OutputError, OSError or MemoryError is one line saying what was written."""

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
    """Print the one line (after a newline ending a progress line drawn in place); return the exit code."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        print(("\n" if sys.stderr.isatty() else "") + message, file=sys.stderr, flush=True)
    return code
