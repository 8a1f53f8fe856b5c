"""Reading hand-ins, bounded whatever is uploaded: an archive over MAX_UPLOAD, a member over journal.MAX_BYTES or
a tar unpacking past MAX_UNPACKED is refused with a flag; a truncated or unrecognised archive is a submission with a
flag, never dropped. Nothing is extracted; no link is followed, in a folder or an archive."""

import bz2
import csv
import functools
import gzip
import io
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
FILES = {"csv": ["grades.csv", "gradebook.csv", "summary.txt"], "gradescope": ["results.json"],  # the grader's,
         "classroom": ["classroom.json"]}  # for each --format: a folder holding one is no student's


class Refused(Exception):
    """Over a limit: its message is the flag."""


def roster_id(name: str) -> str:
    """A student's id from a file name: its archive suffix off, Unicode NFC (macOS writes NFD), bad bytes U+FFFD."""
    name = next((name[:-len(suffix)] for suffix in ARCHIVES if name.lower().endswith(suffix)), name)
    return unicodedata.normalize("NFC", name.encode("utf-8", "surrogateescape").decode("utf-8", "replace"))


def roster(path: Path) -> list:
    """The ids of a roster file: one a line, or a CSV's first column under an optional header; duplicates refused."""
    with open(path, encoding="utf-8-sig", newline="") as file:
        ids = [unicodedata.normalize("NFC", row[0].strip()) for row in csv.reader(file) if row and row[0].strip()]
    ids = ids[1:] if ids and ids[0].lower() in ("id", "student", "login", "username", "email") else ids
    if twice := sorted({i for i in ids if ids.count(i) > 1}):
        raise ValueError(f"--roster lists {', '.join(map(shown, twice))} more than once")
    return ids


def submissions(path: Path, wanted: list, out: Path) -> tuple[dict, list]:
    """({id: {name: bytes or None, "problem": flag}}, [(entry, why skipped)]): PATH itself if it is one submission,
    else each folder or archive in it. Two with one id are an error naming both; the grader's output is no student."""
    if not path.is_dir():
        if not path.name.lower().endswith(ARCHIVES):
            os.stat(path)  # FileNotFoundError says so
            raise ValueError(f"{shown(path, 100)} is neither a folder nor an archive (.zip, .tar, .tar.gz ...)")
        return {roster_id(path.name): _read(path, wanted)}, []
    if any(os.path.lexists(path / place) for place in ["exercises", *wanted]):
        return {roster_id(path.resolve().name): _read(path, wanted)}, []
    found, skipped, named = {}, [], {}
    for entry in sorted(os.scandir(path), key=lambda entry: entry.name):
        why = ("a link, never followed" if entry.is_symlink() else
               "the grader's own output" if os.path.realpath(entry.path) == os.path.realpath(out) or
               entry.is_dir() and {n for names in FILES.values() for n in names} & {*os.listdir(entry.path)} else
               None if entry.is_dir() or entry.name.lower().endswith(ARCHIVES) else "not a folder or an archive")
        if why:
            skipped.append((entry.name, why))
            continue
        student = roster_id(entry.name)
        if student in named:
            raise ValueError(f"{shown(named[student])} and {shown(entry.name)} are both {shown(student)}'s: keep one")
        named[student], found[student] = entry.name, _read(Path(entry.path), wanted)
    return found, skipped


def _read(path: Path, wanted: list) -> dict:
    """{name: bytes or None} for each wanted name at exercises/NAME or NAME, under the folder all files share if
    they share one (GitHub's downloads have one top folder)."""
    try:
        if not path.is_dir() and path.stat().st_size > MAX_UPLOAD:
            raise Refused(f"{shown(path.name)} is over {MAX_UPLOAD // 1_000_000} MB: refused")
        members, folders = {}, []
        entries = _folder(path) if path.is_dir() else _zip(path) if zipfile.is_zipfile(path) else _tar(path)
        for name, size, content in entries:  # (name, size, a function giving its content)
            folders.append(os.path.dirname(name.lstrip("/")))  # an absolute name: no top folder
            if name.rpartition("/")[2] in wanted:
                if size > journal.MAX_BYTES:
                    raise Refused(f"{shown(name)} is over {journal.MAX_BYTES // 1_000_000} MB, more than a hand-in"
                                  " holds: refused")
                members[name] = content()
        top = os.path.commonpath(folders or [""])
        return {want: members.get(os.path.join(top, "exercises", want), members.get(os.path.join(top, want)))
                for want in wanted} | {"problem": None}
    except Exception as error:  # noqa: BLE001 (one hand-in's damage, whatever its kind, is its flag; the class goes on)
        why = f"{shown(path.name)} could not be read (truncated, or not a zip or a tar: {type(error).__name__})"
        return dict.fromkeys(wanted) | {"problem": str(error) if isinstance(error, Refused) else why}


def _folder(path: Path):
    """(name, size, its content) of each file to exercises/NAME in a folder (under one top folder too); no link."""
    for top, folders, files in os.walk(path):  # a link to a folder is never entered
        folders[:] = [f for f in folders if len(Path(top, f).relative_to(path).parts) <= 2]  # top/exercises/NAME
        for file in (Path(top, name) for name in files):
            if file.is_file() and not file.is_symlink():  # no FIFO, device or link
                yield str(file.relative_to(path)), file.stat().st_size, file.read_bytes


def _zip(path: Path):
    """The same for a zip, whose reader stops at a member's declared size."""
    with zipfile.ZipFile(path) as bundle:
        for info in bundle.infolist():
            if not info.is_dir() and not stat.S_ISLNK(info.external_attr >> 16):
                yield info.filename, info.file_size, functools.partial(bundle.read, info)


def _tar(path: Path):
    """The same for a tar, compressed as its name says or not, unpacked in memory up to MAX_UNPACKED bytes: a header
    (a pax one too) that declares more than that finds the end of the data, never more memory."""
    opener = {".gz": gzip.open, ".tgz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}.get(path.suffix.lower(), open)
    with opener(path, "rb") as raw:
        data = raw.read(MAX_UNPACKED + 1)
    if len(data) > MAX_UNPACKED:
        raise Refused(f"it unpacks to more than {MAX_UNPACKED // 1_000_000} MB: refused")
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:") as bundle:
        for member in bundle:
            if member.isfile():  # no links, devices or folders
                yield member.name, member.size, lambda member=member: bundle.extractfile(member).read()
