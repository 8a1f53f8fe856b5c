"""Writing a run's files so that they are never lost, mixed up or redirected, and a run that ends in one line.

    from curriculum.common.outputs import folder_problem, write_run, one_line_failures, content_id

- `folder_problem(out, names)` says, before any simulation, why `out` cannot take a run's files: it tries
  (creates a file where `out`, or its deepest existing folder, is) instead of trusting os.access, which
  says yes to root for /sys and read-only folders. It refuses a path through a symbolic link another user
  planted in a shared sticky folder (like /tmp), as the kernel's protected_symlinks does. It creates no
  folder (runs started together into a missing one must not see it appear and vanish), except inside a
  folder others may write to: there it makes the missing ones at once and keeps them, so that another
  user's run started together finds them and is refused before its run, not after.
- `write_run(out, {"engine.rrd": data, "metrics.json": text})` replaces a run's files together: each goes
  to a new file with an unguessable name in `out` (created exclusively, never through a symlink),
  flushed to disk; only when all are complete are they renamed into place, and the folder is synced.
  Writers into one folder take turns (a lock on the folder itself, so no lock file is left in it).
  On any failure the temporary files are removed and the previous files are as they were.
- `@one_line_failures("engine.py")` on a main() turns Ctrl-C into exit 130, SIGTERM into 143, a write
  failure into one line and exit 1 (2 for bad input), and a closed or full stdout into one line.
"""

import argparse
import contextlib
import errno
import functools
import hashlib
import os
import secrets
import signal
import stat
import sys
import threading
from pathlib import Path

from curriculum.common import interrupts
from curriculum.common.cli import UNSHOWN, shown
from curriculum.common.interrupts import memory_problem, signal_in

try:
    import fcntl
except ImportError:  # Windows: no flock; each file is still replaced atomically, by path
    fcntl = None

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
PRINTING = (errno.EPIPE, errno.ENOSPC, errno.EIO, errno.EBADF, errno.EDQUOT, errno.EFBIG)  # print(), closed or full
# Where the OS lets us (Linux, macOS), every name is opened relative to the folder we locked, so a
# folder swapped for a symlink mid-write cannot redirect us. Elsewhere the same steps go by path.
BY_FOLDER = (fcntl is not None and hasattr(os, "O_DIRECTORY")
             and {os.open, os.rename, os.unlink, os.stat} <= os.supports_dir_fd)
NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
NAME_AND_PATH_MAX = (("PC_NAME_MAX", 255), ("PC_PATH_MAX", 4096))  # os.pathconf's names, and where it has none


class OutputError(Exception):
    """A run's files could not be written. str() is one line for the user; exit_code is 1 or 2 (bad input)."""

    def __init__(self, message: str, exit_code: int = 1):
        super().__init__(message)
        self.exit_code = exit_code


class Terminated(BaseException):
    """Raised in the main thread when SIGTERM arrives during a @one_line_failures main (like KeyboardInterrupt)."""


def content_id(data: bytes | str) -> str:
    """A run identifier made from content, not from a clock: the same run gives the same id.

    16 hex digits of SHA-256. A metrics file carries the id of its own payload (without the id),
    the recording carries the same id, so anyone can check that the two belong together.
    """
    return hashlib.sha256(data.encode() if isinstance(data, str) else data).hexdigest()[:16]


def folder_arg(text: str) -> Path:
    """Argument type for an output folder: any path but the empty one (the current folder) or one that holds a
    control character or a bidi override (every line that names the folder would show it garbled)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("the output folder is empty; name one, e.g. outputs/run1")
    if UNSHOWN.search(text):
        raise argparse.ArgumentTypeError(f"'{shown(text)}' holds a control character; name the folder plainly")
    return Path(text)


def _p(path) -> str:
    """A path as a message shows it: escaped, and cut in the middle past 100 characters."""
    return shown(path, 100)


# --- what the OS said, as one line ---


def _says(error: OSError) -> str:
    """An OSError's reason, without the errno number: 'Permission denied'."""
    return error.strerror or str(error)


