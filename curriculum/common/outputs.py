"""Writing a run's files so that they are never lost, mixed up or redirected, and a run that ends in one line.

    from curriculum.common.outputs import folder_problem, write_run, one_line_failures, content_id

- `folder_problem(out, names)` says, before any simulation, why `out` cannot take a run's files: it tries
  (creates a file with no name where `out`, or its deepest existing folder, is) instead of trusting
  os.access, which says yes to root for /sys and read-only folders. It creates no folder: runs started
  together into a missing folder must not see it appear and vanish; write_run() makes it and keeps it.
- `write_run(out, {"engine.rrd": data, "metrics.json": text})` replaces a run's files together: each goes
  to a new file with an unguessable name in `out` (created exclusively, never through a symlink),
  flushed to disk; only when all are complete are they renamed into place, and the folder is synced.
  Writers into one folder take turns (a lock on the folder itself, so no lock file is left in it).
  On any failure the temporary files are removed and the previous files are as they were.
- `@one_line_failures("engine.py")` on a main() turns Ctrl-C into exit 130, SIGTERM into 143, a write
  failure into one line and exit 1 (2 for bad input), and a closed or full stdout into one line.
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
import threading
from pathlib import Path

from curriculum.common import interrupts
from curriculum.common.interrupts import memory_problem, signal_in

try:
    import fcntl
except ImportError:  # Windows: no flock; each file is still replaced atomically, by path
    fcntl = None

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# Where the OS lets us (Linux, macOS), every name is opened relative to the folder we locked, so a
# folder swapped for a symlink mid-write cannot redirect us. Elsewhere the same steps go by path.
BY_FOLDER = (fcntl is not None and hasattr(os, "O_DIRECTORY")
             and {os.open, os.rename, os.unlink, os.stat} <= os.supports_dir_fd)
NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


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
    """Argument type for an output folder: any path except the empty one (which would mean the current folder)."""
    if not text.strip():
        import argparse

        raise argparse.ArgumentTypeError("the output folder is empty; name one, e.g. outputs/run1")
    return Path(text)


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
        longest = max(out.parts, key=len)
        if len(os.fsencode(longest)) > _name_max(out):
            return (f"{out} cannot be created: a name in it is {len(longest)} characters, longer than the file "
                    f"system allows ({_name_max(out)})")
        return _path_too_long(out, _path_max(out))
    if error.errno == errno.ELOOP:
        return f"{out} cannot be used: it goes through a symbolic link that loops"
    for path in [out, *out.parents]:
        if os.path.islink(path) and not os.path.exists(path):
            return f"{out} cannot be used: {path} is a symbolic link to {os.readlink(path)}, which does not exist"
        if os.path.exists(path) and not os.path.isdir(path):
            what = "a file" if stat.S_ISREG(os.stat(path).st_mode) else "not a folder"
            return f"{out} cannot hold files: {path} is {what}"
    if error.errno == errno.ENOENT:  # "no such file" although the folders exist: /proc and its kind
        existing = next(path for path in [out, *out.parents] if os.path.isdir(path))
        return f"cannot create a file in {out}: {existing} exists but does not let files or folders be created in it"
    return f"cannot create a file in {out}: {_says(error)}"


def _name_max(out: Path) -> int:
    return _pathconf(out, "PC_NAME_MAX", 255)


def _path_max(out: Path) -> int:
    return _pathconf(out, "PC_PATH_MAX", 4096)


def _pathconf(out: Path, name: str, default: int) -> int:
    for path in [out, *out.parents]:
        with contextlib.suppress(OSError, ValueError):
            return os.pathconf(path, name)
    return default


# --- the check before the run ---


def folder_problem(out: Path, names=()) -> str | None:
    """Why `out` cannot take files called `names`, or None if it can. Takes milliseconds; creates nothing.

    It tries instead of guessing (os.access says yes to root for /sys and read-only folders): in
    `out`, or where `out` does not exist yet in the deepest folder that does, it creates a file that
    has no name (O_TMPFILE: it vanishes when closed, so nothing is left even in an append-only
    folder), or where the file system cannot, an empty file with an unguessable name that it
    removes again. No folder is created: runs started together into a missing folder must not find
    it appearing and disappearing under them; write_run() creates what is missing and keeps it.
    A folder, an immutable file or a file of someone else's sticky folder in the place of one of
    `names` is refused as well, since the run could not replace it.
    """
    out = Path(out)  # (an empty --out is refused by folder_arg: Path("") would be the current folder)
    try:
        missing = _first_missing(out)
        existing = missing[0].parent if missing else out
        if not os.path.isdir(existing):
            os.stat(existing)  # a symlink that loops or leads nowhere raises here, a file below
            raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(existing))
        too_long = _too_long(out, missing)
        if too_long:
            return too_long
        _probe(existing)
        if not missing:
            for problem in [_unreplaceable(out, "the folder"), *(_target_problem(out, name) for name in names)]:
                if problem:
                    return problem
    except OSError as error:
        return _describe(out, error)
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


def _too_long(out: Path, missing: list) -> str | None:
    """Whether a missing folder's name, or the whole path, is longer than the file system takes."""
    if not missing:
        return None
    name_max = _name_max(missing[0].parent)
    longest = max((folder.name for folder in missing), key=len)
    if len(os.fsencode(longest)) > name_max:
        return (f"{out} cannot be created: a name in it is {len(longest)} characters, longer than the file "
                f"system allows ({name_max})")
    path_max = _path_max(missing[0].parent)
    if len(os.fsencode(os.path.abspath(out))) + 1 + len("metrics.json.0123456789abcdef.tmp") >= path_max:
        return _path_too_long(out, path_max)
    return None


