"""The journal, `exercises/journal.jsonl`: every prediction and check, one JSON line each, append-only, under a
flock, synced. Every reader sees a line through `valid`, the one schema (a line that fails is unreadable). The header
carries VERSION and a random checkout id; each line a `chain` hash of the one before and its own fields: an edit
breaks it, a copy shares it. COURSE_JOURNAL=off records nothing; COURSE_JOURNAL=PATH moves it."""

import contextlib
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

fcntl = None if os.name == "nt" else __import__("fcntl")  # Windows: no flock; a record is still one append

DEFAULT, COURSE, SETTING = EXERCISES / "journal.jsonl", EXERCISES.parent, "COURSE_JOURNAL"
VERSION = 1  # the format: a journal of another version is named, never read as this one
MAX_BYTES = 4_000_000  # a whole course is a few hundred lines; past this a file is not a journal
MAX_LINE = 20_000  # bytes: a record's longest line, which bounds its every field too
NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)  # none on Windows
NOTE = "Written by the exercises, one line per prediction or check. Do not edit: an edit breaks the chain."
ANSWER, PARTS = "a name, a number, a list of names or a value per name", "{function: solved}"
FIELDS = {"journal": {"version": int, "note": str, "checkout": str},
          "predict": {"ex": int, "question": str, "answer": ANSWER, "typed": str, "because": str, "attempt": int},
          "replay": {"ex": int, "question": str, "prediction": str},
          "marks": {"ex": int, "prediction": str, "right": int, "items": int},
          "check": {"ex": int, "solved": bool, "parts": PARTS, "sha256": str, "own": bool}, "reset": {"ex": int},
          "asked": {"ex": int, "question": str}}  # a bare question, as earlier versions recorded it


def valid(record) -> bool:
    """The schema: a kind the exercises write, exactly its fields (with `chain`, and `t` but on the header), typed."""
    fields = FIELDS.get(record.get("kind")) if isinstance(record, dict) else None
    fields = fields and {"kind": str, "chain": str, **({} if record["kind"] == "journal" else {"t": str}), **fields}
    return bool(fields) and set(fields) - {"version"} <= set(record) <= set(fields) and all(  # no version: older
        _fits(v, fields[n]) for n, v in record.items())


def _fits(value, kind) -> bool:
    if kind in (str, int, bool):  # a str with no lone surrogate (nothing could print or write it)
        return type(value) is kind and (kind is not str or value == value.encode(errors="replace").decode())
    if kind == PARTS:
        return type(value) is dict and all(_fits(k, str) and type(v) is bool for k, v in value.items())
    if type(value) is list:
        return all(_fits(v, str) for v in value)
    if type(value) is dict:
        return all(_fits(k, str) and (_fits(v, str) or _fits(v, int)) for k, v in value.items())
    return _fits(value, str) or _fits(value, int)


@dataclass
class Journal:
    records: list = field(default_factory=list)  # the lines that are valid(), in order, the header first
    unreadable: int = 0  # lines that do not: cut off by a crash, edited into nonsense, or not of this format
    edited: int | None = None  # the first record (1 = the header) whose chain does not follow from the one before
    trouble: str | None = None  # why the file could not be read at all, if it could not

    def of(self, number: int, everything: bool = False) -> list:
        """Exercise `number`'s records, from its last reset on (everything: from the start, the grader's view)."""
        mine = [r for r in self.records if r.get("ex") == number]
        resets = [i for i, r in enumerate(mine) if r["kind"] == "reset"]
        return mine if everything or not resets else mine[resets[-1] + 1:]

    def notes(self) -> list:
        """What is wrong with it, in the words the board, the hand-in and the grader all use."""
        header = self.records[0] if self.records and self.records[0]["kind"] == "journal" else {"version": VERSION}
        version = header.get("version", "from before versions")
        return [n for n in [self.trouble, self.unreadable and f"{self.unreadable} unreadable line(s) (cut off by a"
                            " crash, edited, or not of this format), skipped",
                            self.edited and f"edited by hand: line {self.edited} does not follow from the one before",
                            version not in (None, VERSION) and f"journal format {version}; this course reads"
                            f" {VERSION}"] if n]