def _first_missing(path: Path) -> list[Path]:
    """The folders from the first missing one down to `path`, outermost first (empty if `path` exists)."""
    missing = []
    while not os.path.lexists(path):
        missing.append(path)
        if path.parent == path:
            break
        path = path.parent
    return missing[::-1]


def _make_folders(path: Path, created: list) -> None:
    """Create `path` and its missing parents, noting in `created` the ones this call made.

    A folder that another run creates at the same moment is simply used (it is not ours to remove).
    """
    for folder in _first_missing(path):
        try:
            os.mkdir(folder)
        except FileExistsError:
            continue  # (FileNotFoundError: the folder above was removed meanwhile; write_run starts again)
        created.append(folder)


def _describe(out: Path, error: OSError) -> str:
    """Why `out` cannot be a folder for our files, from the error the OS gave."""
    if error.errno == errno.ENAMETOOLONG:
        return _too_long(out, [out, *out.parents], anyway=True)
    if error.errno == errno.ELOOP:
        return f"{_p(out)} cannot be used: it goes through a symbolic link that loops"
    for path in [out, *out.parents]:
        with contextlib.suppress(OSError):  # a name that appears and vanishes meanwhile is passed by
            if os.path.islink(path) and not os.path.exists(path):
                return f"{_p(out)} cannot be used: {_p(path)} is a symbolic link to {_p(os.readlink(path))}, which" \
                       " does not exist"
            if os.path.exists(path) and not os.path.isdir(path):
                what = "a file" if stat.S_ISREG(os.stat(path).st_mode) else "not a folder"
                return f"{_p(out)} cannot hold files: {_p(path)} is {what}"
    if error.errno == errno.ENOENT:  # "no such file" although the folders exist: /proc and its kind
        existing = next(path for path in [out, *out.parents] if os.path.isdir(path))
        return f"cannot create a file in {_p(out)}: {_p(existing)} exists but does not let files or folders be" \
               " created in it"
    return f"cannot create a file in {_p(out)}: {_says(error)}"


def _pathconf(out: Path, name: str, default: int) -> int:
    for path in [out, *out.parents]:
        with contextlib.suppress(OSError, ValueError):
            return os.pathconf(path, name)
    return default


# --- the check before the run ---


def folder_problem(out: Path, names=()) -> str | None:
    """Why `out` cannot take files called `names`, or None if it can. Takes milliseconds.

    It tries (see the module's docstring): a file with no name (O_TMPFILE: nothing is left even in an
    append-only folder), or where the file system has none, an empty file with an unguessable name,
    removed again; and it opens `out` as write_run() will. A folder, an immutable file or someone else's
    file of a sticky folder in the place of one of `names` is refused too: the run could not replace it.
    """
    out = Path(out)  # (an empty --out is refused by folder_arg: Path("") would be the current folder)
    try:
        missing = _first_missing(out)
        existing = missing[0].parent if missing else out
        if not os.path.isdir(existing):
            os.stat(existing)  # a symlink that loops or leads nowhere raises here, a file below
            raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(existing))
        problem = _planted(out) or (_too_long(out, missing) if missing else None)
        if problem:
            return problem
        if missing and os.stat(existing).st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            _make_folders(out, [])
            missing, existing = [], out
        _probe(existing)
        if not missing and BY_FOLDER:
            try:
                os.close(os.open(out, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC))  # as write_run() opens it
            except PermissionError:
                return f"{_p(out)} lets files be made in it but not read ({stat.filemode(os.stat(out).st_mode)})," \
                       " and the writer must open it; choose another output folder"
        if not missing:
            for problem in [_unreplaceable(out, "the folder"), *(_target_problem(out, name) for name in names)]:
                if problem:
                    return problem
    except OSError as error:
        return _describe(out, error)
    return None


