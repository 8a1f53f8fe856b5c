"""The journal: every prediction and check a student makes, kept in the checkout, append-only.

    from curriculum.common import journal

    journal.append(make)      # make(Journal) -> the record to add (or None), under the lock; synced on return
    journal.load()            # Journal: the records of this checkout's journal, read without the lock
    journal.read(data)        # Journal from bytes (a submission's): its records, the lines cut off, where an edit is

The predict helper (`predict.ask`, `predict.verdict`) and the checker harness (`student_code.main`) write
it; no exercise does. It is `exercises/journal.jsonl`, which git does not ignore, so a push carries it.
One JSON object a line. The first line carries a checkout id, random, made once; every line carries
`chain`, a hash of the line before it and of its own fields, so a line edited by hand breaks the chain,
and a journal copied into another checkout shares its lines with the original. Anyone can recompute the
hashes: the journal says what the exercises saw, for learning, not proctoring.

Writers take turns (flock on the journal itself); a record is one write() at the end of the file, synced
before the exercise goes on, so two terminals at once lose and repeat nothing. A line cut off by a crash
is skipped when read, and counted. The file is opened without following a symbolic link. A record holds
the exercise, the question, the answer as parsed and as typed, the reason given, times and hashes: no user
name, host name, path or code.

COURSE_JOURNAL=off records nothing; COURSE_JOURNAL=PATH keeps the journal at PATH (the tests do). A journal
that cannot be written costs one line on stderr, and the exercise runs on.
"""

import datetime
import errno
import hashlib
import json
import os
import secrets
import stat
import sys
from dataclasses import dataclass, field
from pathlib import Path

from curriculum.common import cli, exercise, interrupts, outputs
from curriculum.common.exercise import EXERCISES

try:
    import fcntl
except ImportError:  # Windows: no flock; each record is still a single append
    fcntl = None

DEFAULT = EXERCISES / "journal.jsonl"
COURSE = EXERCISES.parent  # the chapter's checkout
SETTING = "COURSE_JOURNAL"
MAX_BYTES = 4_000_000  # a whole course is a few hundred lines; past this a submission is not a journal
NOFOLLOW = outputs.NOFOLLOW  # never through a symbolic link
NOTE = "Written by the exercises, one line per prediction or check. Do not edit: an edit breaks the chain."


@dataclass
class Journal:
    records: list = field(default_factory=list)  # the lines that read as records, the header first
    cut: int = 0  # lines skipped: cut off by a crash, or not a record
    edited: int | None = None  # the first line (1 = the header) whose chain does not follow from the one before
    problem: str | None = None  # why the journal could not be read, if it could not

    def of(self, number: int, everything: bool = False) -> list:
        """Exercise `number`'s records, from its last reset on (everything: from the start, the grader's view)."""
        mine = [r for r in self.records if r.get("ex") == number]
        resets = [i for i, r in enumerate(mine) if r.get("kind") == "reset"]
        return mine if everything or not resets else mine[resets[-1] + 1:]


def where() -> Path | None:
    """The journal's path, or None when recording is off."""
    setting = os.environ.get(SETTING, "")
    if setting.strip().lower() == "off":
        return None
    return Path(setting) if setting else DEFAULT


def shown(path: Path) -> str:
    """The journal's path as a message shows it: from the checkout if it is inside, escaped (cli.shown)."""
    return cli.shown(path.relative_to(COURSE) if path.is_relative_to(COURSE) else path, 100)


def when(stamp) -> str:
    """A record's time as people read it: 'Tue 25 Nov 10:02'."""
    try:
        return datetime.datetime.fromisoformat(stamp).strftime("%a %d %b %H:%M")
    except (TypeError, ValueError):
        return "at a time that does not read"


def chained(before: str, record: dict) -> str:
    fields = json.dumps({k: v for k, v in record.items() if k != "chain"}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(f"{before}\n{fields}".encode()).hexdigest()[:16]


def read(data: bytes) -> Journal:
    journal, before = Journal(), ""
    for line in data.split(b"\n"):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except ValueError:  # UnicodeDecodeError too
            record = None
        if not isinstance(record, dict):
            journal.cut += 1
            continue
        if journal.edited is None and record.get("chain") != chained(before, record):
            journal.edited = len(journal.records) + 1
        journal.records.append(record)
        before = str(record.get("chain"))
    return journal


def load() -> Journal:
    """This checkout's journal as it is now (empty if there is none, it cannot be read, or recording is off)."""
    path = where()
    if path is None or not os.path.lexists(path):
        return Journal()
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | NOFOLLOW)
        try:
            if fcntl:
                fcntl.flock(fd, fcntl.LOCK_SH)  # never half a writer's line
            return read(_contents(fd))
        finally:
            os.close(fd)
    except OSError as error:
        return Journal(problem=f"{shown(path)} cannot be read: {_why(error)}")