def _path_too_long(out: Path, path_max: int) -> str:
    return (f"{str(out)[:60]}... cannot be used: the path is {len(os.fsencode(os.path.abspath(out))):,} bytes long, "
            f"more than the system takes in one path ({path_max:,}), though no name in it is too long")


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
            return f"{path} is {word}, so {verb}; lift it with chattr -{'i' if flag == FS_IMMUTABLE_FL else 'a'}" \
                   " or choose another output folder"
    return None


def _target_problem(folder: Path, name: str, dir_fd: int | None = None) -> str | None:
    """Why the file `name` in `folder` cannot be replaced by a rename, or None."""
    try:
        target = os.lstat(**_at(folder, dir_fd, name))
    except FileNotFoundError:
        return None
    if stat.S_ISDIR(target.st_mode):
        return f"{folder / name} is a folder; move it away or choose another output folder"
    here = os.stat(folder if dir_fd is None else dir_fd)
    euid = os.geteuid() if hasattr(os, "geteuid") else 0
    if here.st_mode & stat.S_ISVTX and euid != 0 and euid not in (here.st_uid, target.st_uid):
        return (f"{folder / name} belongs to another user in a sticky folder (like /tmp), so it cannot be "
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
    folder = Path(folder)
    names = tuple(files)
    _last_write.update(folder=folder, names=names, state="writing")
    created = []
    try:
        for _ in range(100):  # a folder another run made and removed again (its write failed) is made anew
            try:
                _make_folders(folder, created)
                with _locked(folder) as dir_fd:
                    _replace_together(folder, dir_fd, {name: _as_bytes(data) for name, data in files.items()})
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
        raise OutputError(f"{folder} keeps disappearing; {_kept(folder, names)}") from None
    except OSError as error:
        raise OutputError(f"{_describe(folder, error)}; {_kept(folder, names)}") from None
    finally:
        if _last_write["state"] != "written":
            for path in reversed(created):
                _remove_if_empty(path)  # only if empty: a concurrent writer's files stay


def _remove_if_empty(folder: Path) -> None:
    """rmdir `folder` while holding its lock, so that a run waiting for it finds it gone (see _locked)."""
    with contextlib.suppress(OSError, _FolderGone), _locked(folder):
        os.rmdir(folder)


def write_atomic(path: Path, data: bytes | str) -> None:
    """Replace one file atomically and durably (write_run with a single file)."""
    path = Path(path)
    write_run(path.parent, {path.name: data})


def read_run(folder: Path, names) -> dict:
    """{name: bytes} of a run's files, read while no writer is between its renames (a shared lock)."""
    with _locked(Path(folder), shared=True) as dir_fd:
        files = {}
        for name in names:
            fd = os.open(**_at(Path(folder), dir_fd, name), flags=os.O_RDONLY | NOFOLLOW)
            with os.fdopen(fd, "rb") as file:
                files[name] = file.read()
        return files


def _as_bytes(data: bytes | str) -> bytes:
    return data.encode() if isinstance(data, str) else bytes(data)


def _kept(folder: Path, names) -> str:
    if len(names) == 1:
        return f"{folder / names[0]} was left as it was"
    return f"{' and '.join(names)} in {folder} were left as they were"


class _FolderGone(Exception):
    """The folder vanished between creating it and opening it."""


@contextlib.contextmanager
def _locked(folder: Path, shared: bool = False):
    """Hold flock on the folder's own descriptor: writers take turns, and no lock file is left behind.

    Waiting for the lock can be interrupted (Ctrl-C, SIGTERM). Where flock is not supported
    (Windows, some network file systems) the write goes ahead unlocked: each file is still atomic.
    Yields the folder's descriptor, or None where names are used by path (see BY_FOLDER).
    """
    if not BY_FOLDER:
        if not os.path.isdir(folder):
            if shared:
                raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), str(folder))
            raise _FolderGone
        yield None
        return
    try:
        dir_fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except FileNotFoundError:
        if shared:
            raise
        raise _FolderGone from None
    try:
        try:
            fcntl.flock(dir_fd, fcntl.LOCK_SH if shared else fcntl.LOCK_EX)
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
            with _signals_deferred():  # the name is recorded before anything can interrupt us
                temp = f".{name}.{secrets.token_hex(8)}.tmp"
                fd = os.open(**_at(folder, dir_fd, temp), flags=os.O_WRONLY | os.O_CREAT | os.O_EXCL | NOFOLLOW,
                             mode=0o600)
                temps[name] = temp
            try:
                _write_all(fd, data)
                if hasattr(os, "fchmod"):
                    os.fchmod(fd, 0o666 & ~_umask())  # private while written; the usual mode once complete
                os.fsync(fd)
            except OSError as error:
                raise OutputError(f"cannot write {folder / name}: {_says(error)}; "
                                  f"{_kept(folder, list(files))}") from None
            finally:
                os.close(fd)
        with _signals_deferred():  # a Ctrl-C here waits until both renames are done
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
                        f"only part of the run was written: {' and '.join(renamed)} in {folder} "
                        f"{'is' if len(renamed) == 1 else 'are'} new, but {name} could not be replaced "
                        f"({_says(error)}), so {' and '.join(old)} {'is' if len(old) == 1 else 'are'} "
                        "from an earlier run") from None
                renamed.append(name)
            _last_write["state"] = "written"  # before a held Ctrl-C is delivered, so its message is true
            try:
                _sync_folder(dir_fd)
            except OSError as error:
                raise OutputError(f"{' and '.join(files)} in {folder} were replaced, but the folder could not be "
                                  f"synced to disk ({_says(error)})") from None
    finally:
        with _signals_deferred():
            for temp in temps.values():
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(**_at(folder, dir_fd, temp))


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view[: 1 << 24]):]


