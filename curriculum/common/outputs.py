"""A run's files written whole or not at all (a temporary file beside each, os.replace'd while signals wait); the check
of an output folder before a run; and the decorator that makes main()'s every other failure one line."""

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

NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)  # for the journal's own open()
KEPT = interrupts.KEPT  # what main() keeps whatever happens next (a prediction in the journal), said in every line


def content_id(data: bytes | str) -> str:
    """16 hex digits of SHA-256: metrics.json carries the id of its own payload, and the recording the same id."""
    return hashlib.sha256(data.encode() if isinstance(data, str) else data).hexdigest()[:16]


def folder_arg(text: str) -> Path:
    """Argument type for an output folder: not empty."""
    if not text.strip():
        raise argparse.ArgumentTypeError("the output folder is empty; name one, e.g. outputs/run1")
    return Path(text)


def folder_problem(out, names=()) -> str | None:
    """Why the folder `out` cannot take files called `names`, or None if it can. Creates nothing."""
    out = existing = Path(out)
    for text in [str(out), *names]:
        if UNSHOWN.search(text):
            return f"'{shown(text, 100)}' holds a control character or a byte that is not text; name it plainly"
    if problem := planted(out):
        return problem
    while not os.path.lexists(existing) and existing != existing.parent:
        existing = existing.parent
    if os.path.isfile(existing):
        return f"{shown(out, 100)} cannot hold files: {shown(existing, 100)} is a file"
    try:
        tempfile.TemporaryFile(dir=existing).close()  # O_TMPFILE where it can: nothing is left, even for a moment
    except OSError as error:
        return f"cannot create a file in {shown(existing, 100)}: {error.strerror or error}"
    for name in names:
        if os.path.isdir(out / name):
            return f"{shown(out / name, 100)} is a folder; move it away or choose another output folder"
    return None


def planted(out, hops: int = 0) -> str | None:
    """Whether the way to `out` (links' targets too) goes through another user's link in a sticky folder everyone may
    write to, or `out` is their file there: the kernel's protected_symlinks and protected_regular, which root skips."""
    path = Path(os.path.abspath(out))
    for step in [*reversed(path.parents), path]:
        try:
            mine, folder = os.lstat(step), os.stat(step.parent)
            link = stat.S_ISLNK(mine.st_mode)
            if folder.st_mode & 0o1002 == 0o1002 and mine.st_uid not in (os.geteuid(), folder.st_uid) and (
                    link or step == path and stat.S_ISREG(mine.st_mode)):
                where = f"goes through {shown(step, 100)}, a symbolic link" if link else "is a file"
                return f"{shown(out, 100)} {where} of user {mine.st_uid} in a shared sticky folder (like /tmp): refused"
            if link and hops < 40:
                return planted(step.parent / os.readlink(step) / path.relative_to(step), hops + 1)
        except OSError:
            return None  # the rest of the way does not exist (yet)
    return None


def write_run(folder, files: dict) -> None:
    """Replace the files {name: bytes or str} in `folder` (made if needed) together: each is written to a temporary
    file beside it, then all are renamed in the order given while signals wait. An OSError leaves no temporary file,
    and interrupts.said() tells what is new, for the one line of a failure or a signal."""
    folder, names = Path(folder), list(files)
    these, were = f"{' and '.join(names)} in {shown(folder, 100)}", "were" if len(names) > 1 else "was"
    interrupts.said(f"{these} {were} left as {'they' if len(names) > 1 else 'it'} {were}")
    if problem := planted(folder):  # checked again: a link planted while the run ran
        raise PermissionError(problem)
    os.makedirs(folder, exist_ok=True)
    temps = {}
    with signals_held():
        try:
            for name, data in files.items():
                temps[name] = folder / f".{name}.{secrets.token_hex(8)}.tmp"
                with open(temps[name], "xb") as file:  # a new file (never through a link), 0o666 less the umask
                    file.write(data.encode() if isinstance(data, str) else data)
                    file.flush()
                    os.fsync(file.fileno())  # on disk before its name is: after a crash, the old file or the new
            for done, name in enumerate(names, 1):
                os.replace(temps[name], folder / name)
                new, are = " and ".join(names[:done]), "is" if done == 1 else "are"
                interrupts.said(f"only {new} in {shown(folder, 100)} {are} new" if done < len(names) else
                                f"{these} {were} written before that")
        finally:
            for temp in temps.values():  # those renamed are gone already
                with contextlib.suppress(OSError):
                    os.unlink(temp)


def write_atomic(path, data: bytes | str) -> None:
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
    """Decorate a main(argv) -> int: an OSError or a MemoryError is one line saying what happened to the files."""

    def decorate(main):
        @functools.wraps(main)
        def guarded(*args, **kwargs):
            KEPT.clear()
            interrupts.said("no file was written")
            for stream in (sys.stdout, sys.stderr):  # a name the terminal's encoding cannot show prints escaped
                with contextlib.suppress(AttributeError, ValueError, OSError):
                    stream.reconfigure(errors="backslashreplace")
            code = None
            try:
                code = main(*args, **kwargs)
                sys.stdout.flush()  # the report reaches its pipe or file now, where a failure is still ours to say
            except OSError as error:
                code = _fail(prog, error.strerror or error)
            except MemoryError:
                code = _fail(prog, f"not enough memory (MemoryError): {memory_hint}, or raise the memory limit")
            finally:
                interrupts.exit_code(code)
            return code

        return guarded

    return decorate


def _fail(prog: str, why) -> int:  # the one line (after a newline ending a progress line drawn in place); exit 1
    print(("\n" if sys.stderr.isatty() else "") + f"{prog}: error: {why}; {interrupts.one_line()}", file=sys.stderr,
          flush=True)
    return 1
