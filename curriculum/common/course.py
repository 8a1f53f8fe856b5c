"""The course flow, the same in every chapter: where a student is, starting over, handing in, a teacher's grades.

    python -m exercises                      # the board: every exercise, its status and when, the next command
    python -m exercises --reset N            # start exercise N over; its records stay, marked as reset
    python -m exercises --handin             # outputs/handin.zip: the journal and the code exercises' files
    python -m exercises --grade PATH         # a teacher's: outputs/grades.csv, a row per student and exercise
    python -m exercises --grade PATH --format gradescope   # or classroom: one submission's results file

A chapter's `exercises/__main__.py` is its first line (`start(__file__)`) and `course.main()`. Everything
here is read, not kept by hand: the exercises from their files (curriculum.common.exercise), their titles
from exercises/README.md, what the student did from the journal (curriculum.common.journal). The board
loads nothing heavy and shows no answer the student has not seen.

The grader reads one submission (a checkout, a folder, or an archive; Gradescope runs one per container)
or a folder of them, each named by the student's roster id. It reads only `exercises/journal.jsonl` and
each code exercise's file (or the same names at the top, as uploaded one by one): an archive is read in
memory, never extracted, and a symbolic link is never followed. A code exercise is checked again by its
own checker, the student's file running in the checker's isolated child; the journal's "solved" is shown,
never trusted. A point is a prediction committed before its measurement, right or wrong, or a code
exercise solved. The journal is for learning, not proctoring: see FORGED.
"""

import argparse
import csv
import errno
import hashlib
import io
import json
import os
import stat
import sys
import tarfile
import tempfile
import zipfile
import zlib
from pathlib import Path

from curriculum.common import exercise, journal
from curriculum.common.cli import OneLineParser
from curriculum.common.exercise import EXERCISES
from curriculum.common.outputs import OutputError, folder_problem, one_line_failures, write_atomic

POINT = ("A point is a prediction committed before its measurement, right or wrong, or a code exercise solved"
         " (checked again here).")
FORGED = ("The journal is for learning, not proctoring: anyone can forge one. A journal edited by hand or copied"
          " from another checkout is flagged when its chain breaks or its lines turn up in another submission;"
          " a careful forgery is not.")
JOURNAL = "journal.jsonl"
FORMATS = {"csv": "grades.csv", "gradescope": "results.json", "classroom": "classroom.json"}