def _planted(out: Path) -> str | None:
    """Whether the way to `out` (links in links' targets too) follows a symbolic link another user made in a sticky
    folder all may write to (/tmp): the kernel's protected_symlinks rule, which some machines turn off."""
    here, parts, hops = Path(), list(out.parts), 0
    while parts and hops < 40 and hasattr(os, "geteuid"):
        step = here / parts.pop(0)
        try:
            link = os.lstat(step)
            if not stat.S_ISLNK(link.st_mode):
                here = step
                continue
            folder = os.stat(here)
            if folder.st_mode & 0o1002 == 0o1002 and link.st_uid not in (os.geteuid(), folder.st_uid):
                return f"{_p(out)} goes through {_p(step)}, a symbolic link that user {link.st_uid} made in a" \
                       " sticky folder everyone may write to; following it could write into files not yours." \
                       " Choose another output folder"
            parts[:0], hops = Path(os.readlink(step)).parts, hops + 1  # an absolute target restarts at /
        except OSError:
            return None  # missing or closed to us: nothing beyond it is followed now
    return None


def _probe(folder: Path) -> None:
    """Create a file in `folder` and leave nothing behind, or raise the OSError that says why not."""
    if hasattr(os, "O_TMPFILE"):
        try:
            os.close(os.open(folder, os.O_TMPFILE | os.O_WRONLY | os.O_CLOEXEC, 0o600))
            return
        except OSError as error:
            if error.errno not in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL):
                raise  # the file system can make unnamed files, and refused this one: that is the answer
    probe = folder / f".probe-{secrets.token_hex(8)}"
    os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL | NOFOLLOW, 0o600))
    try:
        os.unlink(probe)
    except OSError as error:
        raise OSError(error.errno, f"{_says(error)} (and the empty file {probe.name} could not be removed)") from None


def _too_long(out: Path, folders: list, anyway: bool = False) -> str | None:
    """Whether one of `folders`' names, or else the whole path, is longer than the file system takes (the path,
    `anyway`: the OS said a name was too long, and none is)."""
    name_max, path_max = (_pathconf(folders[-1].parent, name, default) for name, default in NAME_AND_PATH_MAX)
    longest = max((folder.name for folder in folders), key=len)
    if len(os.fsencode(longest)) > name_max:
        return (f"{_p(out)} cannot be created: a name in it is {len(longest)} characters, longer than the file "
                f"system allows ({name_max})")
    if anyway or len(os.fsencode(os.path.abspath(out))) + 1 + len("metrics.json.0123456789abcdef.tmp") >= path_max:
        return (f"{_p(str(out)[:60])}... cannot be used: the path is {len(os.fsencode(os.path.abspath(out))):,}"
                f" bytes long, more than the system takes in one path ({path_max:,}), though no name in it is too long")
    return None


# File attributes (chattr) that forbid replacing a file or adding to a folder: Linux's FS_IOC_GETFLAGS.
FS_IOC_GETFLAGS, FS_IMMUTABLE_FL, FS_APPEND_FL = 0x80086601, 0x10, 0x20


def _unreplaceable(path: Path, what: str) -> str | None:
    """Whether `path` carries chattr's +i (immutable) or +a (append only), which no rename can get past."""
    if fcntl is None or not sys.platform.startswith("linux"):
        return None
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | NOFOLLOW)
    except OSError:
        return None  # not ours to open: the rename will say what it says
    try:
        flags = int.from_bytes(fcntl.ioctl(fd, FS_IOC_GETFLAGS, bytes(8))[:4], sys.byteorder)
    except OSError:
        return None  # a file system without these attributes
    finally:
        os.close(fd)
    for flag, word in ((FS_IMMUTABLE_FL, "immutable (chattr +i)"), (FS_APPEND_FL, "append-only (chattr +a)")):
        if flags & flag:
            verb = "files in it cannot be replaced" if what == "the folder" else "it cannot be replaced"
            return f"{_p(path)} is {word}, so {verb}; lift it with chattr -{'i' if flag == FS_IMMUTABLE_FL else 'a'}" \
                   " or choose another output folder"
    return None


