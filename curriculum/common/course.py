"""The course flow, the same in every chapter: where a student is, starting over, handing in.

    python -m exercises                      # the board: every exercise, its status and when, the next command
    python -m exercises --reset N            # start exercise N over; its records stay, marked as reset
    python -m exercises --handin             # outputs/handin.zip: the journal and the code exercises' files
"""

import argparse
import io
import os
import sys
import tempfile
import zipfile
from pathlib import Path

from curriculum.common import exercise, journal
from curriculum.common.cli import OneLineParser, shown
from curriculum.common.exercise import EXERCISES
from curriculum.common.outputs import folder_problem, one_line_failures, planted, write_atomic


@one_line_failures("python -m exercises")
def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if any(a.split("=")[0] == "--grade" for a in argv):  # the teacher's command: nothing else here imports it
        from curriculum.grading import main as grading

        return grading(argv)
    parser = OneLineParser(prog="python -m exercises", description=__doc__.split("\n\n")[0],
                           epilog="Teachers: docs/TEACHING.md, and python -m exercises --grade . --help",
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    what = parser.add_mutually_exclusive_group()
    what.add_argument("--reset", type=int, metavar="N", help="start exercise N over")
    what.add_argument("--handin", action="store_true", help="write the archive to hand in")
    parser.add_argument("--out", type=Path, help="--handin's archive (default outputs/handin.zip)")
    args = parser.parse_args(argv)
    found = exercise.exercises(EXERCISES)
    if args.out and not args.handin:
        parser.error("--out goes with --handin")
    if args.reset is not None:
        return reset(parser, found, args.reset)
    if args.handin:
        out = args.out or Path("outputs/handin.zip")
        problem = folder_problem(out.parent, [out.name]) or planted(out)
        if problem:
            parser.error(f"--out: {problem}")
        return handin(found, out)
    return board(found)


def board(found) -> int:
    book, titles = journal.load(), exercise.titles(EXERCISES)
    rows = [(number, titles.get(number, module), *journal.status(book, number, module, kind))
            for number, module, kind in found]
    print(f"{sum(done for *_, done in rows)} of {len(rows)} exercises done.")
    width = max(len(title) for _, title, *_ in rows)
    for number, title, said, _ in rows:
        print(f"{number:>3}. {title:<{width}}  {said}")
    off = journal.where() is None and f"recording is off ({journal.SETTING}=off): nothing is kept"
    for note in filter(None, [off, *book.notes()]):
        print(f"Note: the journal: {shown(note, 300)}; a teacher's grader flags it too." if note is not off else
              f"Note: {note}.")
    print(journal.next_line(None, book, found))
    return 0


def reset(parser, found, number: int) -> int:
    kinds = {n: (module, kind) for n, module, kind in found}
    if number not in kinds:
        parser.error(f"--reset: there is no exercise {number}; they are {min(kinds)} to {max(kinds)}")
    if journal.where() is None:
        print(f"Recording is off ({journal.SETTING}=off): there is nothing to start over. Nothing was changed.")
        return 0
    module, kind = kinds[number]
    mine, current = EXERCISES / f"{module}.py", journal.own_file(EXERCISES / f"{module}.py")
    stub = (EXERCISES / "support" / "pristine" / f"{module}.py").read_bytes() if kind == "code" else current
    changed = current != stub
    if changed:
        keep = "Yours is kept beside it." if current else "It is not a file of yours (a link?): nothing is kept."
        print(f"Put the untouched stub back in exercises/{mine.name}? {keep} [y/N] ", end="", flush=True)
        if sys.stdin.readline().strip().lower() not in ("y", "yes"):
            print("Nothing was changed.")
            return 0
    if journal.append(lambda book: {"kind": "reset", "ex": number}) is None:
        print(f"Exercise {number} was not started over: nothing was changed.")
        return 1
    if changed:
        kept = None
        if current:
            fd, kept = tempfile.mkstemp(prefix=f"{module}.before-reset-", suffix=".py", dir=EXERCISES)
            with os.fdopen(fd, "wb") as file:
                file.write(current)
        write_atomic(mine, stub)
        print(f"exercises/{mine.name} is the untouched stub again"
              + (f"; yours is exercises/{shown(Path(kept).name)}." if kept else "."))
    print(f"Exercise {number} starts over: the board shows it as not tried. Its records stay in the journal,"
          " marked as reset, and a grade still counts your first prediction.")
    return 0


def handin(found, out: Path) -> int:
    """One zip of the journal and the code exercises' files as they are (the grader refuses one over MAX_BYTES)."""
    book, files = journal.load(), {f"exercises/{m}.py": EXERCISES / f"{m}.py" for _, m, k in found if k == "code"}
    members = {name: data for name, path in {"exercises/journal.jsonl": journal.where(), **files}.items()
               if path and (data := journal.own_file(path)) is not None}
    archive = io.BytesIO()
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as bundle:
        for name, data in members.items():
            bundle.writestr(zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0)), data)
    write_atomic(out, archive.getvalue())
    print(f"{shown(out, 100)}: {', '.join(members) or 'nothing'} ({len(book.records)} journal lines). Hand this file"
          " in; nothing was sent anywhere.")
    off = journal.where() is None and f"recording is off ({journal.SETTING}=off): there is no journal"
    empty = not off and not book.records and not book.trouble and "there is no journal yet: run an exercise first"
    for note in filter(None, [off, empty, *book.notes()]):
        print(f"Note: {shown(note, 300)}.")
    return 0