@one_line_failures("python -m exercises")
def main(argv=None) -> int:
    parser = OneLineParser(prog="python -m exercises", description=__doc__.split("\n\n")[0],
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    what = parser.add_mutually_exclusive_group()
    what.add_argument("--reset", type=int, metavar="N", help="start exercise N over")
    what.add_argument("--handin", action="store_true", help="write the archive to hand in")
    what.add_argument("--grade", type=Path, metavar="PATH", help="a submission, or a folder of them")
    parser.add_argument("--format", choices=FORMATS, default="csv", help="--grade's output (default csv)")
    parser.add_argument("--out", type=Path, help="--handin's archive (default outputs/handin.zip) or --grade's"
                        " folder (default outputs)")
    args = parser.parse_args(argv)
    found = exercise.exercises(EXERCISES)
    if args.format != "csv" and args.grade is None:
        parser.error("--format goes with --grade")
    out = args.out or Path("outputs/handin.zip" if args.handin else "outputs")
    if args.handin or args.grade:
        problem = folder_problem(out.parent, [out.name]) if args.handin else folder_problem(out, [FORMATS[args.format]])
        if problem:
            parser.error(f"--out: {problem}")
    if args.reset is not None:
        return reset(parser, found, args.reset)
    if args.handin:
        return handin(found, out)
    if args.grade:
        return grade(parser, found, args.grade, args.format, out)
    return board(found)


# --- the student's: the board, a reset, the hand-in ---


def board(found) -> int:
    book, titles = journal.load(), exercise.titles(EXERCISES)
    rows = [(number, titles.get(number, module), *status(book, number, module, kind)) for number, module, kind in found]
    print(f"{sum(done for *_, done, _ in rows)} of {len(rows)} exercises done.")
    width = max(len(title) for _, title, *_ in rows)
    for number, title, said, _, _ in rows:
        print(f"{number:>3}. {title:<{width}}  {said}")
    notes = [f"recording is off ({journal.SETTING}=off): nothing is kept" if journal.where() is None else None,
             book.problem, book.cut and f"{book.cut} line(s) of the journal are not whole records (cut off by a"
             " crash?): skipped", book.edited and f"the journal was edited by hand at line {book.edited}: a"
             " teacher's grader flags that"]
    for note in filter(None, notes):
        print(f"Note: {note}.")
    waiting = [command for *_, done, command in rows if not done]
    print(f"Next: {waiting[0]}" if waiting else f"Next: read {exercise.READ_ON}.")
    return 0


def status(book, number: int, module: str, kind: str) -> tuple[str, bool, str]:
    """(what the journal says of an exercise since its last reset, whether it is done, its next command)."""
    mine = book.of(number)
    if kind == "code":
        checks = [r for r in mine if r.get("kind") == "check" and r.get("own", True)]  # not a scratch file's
        command = exercise.command(module, kind)
        if not checks:
            return "not tried", False, command
        last, now = checks[-1], hashlib.sha256(journal.own_file(EXERCISES / f"{module}.py") or b"").hexdigest()
        if last.get("solved"):
            same = last.get("sha256") == now
            return f"solved {journal.when(last.get('t'))}" + ("" if same else ", but the file has changed since"), \
                same, command
        parts = ", ".join(f"{name} {'solved' if ok else 'not yet'}" for name, ok in last.get("parts", {}).items())
        return f"checked {journal.when(last.get('t'))}: {parts or 'it does not run yet'}", False, command
    predictions = [r for r in mine if r.get("kind") == "predict"]
    if predictions:
        first = predictions[0]
        marks = _marks(mine, first)
        tries = sum(r.get("question") == first.get("question") for r in predictions)
        question = f" ({first['question']})" if first.get("question") else ""
        return (f"predicted {journal.when(first.get('t'))}{question}"
                + (f": {marks['right']} of {marks['items']} right" if marks else ": not measured yet")
                + (f", {tries} attempts" if tries > 1 else ""), True, "")
    asked = next((r for r in mine if r.get("kind") == "asked"), None)
    if asked:
        return f"asked {journal.when(asked.get('t'))}", False, f"python -m exercises.{module} --predict ANSWER"
    return "not tried", False, exercise.command(module, kind)


def reset(parser, found, number: int) -> int:
    kinds = {n: (module, kind) for n, module, kind in found}
    if number not in kinds:
        parser.error(f"--reset: there is no exercise {number}; they are {min(kinds)} to {max(kinds)}")
    if journal.where() is None:
        print(f"Recording is off ({journal.SETTING}=off): there is nothing to start over.")
        return 0
    module, kind = kinds[number]
    mine, stub = EXERCISES / f"{module}.py", EXERCISES / "support" / "pristine" / f"{module}.py"
    current = journal.own_file(mine)
    changed = kind == "code" and current != stub.read_bytes()
    if changed:
        kept = next(mine.with_name(f"{module}.before-reset-{i}.py") for i in range(1, 10_000)
                    if not os.path.lexists(mine.with_name(f"{module}.before-reset-{i}.py")))
        print(f"Put the untouched stub back in exercises/{mine.name}? Yours is kept as exercises/{kept.name}."
              " [y/N] ", end="", flush=True)
        if sys.stdin.readline().strip().lower() not in ("y", "yes"):
            print("Nothing was changed.")
            return 0
    if journal.append(lambda book: {"kind": "reset", "ex": number}) is None:
        return 1  # the journal said why, in one line; nothing was changed
    if changed:
        if current is not None:
            write_atomic(kept, current)
        write_atomic(mine, stub.read_bytes())
        print(f"exercises/{mine.name} is the untouched stub again; yours is exercises/{kept.name}.")
    print(f"Exercise {number} starts over: the board shows it as not tried. Its records stay in the journal,"
          " marked as reset, and a grade still reads your first prediction.")
    return 0


def handin(found, out: Path) -> int:
    """One zip of the journal and every code exercise's file, as they sit in the checkout; the same files give the
    same bytes."""
    members = {f"exercises/{JOURNAL}": journal.own_file(journal.where()) if journal.where() else None}
    members |= {f"exercises/{module}.py": journal.own_file(EXERCISES / f"{module}.py") for _, module, kind in found
                if kind == "code"}
    archive = io.BytesIO()
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as bundle:
        for name, data in members.items():
            if data is not None:
                bundle.writestr(zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0)), data)
    write_atomic(out, archive.getvalue())
    records = len(journal.read(members[f"exercises/{JOURNAL}"] or b"").records)
    print(f"{out}: {', '.join(name for name, data in members.items() if data is not None) or 'nothing'}"
          f" ({records} journal lines). Hand this file in; nothing was sent anywhere.")
    if not records:
        print("Note: there is no journal yet" + (f" (recording is off: {journal.SETTING}=off)" if journal.where()
                                                 is None else ": run an exercise first") + ".")
    return 0


