"""Reading hand-ins: which entries of a class folder are submissions, and the few files each one holds.

Bounded whatever a student uploads: an archive over MAX_UPLOAD bytes, a member declaring more than
journal.MAX_BYTES, or a tar that unpacks past MAX_UNPACKED (a pax header included) is refused with a flag;
a truncated or unrecognised archive is a submission with a flag, never dropped. Nothing is extracted to disk
and no link is followed, in a folder or an archive.
"""

import bz2
import csv
import gzip
import lzma
import os
import stat
import tarfile
import unicodedata
import zipfile
from pathlib import Path

from curriculum.common import journal
from curriculum.common.cli import shown

ARCHIVES = (".zip", ".tar.gz", ".tgz", ".tar.bz2", ".tar.xz", ".tar")
MAX_UPLOAD, MAX_UNPACKED = 64_000_000, 32_000_000
OURS = {"grades.csv", "gradebook.csv", "summary.txt", "results.json", "classroom.json"}  # the grader's own output


class Refused(Exception):
    """An archive over a limit: its message is the flag."""


def roster_id(name: str) -> str:
    """A student's id from a file name: its archive suffix off, Unicode NFC (macOS writes NFD), bad bytes shown as
    U+FFFD."""
    for suffix in ARCHIVES:
        if name.lower().endswith(suffix):
            name = name[: -len(suffix)]
            break
    return unicodedata.normalize("NFC", name.encode("utf-8", "surrogateescape").decode("utf-8", "replace"))


def roster(path: Path) -> list:
    """The ids of a roster file: one a line, or a CSV's first column under an optional header; duplicates refused."""
    with open(path, encoding="utf-8-sig", newline="") as file:
        ids = [unicodedata.normalize("NFC", row[0].strip()) for row in csv.reader(file) if row and row[0].strip()]
    if ids and ids[0].lower() in ("id", "student", "login", "username", "sis login id", "email"):
        ids = ids[1:]
    twice = sorted({i for i in ids if ids.count(i) > 1})
    if twice:
        raise ValueError(f"--roster lists {', '.join(map(shown, twice))} more than once")
    return ids


def submissions(path: Path, wanted: list, out: Path) -> tuple[dict, list]:
    """({id: {name: bytes or None, "problem": flag or None}}, [(entry, why skipped)]) for PATH: itself if it is one
    submission (a checkout, a folder of the files, an archive), else each folder or archive in it. Two entries
    with one id are an error naming both; the grader's own output folder is never a student."""
    if not path.is_dir():
        if not path.name.lower().endswith(ARCHIVES):
            os.stat(path)  # FileNotFoundError says so
            raise ValueError(f"{shown(path, 100)} is neither a folder nor an archive (.zip, .tar, .tar.gz ...)")
        return {roster_id(path.name): _read(path, wanted)}, []
    if _holds(path, wanted):
        return {roster_id(path.resolve().name): _read(path, wanted)}, []
    found, skipped, named = {}, [], {}
    for entry in sorted(os.scandir(path), key=lambda entry: entry.name):
        why = ("a link, never followed" if entry.is_symlink() else
               "the grader's own output" if os.path.realpath(entry.path) == os.path.realpath(out) or
               entry.is_dir() and OURS & set(os.listdir(entry.path)) else
               None if entry.is_dir() or entry.name.lower().endswith(ARCHIVES) else "not a folder or an archive")
        if why:
            skipped.append((entry.name, why))
            continue
        student = roster_id(entry.name)
        if student in named:
            raise ValueError(f"{shown(named[student])} and {shown(entry.name)} are both {shown(student)}'s: keep one")
        named[student], found[student] = entry.name, _read(Path(entry.path), wanted)
    return found, skipped


def _holds(folder: Path, wanted: list) -> bool:
    return any(os.path.lexists(folder / place) for place in ["exercises", *wanted])


def _read(path: Path, wanted: list) -> dict:
    """{name: bytes or None} for each wanted name at exercises/NAME or NAME (under one top folder too, as GitHub's
    downloads are), and "problem": why it could not be read, or None."""
    try:
        if path.is_dir():
            return _folder(path, wanted) | {"problem": None}
        if path.stat().st_size > MAX_UPLOAD:
            raise Refused(f"{shown(path.name)} is over {MAX_UPLOAD // 1_000_000} MB: refused")
        return _pick(*(_zip if zipfile.is_zipfile(path) else _tar)(path, wanted), wanted) | {"problem": None}
    except Refused as refused:
        return dict.fromkeys(wanted) | {"problem": str(refused)}
    except Exception as error:  # noqa: BLE001 (one hand-in's damage, whatever its kind, is its flag; the class goes on)
        return dict.fromkeys(wanted) | {"problem": f"{shown(path.name)} could not be read (truncated, or not a zip"
                                                   f" or a tar: {type(error).__name__})"}


