"""What the grader writes: the CSVs (every cell spreadsheet-safe), a platform's results, Gradescope's autograder.
Gradescope: autograder_samples' docs/specs.md (every text field "text": nothing a student names is HTML). Classroom:
autograding-grading-reporter reads it base64 from `<STEP ID>_RESULTS` (src/main.js), points from "pass" statuses."""

import csv
import io
import json
import re
import zipfile

from curriculum.common.exercise import EXERCISES
from curriculum.grading.score import POINT

CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]+")
FORMULA = ("=", "+", "-", "@")
GRADE_ITEM = "Chapter 3.3 exercises"


def cell(value):
    """As text in any spreadsheet: controls (line ends too) a space, lone surrogates U+FFFD, a formula start '-led."""
    if isinstance(value, int):
        return value
    text = CONTROL.sub(" ", str(value)).encode("utf-8", "replace").decode()
    return f"'{text}" if text.lstrip().startswith(FORMULA) else text


def _table(header: list, rows: list) -> str:
    text = io.StringIO()
    table = csv.writer(text, lineterminator="\r\n")  # RFC 4180's line end: a field holding one is quoted anyway
    table.writerows([[cell(value) for value in row] for row in [header, *rows]])
    return text.getvalue()


def grades(graded: dict) -> str:
    """The detail: a row per student and exercise."""
    header = [*next(iter(graded.values()))["rows"][0]][:-1] + ["flags"]
    return _table(header, [[*list(row.values())[:-1], "; ".join(result["flags"])]
                           for result in graded.values() for row in result["rows"]])


def gradebook(graded: dict, possible: int) -> str:
    """One row per student, as Canvas's and Moodle's gradebook imports take it (docs/TEACHING.md)."""
    return _table(["Student", "SIS Login ID", "Section", GRADE_ITEM, "Points Possible", "Flags"],
                  [[name, name, "", result["points"], possible, "; ".join(result["flags"])]
                   for name, result in sorted(graded.items())])


def platform(form: str, graded: dict, possible: int) -> str:
    """Gradescope's results.json or the Classroom runner's result, for one submission."""
    ((name, result),) = graded.items()
    notes = "\n".join(result["flags"])
    if form == "gradescope":
        return json.dumps({"score": result["points"], "output": "\n".join(filter(None, [notes, POINT])),
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


def autograder_zip() -> bytes:
    """setup.sh and run_autograder at the top (Gradescope's spec), and the course's files pinned under course/."""
    course, archive = EXERCISES.parent, io.BytesIO()
    files = [p for pattern in ("engine*.py", "curriculum/**/*.py", "exercises/**/*", "pyproject.toml")
             for p in sorted(course.glob(pattern)) if p.is_file() and "__pycache__" not in p.parts
             and p.name != "journal.jsonl" and ".before-reset-" not in p.name]
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as bundle:
        for name in ("setup.sh", "run_autograder"):  # docs/gradescope/: Gradescope's two, at the top
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.external_attr = 0o100755 << 16
            bundle.writestr(info, (course / "docs" / "gradescope" / name).read_bytes())
        for path in files:
            bundle.writestr(zipfile.ZipInfo(f"course/{path.relative_to(course)}", (1980, 1, 1, 0, 0, 0)),
                            path.read_bytes())
    return archive.getvalue()