def _marks(records: list, prediction: dict) -> dict | None:
    return next((r for r in records if r.get("kind") == "marks" and r.get("prediction") == prediction.get("chain")),
                None)


# --- the teacher's: reading submissions, grading them, writing the grades ---


def grade(parser, found, path: Path, form: str, out: Path) -> int:
    wanted = [JOURNAL, *(f"{module}.py" for _, module, kind in found if kind == "code")]
    try:
        submissions = _submissions(path, wanted)
    except OSError as error:
        parser.error(f"--grade: {path}: {error.strerror}")
    if not submissions:
        parser.error(f"--grade: {path} holds no submission (a checkout, a folder or an archive)")
    if form != "csv" and len(submissions) != 1:
        parser.error(f"--grade: --format {form} reads one submission, and {path} holds {len(submissions)}")
    titles, owners = exercise.titles(EXERCISES), {}
    graded = {}
    for name, files in submissions.items():
        book = journal.read(files[JOURNAL]) if files[JOURNAL] is not None else None
        graded[name] = {"book": book, "rows": [_row(name, book, files, titles, *item) for item in found]}
        for record in book.records if book else []:
            owners.setdefault(str(record.get("chain")), set()).add(name)
    for name, result in graded.items():
        book = result["book"]
        shared = sorted(set().union(*(owners[str(r.get("chain"))] for r in book.records if r.get("chain"))) - {name}) \
            if book else []
        flags = [submissions[name].get("problem"), "no journal" if book is None else None,
                 book and book.edited and f"edited by hand: line {book.edited} does not follow from the one before",
                 shared and f"shares journal lines with {', '.join(shared)}: one is a copy",
                 book and book.cut and f"{book.cut} line(s) that are not whole records, skipped"]
        result["flags"] = "; ".join(filter(None, flags))
    write_atomic(out / FORMATS[form], _written(form, graded))
    print(f"{len(graded)} submission(s), {len(found)} points each: {out / FORMATS[form]}")
    for name, result in graded.items():
        print(f"  {name:<24}{sum(row['points'] for row in result['rows']):>3}  {result['flags']}")
    print(POINT)
    print(FORGED)
    return 0