def _target_problem(folder: Path, name: str, dir_fd: int | None = None) -> str | None:
    """Why the file `name` in `folder` cannot be replaced by a rename, or None."""
    try:
        target = os.lstat(**_at(folder, dir_fd, name))
    except FileNotFoundError:
        return None
    if stat.S_ISDIR(target.st_mode):
        return f"{_p(folder / name)} is a folder; move it away or choose another output folder"
    here = os.stat(folder if dir_fd is None else dir_fd)
    euid = os.geteuid() if hasattr(os, "geteuid") else 0
    if here.st_mode & stat.S_ISVTX and euid != 0 and euid not in (here.st_uid, target.st_uid):
        return (f"{_p(folder / name)} belongs to another user in a sticky folder (like /tmp), so it cannot be "
                "replaced; choose another output folder")
    if stat.S_ISREG(target.st_mode):
        return _unreplaceable(folder / name, "the file")
    return None


# --- writing ---

_last_write = {"folder": None, "names": (), "state": None}  # what the current main() has written, for its messages
KEPT = []  # what main() keeps whatever happens next (a prediction in the journal): every one-line message says so


def write_run(folder: Path, files: dict) -> None:
    """Replace the files {name: bytes or str} in `folder` together, creating `folder` if needed.

    All temporary files are complete and on disk before the first rename; the renames happen in
    the order given (put the index, e.g. metrics.json, last). Raises OutputError with one line;
    on failure, folders this call created are removed again and no temporary file is left.
    """
    folder, names = Path(folder), tuple(files)
    files = {name: data.encode() if isinstance(data, str) else bytes(data) for name, data in files.items()}
    _last_write.update(folder=folder, names=names, state="writing")
    created = []
    try:
        planted = _planted(folder)  # a link planted after the check is refused too
        if planted:
            raise OutputError(f"{planted}; {_kept(folder, names)}", exit_code=2)
        for _ in range(100):  # a folder another run made and removed again (its write failed) is made anew
            try:
                _make_folders(folder, created)
                with _locked(folder) as dir_fd:
                    _replace_together(folder, dir_fd, files)
                break
            except _FolderGone:
                continue
            except FileNotFoundError:
                missing = _first_missing(folder)
                if not missing or not os.path.isdir(missing[0].parent):
                    raise  # not a race: the folder is there (/proc and its kind), or something above it is no folder
        else:
            raise FileNotFoundError(errno.ENOENT, "the folder keeps disappearing")
    except _FolderGone:
        raise OutputError(f"{_p(folder)} keeps disappearing; {_kept(folder, names)}") from None
    except OSError as error:
        raise OutputError(f"{_describe(folder, error)}; {_kept(folder, names)}") from None
    finally:
        for path in reversed(created if _last_write["state"] != "written" else []):
            with contextlib.suppress(OSError, _FolderGone), _locked(path):  # under its lock: a run waiting
                os.rmdir(path)  # for it finds it gone (see _locked); only if empty: another writer's files stay


def write_atomic(path: Path, data: bytes | str) -> None:
    """Replace one file atomically and durably (write_run with a single file)."""
    write_run(Path(path).parent, {Path(path).name: data})


def _kept(folder: Path, names) -> str:
    if len(names) == 1:
        return f"{_p(folder / names[0])} was left as it was"
    return f"{' and '.join(names)} in {_p(folder)} were left as they were"


class _FolderGone(Exception):
    """The folder vanished between creating it and opening it."""