def append(make, kept: str | None = None) -> dict | None:
    """Add the record make(journal) returns (None: nothing to add), with its time and chain, and the header first
    if the journal is new. On disk (synced) when this returns it; None if recording is off or failed. `kept`
    joins what every one-line message of this run says was kept (outputs.KEPT), in the same instant: a Ctrl-C
    waits for the record to be whole and said."""
    path = where()
    if path is None:
        return None
    try:
        fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT | NOFOLLOW, 0o644)
    except OSError as error:
        return _cannot(path, error)
    try:
        if fcntl:
            fcntl.flock(fd, fcntl.LOCK_EX)  # writers take turns; released when fd closes
        data = _contents(fd)
        journal = read(data)
        record = make(journal)
        if record is None:
            return None
        record = {**record, "t": datetime.datetime.now().astimezone().isoformat(timespec="seconds")}
        header = [] if journal.records else [{"kind": "journal", "note": NOTE, "checkout": secrets.token_hex(16)}]
        before, lines = str(journal.records[-1].get("chain")) if journal.records else "", []
        for item in [*header, record]:
            item["chain"] = before = chained(before, item)
            lines.append(json.dumps(item) + "\n")
        cut_off = "\n" if data and not data.endswith(b"\n") else ""  # a line a crash cut off stays a line apart
        out = (cut_off + "".join(lines)).encode()
        with outputs.signals_held():  # the same hold as a run's own files: Ctrl-C waits, then is said
            while out:  # one write() in practice; the lock keeps any remainder next to it
                out = out[os.write(fd, out):]
            os.fsync(fd)
            if header:
                _sync_folder(path.parent)  # the new file's name is on disk too, not only its bytes
            if kept:
                outputs.KEPT.append(kept)
        return record
    except OSError as error:
        return _cannot(path, error)
    finally:
        os.close(fd)


def _contents(fd: int) -> bytes:
    """The whole file (at most MAX_BYTES), if it is a regular file: never a FIFO or a device left in its place."""
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode):
        raise OSError(errno.EINVAL, "it is not a regular file")
    if info.st_size > MAX_BYTES:
        raise OSError(errno.EFBIG, f"it is over {MAX_BYTES // 1_000_000} MB, more than a journal ever holds")
    os.lseek(fd, 0, os.SEEK_SET)  # (appends still go to the end: O_APPEND)
    chunks = []
    while chunk := os.read(fd, 1 << 20):
        chunks.append(chunk)
    return b"".join(chunks)


def _sync_folder(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _cannot(path: Path, error: OSError) -> None:
    print(f"note: this run is not recorded in the journal ({shown(path)}: {_why(error)}); the exercise runs on as"
          " usual", file=sys.stderr)
    return None


def _why(error: OSError) -> str:
    return "it is a symbolic link, which is never followed" if error.errno == errno.ELOOP else str(error.strerror)


def checked(default: Path, path: Path, parts: dict) -> None:
    """The checker harness's record of one check (solved or not, which parts, the file's hash, whether it is the
    exercise's own file or another one), then its run's last line. `default` is the exercise's own file, which
    says which exercise this is."""
    number = int(exercise.EXERCISE_FILE.fullmatch(default.name).group(1))
    digest = hashlib.sha256(own_file(Path(path)) or b"").hexdigest()
    append(lambda book: {"kind": "check", "ex": number, "solved": bool(parts) and all(parts.values()),
                         "parts": parts, "sha256": digest, "own": Path(path).resolve() == Path(default).resolve()})
    if interrupts.active():  # solved: on to the next exercise; not yet: this checker again, on the same file
        file = "" if Path(path) == Path(default) else f" {cli.shown(path, 100)}"
        again = f"python -m exercises.check_ex{number}{file}"
        print(exercise.next_line(EXERCISES, number) if all(parts.values()) and parts else f"Next: {again}")


def own_file(path: Path) -> bytes | None:
    """A file of the checkout, never through a symbolic link; None if it is not there."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | NOFOLLOW)
    except OSError:
        return None
    with os.fdopen(fd, "rb") as file:
        return file.read() if stat.S_ISREG(os.fstat(fd).st_mode) else None
