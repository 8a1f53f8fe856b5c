"""The teacher's grader: from hand-ins to a gradebook. The student's path never imports it.

    python -m exercises --grade CLASS [--roster ids.txt] [--due 2026-12-01T23:59+01:00]   # a folder of hand-ins
    python -m exercises --grade ONE --format gradescope|classroom --out FOLDER      # one submission, one platform

CLASS holds a submission per student (the --handin zip, a zip, a tar, a checkout, a folder) named by the student's
id; anything else is named and skipped. docs/TEACHING.md says what is read, how, and what each flag means.
"""

import argparse
import csv
import datetime
import io
import json
import re
from pathlib import Path

from curriculum.common import exercise
from curriculum.common.cli import OneLineParser, shown
from curriculum.common.outputs import folder_problem, write_atomic
from curriculum.grading import read, score

FORMULA = ("=", "+", "-", "@")


def main(argv) -> int:
    parser = OneLineParser(prog="python -m exercises", description=__doc__.split("\n\n")[0],
                           formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("\n\n", 2)[2])
    parser.add_argument("--grade", type=str, metavar="PATH", required=True, help="a submission, or a folder of them")
    parser.add_argument("--format", choices=read.FILES, default="csv", help="--grade's output (default csv)")
    parser.add_argument("--out", type=Path, default=Path("outputs"), help="--grade's folder (default outputs)")
    parser.add_argument("--roster", type=Path, metavar="FILE", help="the class's ids, one a line (a CSV's first"
                        " column): each id gets a row, and an id with no submission is listed")
    parser.add_argument("--due", type=datetime.datetime.fromisoformat, metavar="TIME", help="ISO 8601, e.g."
                        " 2026-12-01T23:59+01:00 (UTC if no offset): a first prediction after it is flagged late")
    args = parser.parse_args(argv)
    args.due = args.due and (args.due if args.due.tzinfo else args.due.replace(tzinfo=datetime.UTC))
    if not args.grade.strip():
        parser.error("--grade: the path is empty: give the folder or archive to grade")
    if problem := folder_problem(args.out, read.FILES[args.format]):
        parser.error(f"--out: {problem}")
    found = exercise.exercises(exercise.EXERCISES)
    wanted = ["journal.jsonl", *(f"{module}.py" for _, module, kind in found if kind == "code")]
    try:
        roster = read.roster(args.roster) if args.roster else None
        submissions, skipped = read.submissions(Path(args.grade), wanted, args.out)
    except (OSError, ValueError) as error:
        parser.error(f"--grade: {error.strerror if isinstance(error, OSError) else error}")
    if args.format != "csv":  # one platform run: a bad upload still gets its results file, with 0 and why
        upload = ", ".join(sorted([*submissions, *(name for name, _ in skipped)])) or "nothing"
        graded = score.grade(submissions, found, args.due) if len(submissions) == 1 else {"upload": score.missing(
            "upload", found, f"Upload the one zip `python -m exercises --handin` writes (outputs/handin.zip); this"
                             f" upload holds {upload}.")}
        files, summary = {read.FILES[args.format][0]: platform(args.format, graded, len(found))}, ""
    else:
        if not submissions and not roster:
            parser.error(f"--grade: {shown(args.grade, 100)} holds no submission (a folder, a zip or a tar)")
        graded = score.grade(submissions, found, args.due)
        for name in sorted(set(roster or []) - set(graded)):
            graded[name] = score.missing(name, found)
        for name in sorted(set(graded) - set(roster or graded)):
            graded[name]["flags"].append("not on the roster")
        summary = score.summary(graded, found)
        files = dict(zip(read.FILES["csv"], (grades(graded), gradebook(graded, len(found)), summary), strict=True))
    for name, data in files.items():
        write_atomic(args.out / name, data)
    print(f"{len(graded)} student(s), {len(found)} points each: {', '.join(shown(args.out / f, 100) for f in files)}")
    for name, result in graded.items():
        print(f"  {shown(name, 30):<30}{result['points']:>3}  {shown('; '.join(result['flags']), 500)}")
    for name, why in skipped:
        print(f"  skipped {shown(name, 60)}: {why}")
    print(score.POINT, summary, sep="\n", end="", flush=True)
    return 0


# --- what it writes: every CSV cell spreadsheet-safe ---


def cell(value):
    """As text in any spreadsheet: controls (line ends too) a space, lone surrogates U+FFFD, a formula start '-led."""
    text = re.sub(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]+", " ", str(value)).encode("utf-8", "replace").decode()
    return f"'{text}" if text.lstrip().startswith(FORMULA) else text


def _table(header: list, rows: list) -> str:  # RFC 4180's line end (a field holding one is quoted anyway)
    text = io.StringIO()
    csv.writer(text, lineterminator="\r\n").writerows([[cell(value) for value in row] for row in [header, *rows]])
    return text.getvalue()


def grades(graded: dict) -> str:
    """The detail: a row per student and exercise."""
    header = [*next(iter(graded.values()))["rows"][0]][:-1] + ["flags"]
    return _table(header, [[*list(row.values())[:-1], "; ".join(result["flags"])]
                           for result in graded.values() for row in result["rows"]])


def gradebook(graded: dict, possible: int) -> str:
    """One row per student, as Canvas's and Moodle's gradebook imports take it (docs/TEACHING.md)."""
    return _table(["Student", "SIS Login ID", "Section", "Chapter 3.3 exercises", "Points Possible", "Flags"],
                  [[name, name, "", result["points"], possible, "; ".join(result["flags"])]
                   for name, result in sorted(graded.items())])


def platform(form: str, graded: dict, possible: int) -> str:
    """Gradescope's results.json (autograder_samples' docs/specs.md: every text "text", so nothing a student names is
    HTML) or Classroom's runner result (autograding-grading-reporter reads it base64 from `<STEP ID>_RESULTS`,
    src/main.js, and counts "pass" statuses, src/helpers/test-helpers.js), for one submission."""
    ((name, result),) = graded.items()
    notes = "\n".join(result["flags"])
    if form == "gradescope":
        return json.dumps({"score": result["points"], "output": "\n".join(filter(None, [notes, score.POINT])),
                           "output_format": "text", "test_output_format": "text", "test_name_format": "text",
                           "tests": [{"name": f"Exercise {row['exercise']}: {row['title']}", "name_format": "text",
                                      "number": str(row["exercise"]), "score": row["points"], "max_score": 1,
                                      "status": "passed" if row["points"] else "failed", "output": row["detail"],
                                      "output_format": "text", "visibility": "visible"} for row in result["rows"]]},
                          indent=1)
    return json.dumps({"version": 1, "status": "pass" if result["points"] == possible else "fail",
                       "max_score": possible,
                       "tests": [{"name": f"Exercise {row['exercise']}: {row['title']}: {row['detail']}"[:300],
                                  "status": "pass" if row["points"] else "fail", "score": row["points"],
                                  "message": "; ".join(filter(None, [row["detail"], notes])), "test_code": "",
                                  "filename": "", "line_no": 0, "duration": 0} for row in result["rows"]]}, indent=1)