def read(data: bytes) -> Journal:
    book, before = Journal(), ""
    for line in data.split(b"\n"):
        if not line.strip():
            continue
        try:
            record = json.loads(line) if len(line) <= MAX_LINE else None
        except (ValueError, RecursionError):  # UnicodeDecodeError too; RecursionError: nested past any record
            record = None
        if not valid(record):
            book.unreadable += 1
            continue
        if book.edited is None and record["chain"] != chained(before, record):
            book.edited = len(book.records) + 1
        book.records.append(record)
        before = record["chain"]
    return book


def chained(before: str, record: dict) -> str:
    fields = json.dumps({k: v for k, v in record.items() if k != "chain"}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(f"{before}\n{fields}".encode()).hexdigest()[:16]


def where() -> Path | None:  # None: recording is off
    setting = os.environ.get(SETTING, "")
    return None if setting.strip().lower() == "off" else Path(setting or DEFAULT)


def shown(path: Path) -> str:  # escaped, from the checkout if inside it
    return cli.shown(path.relative_to(COURSE) if path.is_relative_to(COURSE) else path, 100)


def when(stamp) -> str:  # 'Tue 25 Nov 10:02'
    try:
        return datetime.datetime.fromisoformat(stamp).strftime("%a %d %b %H:%M")
    except (TypeError, ValueError):
        return "at a time that does not read"


@contextlib.contextmanager
def _opened(path: Path, flags: int):
    """(fd, contents) of the journal, flocked (shared to read), never through a link, never past MAX_BYTES, never
    another user's file in a sticky folder (like /tmp: root is not stopped by the kernel's protected_regular)."""
    if problem := outputs.planted(path):
        raise OSError(errno.EPERM, problem)
    fd = os.open(path, flags | os.O_NONBLOCK | NOFOLLOW, 0o644)  # O_NONBLOCK: a FIFO fails in pread, never hangs
    try:
        fcntl and fcntl.flock(fd, fcntl.LOCK_SH if flags == os.O_RDONLY else fcntl.LOCK_EX)  # released by close
        if os.fstat(fd).st_size > MAX_BYTES:
            raise OSError(errno.EFBIG, f"it is over {MAX_BYTES // 1_000_000} MB, more than a journal ever holds")
        yield fd, os.pread(fd, MAX_BYTES + 1, 0)
    finally:
        os.close(fd)


def load() -> Journal:
    path = where()
    if path is None or not os.path.lexists(path):
        return Journal()
    try:
        with _opened(path, os.O_RDONLY) as (_, data):
            return read(data)
    except OSError as error:
        return Journal(trouble=f"{shown(path)} cannot be read: {error.strerror}")


def append(make, kept: str | None = None) -> dict | None:
    """Add make(journal)'s record (None: nothing) with its time and chain, after the header if the journal is new.
    Synced when this returns it; None if recording is off or failed (said on stderr). `kept` joins what a signal's
    line says was kept (interrupts.KEPT) in the same instant."""
    path = where()
    if path is None:
        return None
    try:
        with _opened(path, os.O_RDWR | os.O_APPEND | os.O_CREAT) as (fd, data):
            book = read(data)
            record = make(book)
            if record is None:
                return None
            record = {**record, "t": datetime.datetime.now().astimezone().isoformat(timespec="seconds")}
            header = [] if book.records else [{"kind": "journal", "version": VERSION, "note": NOTE,
                                               "checkout": secrets.token_hex(16)}]
            before, lines = book.records[-1]["chain"] if book.records else "", []
            for item in [*header, record]:
                item["chain"] = before = chained(before, item)
                lines.append(json.dumps(item) + "\n")
            out = (("\n" if data and not data.endswith(b"\n") else "") + "".join(lines)).encode()  # a cut line apart
            with outputs.signals_held():  # Ctrl-C waits for the whole record, then is said
                os.write(fd, out)  # one write() under the lock; short only on a full disk: a cut line, skipped
                os.fsync(fd)
                interrupts.KEPT.extend([kept] if kept else [])
            return record
    except OSError as error:
        print(f"note: nothing was recorded in the journal ({shown(path)}: {error.strerror})", file=sys.stderr)
        return None


def checked(default: Path, path: Path, parts: dict) -> None:
    """The checker's record of one check, then its last line: the board's Next line once solved (saying so if the file
    is not the exercise's own, which the board reads), else the check again."""
    number = int(exercise.EXERCISE_FILE.fullmatch(default.name).group(1))
    digest = hashlib.sha256(own_file(Path(path)) or b"").hexdigest()
    solved, own = bool(parts) and all(parts.values()), Path(path).resolve() == Path(default).resolve()
    append(lambda book: {"kind": "check", "ex": number, "solved": solved, "parts": parts, "sha256": digest, "own": own})
    if interrupts.active():
        file = "" if Path(path) == Path(default) else f" {cli.shown(path, 100)}"
        if solved and not own:
            print(f"(This file is not exercises/{default.name}, the one the board and the grade read.)")
        print(next_line(number) if solved else f"Next: python -m exercises.check_ex{number}{file}")


def next_line(number: int | None, book=None, found=None) -> str:
    """The board's Next line, which every run ends with: the first exercise not done (no journal: after `number`)."""
    book, found = book or load(), found or exercise.exercises(EXERCISES)
    blind = number is not None and not book.records  # recording off or failing: the board knows nothing
    waiting = [(n, module, kind) for n, module, kind in found
               if (n > number if blind else not status(book, n, module, kind)[1])]
    if waiting:
        return exercise.announce(EXERCISES, *waiting[0])
    last = "that was the last one. python -m exercises shows what is left; then read" if blind else "read"
    return f"Next: {last} {exercise.READ_ON}."


def status(book, number: int, module: str, kind: str) -> tuple[str, bool]:
    """(the board's words, done): the first prediction (the grade's), or the last check."""
    since = book.of(number)
    if kind == "code":
        checks = [r for r in since if r["kind"] == "check" and r["own"]]  # not a scratch file's
        if not checks:
            return "not tried", False
        last = checks[-1]
        if last["solved"]:
            same = last["sha256"] == hashlib.sha256(own_file(EXERCISES / f"{module}.py") or b"").hexdigest()
            return f"solved {when(last['t'])}" + ("" if same else ", but the file has changed since"), same
        parts = ", ".join(f"{cli.shown(name)} {'solved' if ok else 'not yet'}" for name, ok in last["parts"].items())
        return f"checked {when(last['t'])}: {parts or 'it does not run yet'}", False
    every = book.of(number, everything=True)
    predictions = [r for r in every if r["kind"] == "predict"]
    if any(r["kind"] == "predict" for r in since):  # done since the last reset; the grade counts the first ever
        first = predictions[0]
        marks = next((r for r in every if r["kind"] == "marks" and r["prediction"] == first["chain"]), None)
        tries = sum(r["question"] == first["question"] for r in predictions)
        question = f" ({cli.shown(first['question'])})" if first["question"] else ""
        return (f"predicted {when(first['t'])}{question}"
                + (f": {marks['right']} of {marks['items']} right" if marks else ": not measured yet")
                + (f", {tries} attempts" if tries > 1 else "")
                + ("; the grade counts this first one, from before your reset" if first not in since else ""), True)
    return "not tried", False


def own_file(path: Path) -> bytes | None:
    """A regular file's first MAX_BYTES + 1 bytes, never through a link; None if it is not one."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | NOFOLLOW)
    except OSError:
        return None
    try:
        return os.pread(fd, MAX_BYTES + 1, 0) if stat.S_ISREG(os.fstat(fd).st_mode) else None
    finally:
        os.close(fd)