def _row(student: str, book, files: dict, titles: dict, number: int, module: str, kind: str) -> dict:
    """One student's line for one exercise, from the whole journal (resets included) and the checker."""
    mine = book.of(number, everything=True) if book else []
    row = {"student": student, "exercise": number, "title": titles.get(number, module), "question": "",
           "first_prediction": "", "first_time": "", "attempts": 0,
           "resets": sum(r.get("kind") == "reset" for r in mine), "right": "", "items": "", "reason": "",
           "recorded": "", "solved": "", "points": 0, "detail": ""}
    if kind == "code":
        checks = [r for r in mine if r.get("kind") == "check" and r.get("own", True)]  # not a scratch file's
        solved, detail = _check_again(module, files[f"{module}.py"])
        row.update(attempts=len(checks), solved="yes" if solved else "no", points=int(solved), detail=detail)
        if checks:
            row["recorded"] = f"{'solved' if checks[-1].get('solved') else 'not solved'} {checks[-1].get('t')}"
        return row
    predictions = [r for r in mine if r.get("kind") == "predict"]
    if predictions:
        first = predictions[0]
        predictions = [r for r in predictions if r.get("question") == first.get("question")]  # its attempts
        marks = _marks(mine, first) or {}
        answer = first.get("answer")
        said = (", ".join(f"{k}={v}" for k, v in answer.items()) if isinstance(answer, dict) else
                ", ".join(map(str, answer)) or "none" if isinstance(answer, list) else str(answer))
        row.update(question=first.get("question", ""), first_prediction=said, first_time=first.get("t", ""),
                   attempts=len(predictions), right=marks.get("right", ""), items=marks.get("items", ""),
                   reason=first.get("because", ""), points=1)
        row["detail"] = (f"first prediction {first.get('t')}: {said}"
                         + (f" ({marks['right']} of {marks['items']} right)" if marks else ", not measured")
                         + f"; {len(predictions)} attempt(s)" + (f"; because {row['reason']}" if row["reason"] else ""))
    else:
        row["detail"] = "no prediction recorded"
    return row


def _check_again(module: str, data: bytes | None) -> tuple[bool, str]:
    """(solved, what the checker said) for a submitted file, run by the chapter's own checker in its child."""
    if data is None:
        return False, f"no {module}.py handed in"
    if data == (EXERCISES / "support" / "pristine" / f"{module}.py").read_bytes():
        return False, "the untouched stub"
    import importlib

    from curriculum.common import student_code

    checker = importlib.import_module(f"exercises.check_ex{exercise.EXERCISE_FILE.match(module + '.py')[1]}")
    with tempfile.TemporaryDirectory() as scratch:
        path = Path(scratch) / f"{module}.py"
        path.write_bytes(data)
        problem = student_code.source_problem(path)
        if problem:
            return False, problem[1].replace(str(path), f"{module}.py")
        try:
            parts, messages, _ = checker.check(path)
        except student_code.ScratchProblem as error:
            raise OutputError(str(error), exit_code=2) from None
    solved = all(parts.values())
    return solved, "solved, checked again here" if solved else " ".join(messages)


def _written(form: str, graded: dict) -> str:
    if form == "csv":
        text = io.StringIO()
        columns = [*next(iter(graded.values()))["rows"][0], "flags"]
        table = csv.DictWriter(text, columns, lineterminator="\n")
        table.writeheader()
        for result in graded.values():
            for row in result["rows"]:
                table.writerow({k: _cell(v) for k, v in {**row, "flags": result["flags"]}.items()})
        return text.getvalue()
    (result,) = graded.values()
    rows, total = result["rows"], sum(row["points"] for row in result["rows"])
    if form == "gradescope":  # gradescope-autograders.readthedocs.io/en/latest/specs/
        return json.dumps({"score": total, "output": "\n".join(filter(None, [POINT, FORGED, result["flags"]])),
                           "tests": [{"name": f"Exercise {row['exercise']}: {row['title']}",
                                      "number": str(row["exercise"]), "score": row["points"], "max_score": 1,
                                      "status": "passed" if row["points"] else "failed", "output": row["detail"],
                                      "visibility": "visible"} for row in rows]}, indent=1)
    # GitHub Classroom's runner result (classroom-resources/autograding-command-grader), for its grading reporter
    return json.dumps({"version": 1, "status": "pass" if total == len(rows) else "fail", "max_score": len(rows),
                       "tests": [{"name": f"Exercise {row['exercise']}: {row['title']}",
                                  "status": "pass" if row["points"] else "fail", "score": row["points"],
                                  "message": "; ".join(filter(None, [row["detail"], result["flags"]])),
                                  "test_code": "", "filename": "", "line_no": 0, "duration": 0} for row in rows]},
                      indent=1)


