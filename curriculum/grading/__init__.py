"""The teacher's grader: from hand-ins to a gradebook. The student's path never imports it.

    python -m exercises --grade CLASS [--roster ids.txt] [--due 2026-12-01T23:59+01:00]   # a folder of hand-ins
    python -m exercises --grade ONE --format gradescope|classroom --out FOLDER      # one submission, one platform
    python -m exercises --autograder-zip outputs/autograder.zip                     # Gradescope's autograder

CLASS holds a submission per student (the --handin zip, a zip, a tar, a checkout, a folder) named by the student's
id; anything else is named and skipped. docs/TEACHING.md says what is read, how, and what each flag means.
"""

import argparse
import datetime
from pathlib import Path

from curriculum.common import exercise
from curriculum.common.cli import OneLineParser, shown
from curriculum.common.exercise import EXERCISES
from curriculum.common.outputs import folder_problem, write_atomic
from curriculum.grading import read, recheck, score, write

FILES = {"csv": ["grades.csv", "gradebook.csv", "summary.txt"], "gradescope": ["results.json"],
         "classroom": ["classroom.json"]}


def main(argv) -> int:
    parser = OneLineParser(prog="python -m exercises", description=__doc__.split("\n\n")[0],
                           formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("\n\n", 2)[2])
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--grade", type=str, metavar="PATH", help="a submission, or a folder of them")
    what.add_argument("--autograder-zip", type=Path, metavar="FILE", help="write Gradescope's autograder zip")
    parser.add_argument("--format", choices=FILES, default="csv", help="--grade's output (default csv)")
    parser.add_argument("--out", type=Path, default=Path("outputs"), help="--grade's folder (default outputs)")
    parser.add_argument("--roster", type=Path, metavar="FILE", help="the class's ids, one a line (a CSV's first"
                        " column): each id gets a row, and an id with no submission is listed")
    parser.add_argument("--due", type=datetime.datetime.fromisoformat, metavar="TIME", help="ISO 8601, e.g."
                        " 2026-12-01T23:59+01:00 (UTC if no offset): a first prediction after it is flagged late")
    args = parser.parse_args(argv)
    args.due = args.due and (args.due if args.due.tzinfo else args.due.replace(tzinfo=datetime.UTC))
    if args.autograder_zip:
        problem = folder_problem(args.autograder_zip.parent, [args.autograder_zip.name])
        if problem:
            parser.error(f"--autograder-zip: {problem}")
        write_atomic(args.autograder_zip, write.autograder_zip())
        print(f"{shown(args.autograder_zip, 100)}: upload it as the assignment's autograder (Gradescope, Ubuntu 22.04"
              " base image); students upload the zip `python -m exercises --handin` writes.")
        return 0
    if not args.grade.strip():
        parser.error("--grade: the path is empty: give the folder or archive to grade")
    args.grade = Path(args.grade)
    problem = folder_problem(args.out, FILES[args.format])
    if problem:
        parser.error(f"--out: {problem}")
    found = exercise.exercises(EXERCISES)
    recheck.snapshot()  # the checker's files, read before any student's code runs
    wanted = ["journal.jsonl", *(f"{module}.py" for _, module, kind in found if kind == "code")]
    try:
        roster = read.roster(args.roster) if args.roster else None
        submissions, skipped = read.submissions(args.grade, wanted, args.out)
    except (OSError, ValueError) as error:
        parser.error(f"--grade: {error.strerror if isinstance(error, OSError) else error}")
    if args.format != "csv":  # one platform run: a bad upload still gets its results file, with 0 and why
        graded = score.one(submissions, skipped, found, args.due)
        write_atomic(args.out / FILES[args.format][0], write.platform(args.format, graded, len(found)))
        print_class(graded, skipped, found, args.out / FILES[args.format][0])
        return 0
    if not submissions and not roster:
        parser.error(f"--grade: {shown(args.grade, 100)} holds no submission (a folder, a zip or a tar)")
    graded = score.grade(submissions, found, args.due)
    for name in sorted(set(roster or []) - set(graded)):
        graded[name] = score.missing(name, found)
    for name in sorted(set(graded) - set(roster or graded)):
        graded[name]["flags"].append("not on the roster")
    summary = score.summary(graded, found)
    files = dict(zip(FILES["csv"], (write.grades(graded), write.gradebook(graded, len(found)), summary), strict=True))
    for name, data in files.items():
        write_atomic(args.out / name, data)
    print_class(graded, skipped, found, *(args.out / name for name in files))
    print(summary, end="")
    return 0


def print_class(graded: dict, skipped: list, found: list, *written: Path) -> None:
    print(f"{len(graded)} student(s), {len(found)} points each: {', '.join(shown(p, 100) for p in written)}")
    for name, result in graded.items():
        print(f"  {shown(name, 30):<30}{result['points']:>3}  {shown('; '.join(result['flags']), 500)}")
    for name, why in skipped:
        print(f"  skipped {shown(name, 60)}: {why}")
    print(score.POINT, flush=True)