@contextlib.contextmanager
def _locked(folder: Path):
    """Hold flock on the folder's own descriptor: writers take turns, and no lock file is left behind.

    Waiting for the lock can be interrupted (Ctrl-C, SIGTERM). Where flock is not supported
    (Windows, some network file systems) the write goes ahead unlocked: each file is still atomic.
    Yields the folder's descriptor, or None where names are used by path (see BY_FOLDER). A reader who
    takes a shared flock on the folder never sees one run's file beside another's.
    """
    if not BY_FOLDER:
        if not os.path.isdir(folder):
            raise _FolderGone
        yield None
        return
    try:
        dir_fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except FileNotFoundError:
        raise _FolderGone from None
    try:
        try:
            fcntl.flock(dir_fd, fcntl.LOCK_EX)
        except OSError as error:
            if error.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.EINVAL, errno.EBADF):
                raise
        if os.fstat(dir_fd).st_nlink == 0:  # removed while we waited (a run that made it failed): not a folder
            raise _FolderGone  # any more, though still open; write_run makes it again
        yield dir_fd
    finally:
        os.close(dir_fd)  # closing the last descriptor releases the lock


def _at(folder: Path, dir_fd: int | None, name: str) -> dict:
    """`name` in `folder` as os.open, os.lstat and os.unlink take it: relative to the open folder where we can."""
    return {"path": name, "dir_fd": dir_fd} if dir_fd is not None else {"path": str(folder / name)}


def _rename(folder: Path, dir_fd: int | None, temp: str, name: str) -> None:
    """Put `temp` in the place of `name`, atomically (on POSIX a rename replaces; on Windows os.replace does)."""
    if dir_fd is None:
        os.replace(folder / temp, folder / name)
    else:
        os.rename(temp, name, src_dir_fd=dir_fd, dst_dir_fd=dir_fd)


def _replace_together(folder: Path, dir_fd: int | None, files: dict) -> None:
    temps = {}
    try:
        for name, data in files.items():
            with signals_held():  # the name is recorded before anything can interrupt us
                temp = f".{name}.{secrets.token_hex(8)}.tmp"
                fd = os.open(**_at(folder, dir_fd, temp), flags=os.O_WRONLY | os.O_CREAT | os.O_EXCL | NOFOLLOW,
                             mode=0o666)  # the umask applies, as to any new file
                temps[name] = temp
            try:
                _write_all(fd, data)
                os.fsync(fd)
            except OSError as error:
                raise OutputError(f"cannot write {_p(folder / name)}: {_says(error)}; "
                                  f"{_kept(folder, list(files))}") from None
            finally:
                os.close(fd)
        with signals_held():  # a Ctrl-C here waits until both renames are done
            for name in files:
                problem = _target_problem(folder, name, dir_fd)
                if problem:
                    raise OutputError(f"{problem}; {_kept(folder, list(files))}", exit_code=2)
            renamed = []
            for name, temp in temps.items():
                try:
                    _rename(folder, dir_fd, temp, name)
                except OSError as error:
                    if not renamed:
                        raise
                    old = [n for n in files if n not in renamed]
                    raise OutputError(
                        f"only part of the run was written: {' and '.join(renamed)} in {_p(folder)} "
                        f"{'is' if len(renamed) == 1 else 'are'} new, but {name} could not be replaced "
                        f"({_says(error)}), so {' and '.join(old)} {'is' if len(old) == 1 else 'are'} "
                        "from an earlier run") from None
                renamed.append(name)
            _last_write["state"] = "written"  # before a held Ctrl-C is delivered, so its message is true
            try:
                if dir_fd is not None:  # (by path, on Windows, a folder cannot be opened to sync)
                    os.fsync(dir_fd)  # the renames themselves reach the disk
            except OSError as error:
                if error.errno not in (errno.EINVAL, errno.EBADF):  # (some file systems cannot sync a folder)
                    raise OutputError(f"{' and '.join(files)} in {_p(folder)} were replaced, but the folder could"
                                      f" not be synced to disk ({_says(error)})") from None
    finally:
        with signals_held():
            for temp in temps.values():
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(**_at(folder, dir_fd, temp))


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view[: 1 << 24]):]