def _cell(value):
    """A CSV cell that a spreadsheet shows as text: never one that starts a formula (=, +, -, @, tab, return)."""
    text = str(value)
    return f"'{text}" if text[:1] in ("=", "+", "-", "@", "\t", "\r") else value


def _submissions(path: Path, wanted: list) -> dict:
    """{roster id: {name: bytes or None}}: PATH itself if it is one submission, else each folder or archive in it."""
    if not path.is_dir() and not _archive(path):
        os.stat(path)  # FileNotFoundError says so
        raise OSError(errno.EINVAL, "it is neither a folder nor an archive (zip or tar)")
    if not path.is_dir() or _holds(path, wanted):
        return {_roster_id(path.resolve()): _read(path, wanted)}
    return {_roster_id(Path(entry.path)): _read(Path(entry.path), wanted)
            for entry in sorted(os.scandir(path), key=lambda entry: entry.name)
            if not entry.name.startswith(".") and not entry.is_symlink() and (entry.is_dir() or _archive(entry.path))}


def _holds(folder: Path, wanted: list) -> bool:
    return any(os.path.lexists(folder / place) for place in ["exercises", *wanted])


def _roster_id(path: Path) -> str:
    name = path.name
    for suffix in (".tar.gz", ".tgz", ".tar", ".zip"):
        name = name.removesuffix(suffix)
    return name


def _archive(path) -> bool:
    return os.path.isfile(path) and (zipfile.is_zipfile(path) or tarfile.is_tarfile(path))


def _read(path: Path, wanted: list) -> dict:
    """{name: bytes or None} for each wanted name at exercises/NAME or NAME, in a folder or an archive (under one
    top folder too, as GitHub's downloads are): read, never extracted, and never through a symbolic link. An
    archive that does not read gives None for each, and says why under "problem"."""
    try:
        return _read_files(path, wanted)
    except (OSError, EOFError, RuntimeError, zipfile.BadZipFile, tarfile.TarError, zlib.error) as error:
        return {name: None for name in wanted} | {"problem": f"{path.name} could not be read ({error})"}


def _read_files(path: Path, wanted: list) -> dict:
    limit = max(journal.MAX_BYTES, 1_000_000)
    if path.is_dir():
        root = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            folders = [e for e in os.scandir(root) if e.is_dir(follow_symlinks=False)]
            if not _holds(path, wanted) and len(folders) == 1:
                return _read_files(path / folders[0].name, wanted)
            found = {name: _beneath(root, f"exercises/{name}", limit) for name in wanted}
            return {name: _beneath(root, name, limit) if data is None else data for name, data in found.items()}
        finally:
            os.close(root)
    members = {}
    if zipfile.is_zipfile(path):
        with zipfile.ZipFile(path) as bundle:
            for info in bundle.infolist():
                if not info.is_dir() and not stat.S_ISLNK(info.external_attr >> 16):
                    members[info.filename] = lambda info=info, bundle=bundle: bundle.open(info).read(limit + 1)
            return _pick(members, wanted, limit)
    with tarfile.open(path) as bundle:
        for member in bundle.getmembers():
            if member.isfile():  # no links, devices or folders
                members[member.name] = lambda member=member, bundle=bundle: bundle.extractfile(member).read(limit + 1)
        return _pick(members, wanted, limit)


def _pick(members: dict, wanted: list, limit: int) -> dict:
    names = {name: name.split("/") for name in members if not name.startswith("/") and ".." not in name.split("/")}
    tops = {parts[0] for parts in names.values() if len(parts) > 1}
    top = [tops.pop()] if len(tops) == 1 and all(len(parts) > 1 for parts in names.values()) else []
    found = {}
    for name in wanted:
        place = next((n for n, parts in names.items() if parts in ([*top, "exercises", name], [*top, name])), None)
        data = members[place]() if place else None
        found[name] = data if data is None or len(data) <= limit else None
    return found


def _beneath(root: int, relative: str, limit: int) -> bytes | None:
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
            data = opened.read(limit + 1) if stat.S_ISREG(os.fstat(file).st_mode) else None
        return data if data is None or len(data) <= limit else None
    except OSError:
        return None
    finally:
        os.close(fd)