def _sync_folder(dir_fd: int | None) -> None:
    if dir_fd is None:
        return  # by path (Windows): a folder cannot be opened to sync
    try:
        os.fsync(dir_fd)  # the renames themselves reach the disk
    except OSError as error:
        if error.errno not in (errno.EINVAL, errno.EBADF):  # file systems that cannot sync a folder
            raise


def _umask() -> int:
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def _signals_deferred():
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
            restore = _install_sigterm()
            code = None
            try:
                code = main(*args, **kwargs)
                sys.stdout.flush()  # the report reaches its pipe or file now, where a failure is still ours to say
                return code
            except OutputError as error:
                code = _stop(error.exit_code, f"{prog}: error: {error}")
                return code
            except OSError as error:
                if not _printing_failed(error) or memory_problem(error) or signal_in(error):
                    code = _other(error, prog, memory_hint)
                    return code
                _silence_stdout()
                code = _stop(1, f"{prog}: error: could not print the report ({_says(error)}: stdout closed or full?); "
                                f"{_what_was_written()}")
                return code
            except SystemExit as error:  # argparse's exit: bad input (2) or --help (0)
                code = error.code if isinstance(error.code, int) else 1
                raise
            except BaseException as error:
                code = _other(error, prog, memory_hint)
                return code
            finally:
                restore()
                if interrupts.active():
                    interrupts.finished(_what_was_written(), code)

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
    if number == signal.SIGINT:
        return _stop(130, f"interrupted: {_what_was_written()}")
    if number == signal.SIGTERM:
        return _stop(143, f"terminated: {_what_was_written()}")
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
        listed = " and ".join(names)
        said = f"{listed} in {folder} {'were' if len(names) > 1 else 'was'} written before that"
    elif state == "writing":
        said = _kept(folder, names)
    return "; ".join([said, *KEPT])


def _install_sigterm():
    """While main() runs, Ctrl-C raises KeyboardInterrupt and SIGTERM raises Terminated (each unless it was
    ignored), replacing the start-up guard of curriculum.common.interrupts; returns the undo."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None

    def terminate(number, frame):
        raise Terminated

    wanted = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: terminate}
    before = {number: signal.getsignal(number) for number in wanted}
    for number, handler in wanted.items():
        if before[number] is not signal.SIG_IGN:
            signal.signal(number, handler)

    def undo():
        for number, handler in before.items():
            signal.signal(number, handler if handler is not None else signal.SIG_DFL)

    return undo


def _stop(code: int, message: str) -> int:
    """Print the one line (a second Ctrl-C meanwhile is ignored) and return the exit code."""
    held = {}
    if threading.current_thread() is threading.main_thread():
        held = {number: signal.signal(number, signal.SIG_IGN) for number in STOP_SIGNALS}
    try:
        if sys.stderr.isatty():
            message = "\n" + message  # ends a progress line drawn in place
        print(message, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass  # stderr is gone too: the exit code still says it
    finally:
        for number, handler in held.items():
            signal.signal(number, handler)
    return code


def _printing_failed(error: OSError) -> bool:
    """Whether `error` is what printing to a closed (EPIPE) or full stream raises.

    Every failure of write_run() arrives as an OutputError, so an OSError like this one that
    reaches main() came from print(): the one other thing a run writes to.
    """
    return error.errno in (errno.EPIPE, errno.ENOSPC, errno.EIO, errno.EBADF, errno.EDQUOT, errno.EFBIG)


def _silence_stdout() -> None:
    """Point stdout at /dev/null, so Python's own flush at exit does not print a second error."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


def recording_problem(path: Path) -> str | None:
    """Why an exercise's recording cannot go to `path`, or None: it must be an .rrd file in a folder we can
    write, so that a slip such as `--rrd README.md` never overwrites something else."""
    if path.suffix != ".rrd":
        return f"{path} does not end in .rrd"
    if path.exists() and not path.is_file():
        return f"{path} is not a file"
    return folder_problem(path.parent, [path.name])