def _zip(path: Path, wanted: list) -> tuple[dict, list]:
    members, names = {}, []
    with zipfile.ZipFile(path) as bundle:
        for info in bundle.infolist():
            if info.is_dir() or stat.S_ISLNK(info.external_attr >> 16):
                continue
            names.append(info.filename)
            if info.filename.rpartition("/")[2] in wanted:
                _bounded(info.filename, info.file_size)
                with bundle.open(info) as member:
                    members[info.filename] = _bounded(info.filename, len(data := member.read(journal.MAX_BYTES + 1)),
                                                      data)
    return members, names


def _tar(path: Path, wanted: list) -> tuple[dict, list]:
    """Streamed once through the decompressor its first bytes name, capped at MAX_UNPACKED."""
    raw = open(path, "rb")  # noqa: SIM115 (closed below with the stream)
    start = raw.read(6)
    raw.seek(0)
    opener = next((o for magic, o in ((b"\x1f\x8b", gzip.GzipFile), (b"BZh", bz2.BZ2File),
                                      (b"\xfd7zXZ", lzma.LZMAFile)) if start.startswith(magic)), None)
    stream = _Capped(opener(fileobj=raw) if opener else raw)
    members, names = {}, []
    try:
        with tarfile.open(fileobj=stream, mode="r|") as bundle:
            for member in bundle:
                if member.isfile():  # no links, devices or folders
                    names.append(member.name)
                    if member.name.rpartition("/")[2] in wanted:
                        _bounded(member.name, member.size)
                        members[member.name] = bundle.extractfile(member).read()
    finally:
        raw.close()
    return members, names


class _Capped:
    """A file that refuses to give more than MAX_UNPACKED bytes in all, before it reads them."""

    def __init__(self, file):
        self.file, self.given = file, 0

    def read(self, size=-1):
        if size < 0 or self.given + size > MAX_UNPACKED:
            raise Refused(f"it unpacks to more than {MAX_UNPACKED // 1_000_000} MB (or a header says it would):"
                          " refused")
        data = self.file.read(size)
        self.given += len(data)
        return data


def _bounded(name: str, size: int, data: bytes = b""):
    if size > journal.MAX_BYTES:
        raise Refused(f"{shown(name)} is over {journal.MAX_BYTES // 1_000_000} MB, more than any hand-in holds:"
                      " refused")
    return data


def _pick(members: dict, names: list, wanted: list) -> dict:
    parts = {name: name.split("/") for name in names if not name.startswith("/") and ".." not in name.split("/")}
    tops = {p[0] for p in parts.values() if len(p) > 1}
    top = [tops.pop()] if len(tops) == 1 and all(len(p) > 1 for p in parts.values()) else []
    return {want: next((members[n] for n, p in parts.items() if n in members and p in
                        ([*top, "exercises", want], [*top, want])), None) for want in wanted}


def _folder(path: Path, wanted: list) -> dict:
    root = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | journal.NOFOLLOW)
    try:
        folders = [e for e in os.scandir(root) if e.is_dir(follow_symlinks=False)]
        if not _holds(path, wanted) and len(folders) == 1:
            return _folder(path / folders[0].name, wanted)
        return {name: _beneath(root, f"exercises/{name}") or _beneath(root, name) for name in wanted}
    finally:
        os.close(root)


def _beneath(root: int, relative: str) -> bytes | None:
    """The file at `relative` below the folder `root`, opened one name at a time without following a link."""
    *folders, name = relative.split("/")
    fd = os.dup(root)
    try:
        for folder in folders:
            fd, previous = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | journal.NOFOLLOW,
                                   dir_fd=fd), fd
            os.close(previous)
        file = os.open(name, os.O_RDONLY | os.O_NONBLOCK | journal.NOFOLLOW, dir_fd=fd)
        with os.fdopen(file, "rb") as opened:
            data = opened.read(journal.MAX_BYTES + 1) if stat.S_ISREG(os.fstat(file).st_mode) else None
        return _bounded(relative, len(data), data) if data is not None else None
    except OSError:
        return None
    finally:
        os.close(fd)