@contextlib.contextmanager
def signals_held():
    """Hold Ctrl-C and SIGTERM until the block is done, then deliver them.

    Blocking the signal mask is not enough: Rerun's threads could receive it. So the handlers are
    swapped for one that only notes the signal, and the signal is raised again afterwards.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    arrived, previous = [], {}
    try:
        for number in STOP_SIGNALS:
            previous[number] = signal.signal(number, lambda caught, frame: arrived.append(caught))
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        if arrived:
            signal.raise_signal(arrived[0])


# --- main(): every failure is one line ---


def one_line_failures(prog: str, memory_hint: str = "a shorter run needs less"):
    """Decorate a main(argv) -> int so that no failure ends in a traceback.

    Ctrl-C -> 130 and SIGTERM -> 143 (temporary files removed; also when the signal surfaced as a
    library's ImportError), OutputError -> its exit code, not enough memory -> 1, stdout closed from
    the start (`>&-`), closed early (`| head -1`) or full (/dev/full) -> 1. Each with one line on
    stderr that says what happened to the run's files. Paths stdout cannot encode print escaped.
    The SIGTERM handler exists only while main() runs: importing the chapter installs nothing;
    afterwards the guard (interrupts.py) answers signals with what was written.
    """

    def decorate(main):
        @functools.wraps(main)
        def guarded(*args, **kwargs):
            _last_write.update(folder=None, names=(), state=None)
            KEPT.clear()
            if sys.stdout is None:  # started with stdout closed (`>&-`): the report would vanish, exit 0 would lie
                return _stop(1, f"{prog}: error: standard output is closed, so the report could not be printed;"
                                " nothing was run")
            _readable_paths()
            restore, code = _install_sigterm(), None
            try:
                code = main(*args, **kwargs)
                sys.stdout.flush()  # the report reaches its pipe or file now, where a failure is still ours to say
            except OutputError as error:
                code = _stop(error.exit_code, f"{prog}: error: {error}")
            except SystemExit as error:  # argparse's exit: bad input (2) or --help (0)
                code = error.code if isinstance(error.code, int) else 1
                raise
            except BaseException as error:
                # Every failure of write_run() is an OutputError: an OSError such as print()'s, on a closed (EPIPE)
                # or full stream, comes from the one other thing a run writes to, stdout.
                if getattr(error, "errno", None) not in PRINTING or memory_problem(error) or signal_in(error):
                    code = _other(error, prog, memory_hint)
                else:
                    with contextlib.suppress(OSError, ValueError):  # Python's own flush at exit would fail again
                        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
                    code = _stop(1, f"{prog}: error: could not print the report ({_says(error)}: stdout closed or"
                                    f" full?); {_what_was_written()}")
            finally:
                restore()
                if interrupts.active():
                    interrupts.finished(_what_was_written(), code)
            return code

        return guarded

    return decorate


def _other(error: BaseException, prog: str, memory_hint: str) -> int:
    """A signal (also one that surfaced as a library's ImportError) or the system refusing memory: one line.
    Anything else is a bug and keeps its traceback."""
    number = signal_in(error)
    if number is not None:
        # An object the signal caught half-built (a Rerun stream, say) may complain when it is collected: "Exception
        # ignored in ... __del__" and a traceback. The process is ending on the signal; the one line below says all.
        sys.unraisablehook = lambda unraisable: None
        return _stop(interrupts.EXIT_CODES[number], f"{interrupts.WORDS[number]}: {_what_was_written()}")
    if isinstance(error, OSError) and error.errno in (errno.EMFILE, errno.ENFILE, errno.EAGAIN):
        return _stop(1, f"{prog}: error: the system refused to open or start more ({_says(error)}): raise the limit"
                        f" (ulimit -n, ulimit -u) or close other programs; {_what_was_written()}")
    if memory_problem(error):
        loading = next((_library(link) for link in interrupts.chain(error) if isinstance(link, ImportError)), None)
        if loading:  # a library loading late (numpy.random, rerun) under a memory limit: the run's size is not why
            return _stop(1, f"{prog}: error: not enough memory to load {loading} ({memory_problem(error)}): raise the"
                            f" memory limit (ulimit -v); {_what_was_written()}")
        return _stop(1, f"{prog}: error: not enough memory ({memory_problem(error)}): {memory_hint}, or raise the"
                        f" memory limit; {_what_was_written()}")
    raise error


def _library(error: ImportError) -> str:
    """The package an ImportError failed to load: numpy.random for .../site-packages/numpy/random/_common.so."""
    where = (error.path or str(error)).replace(os.sep, "/")
    if "-packages/" in where:
        return ".".join(where.split("-packages/", 1)[1].split(":")[0].split("/")[:-1]) or str(error.name)
    return str(error.name)


def _readable_paths() -> None:
    """Print paths stdout cannot encode (a non-ASCII folder under PYTHONIOENCODING=ascii, a non-UTF-8 byte
    in a name) as backslash escapes, instead of failing after the files were written."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, ValueError, OSError):
            stream.reconfigure(errors="backslashreplace")


def _what_was_written() -> str:
    folder, names, state = _last_write["folder"], _last_write["names"], _last_write["state"]
    said = "no file was written"
    if state == "written":
        said = f"{' and '.join(names)} in {_p(folder)} {'were' if len(names) > 1 else 'was'} written before that"
    elif state == "writing":
        said = _kept(folder, names)
    return "; ".join([said, *KEPT])


def _install_sigterm():
    """While main() runs, Ctrl-C raises KeyboardInterrupt and SIGTERM raises Terminated (each unless it was
    ignored), replacing the start-up guard of curriculum.common.interrupts; returns the undo.
    Raised inside a __del__ or a weakref callback, Python would print "Exception ignored" and run on: the
    unraisable hook ends the run there with the one line (nothing is half-written outside signals_held)."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None

    def terminate(number, frame):
        raise Terminated

    def swallowed(unraisable, previous=sys.unraisablehook):
        if signal_in(unraisable.exc_value) is None or not interrupts.active():  # (main() called by a test)
            return previous(unraisable)
        with contextlib.suppress(OSError, ValueError, AttributeError):
            sys.stdout.flush()
        os._exit(_other(unraisable.exc_value, "", ""))  # a signal: _other says it and gives its exit code

    wanted = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: terminate}
    before = {number: signal.getsignal(number) for number in wanted}
    for number, handler in wanted.items():
        if before[number] is not signal.SIG_IGN:
            signal.signal(number, handler)
    previous, sys.unraisablehook = sys.unraisablehook, swallowed

    def undo():
        for number, handler in before.items():
            signal.signal(number, handler if handler is not None else signal.SIG_DFL)
        if sys.unraisablehook is swallowed:  # (after a signal, _other's silent hook stays)
            sys.unraisablehook = previous

    return undo


def _stop(code: int, message: str) -> int:
    """Print the one line (a second Ctrl-C meanwhile is ignored) and return the exit code."""
    main = threading.current_thread() is threading.main_thread()
    held = {number: signal.signal(number, signal.SIG_IGN) for number in STOP_SIGNALS} if main else {}
    try:  # a newline first ends a progress line drawn in place
        print(("\n" if sys.stderr.isatty() else "") + message, file=sys.stderr, flush=True)
    except (OSError, ValueError, AttributeError):
        pass  # stderr is gone too: the exit code still says it
    for number, handler in held.items():
        signal.signal(number, handler)
    return code


def recording_problem(path: Path) -> str | None:
    """Why an exercise's recording cannot go to `path`, or None: it must be an .rrd file in a folder we can
    write, so that a slip such as `--rrd README.md` never overwrites something else."""
    if UNSHOWN.search(str(path)):
        return f"'{_p(path)}' holds a control character; name the file plainly"
    if path.suffix != ".rrd":
        return f"{_p(path)} does not end in .rrd"
    return folder_problem(path.parent, [path.name])
