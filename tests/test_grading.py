"""The teacher's grader (curriculum/grading): a class graded to the gradebook and the summary, the platforms'
results read as their own code reads them, Classroom's workflow wired to the reporter's contract, and every
hand-in treated as hostile (issue 35's cases, a row each)."""

import base64
import csv
import gzip
import hashlib
import io
import json
import lzma
import os
import re
import shutil
import subprocess
import sys
import tarfile
import unicodedata
import zipfile
from pathlib import Path

import pytest

from conftest import REPO
from curriculum import grading
from curriculum.common import journal
from curriculum.common.exercise import EXERCISES, exercises
from curriculum.grading import read, recheck, score

FOUND = exercises(EXERCISES)
STUB = (EXERCISES / "support" / "pristine" / "ex2_integrators.py").read_bytes()
SOLUTION = (EXERCISES / "solutions" / "ex2_integrators.py").read_bytes()
TRUTH = score.truths()
WRONG = {1: {"euler": "grows", "semi_implicit": "grows", "rk4": "stays"}, 4: 10000, 6: ["implicit"]}
T = "2026-11-20T10:00:00+01:00"


def journal_lines(*entries, checkout="c", version=journal.VERSION) -> bytes:
    """A journal as the exercises write it: the header, then each record with its time and chain."""
    out, before = [], ""
    for record in [{"kind": "journal", "version": version, "note": journal.NOTE, "checkout": checkout}, *entries]:
        record = {**record, **({} if record["kind"] == "journal" else {"t": record.get("t", T)})}
        record["chain"] = before = journal.chained(before, record)
        out.append(json.dumps(record) + "\n")
    return "".join(out).encode()


def predicted(ex, answer, because="", t=T) -> dict:
    return {"kind": "predict", "ex": ex, "question": "", "answer": answer, "typed": str(answer), "because": because,
            "attempt": 1, "t": t}


def handin(path: Path, data: bytes | None, ex2: bytes | None = STUB, top: str = "") -> None:
    with zipfile.ZipFile(path, "w") as archive:
        for name, content in (("journal.jsonl", data), ("ex2_integrators.py", ex2)):
            if content is not None:
                archive.writestr(f"{top}exercises/{name}", content)


def grade(*args, cwd=REPO):
    return subprocess.run([sys.executable, "-m", "exercises", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "COURSE_JOURNAL": "off"})


def table(path: Path) -> list:
    return list(csv.DictReader(io.StringIO(path.read_text(encoding="utf-8"))))


def safe(path: Path) -> bool:
    """No cell starts a formula once leading spaces and control characters are gone; no line end inside a cell."""
    cells = [c for row in csv.reader(io.StringIO(path.read_text(encoding="utf-8"), newline="")) for c in row]
    return all(not c.lstrip("".join(map(chr, range(33)))).startswith(grading.FORMULA) and not re.search("[\r\n]", c)
               for c in cells)


def test_a_class_gives_one_row_each_with_a_roster_a_summary_and_the_same_scores_on_a_second_run(tmp_path):
    klass, roster = tmp_path / "class", tmp_path / "roster.csv"
    klass.mkdir()
    right = [predicted(n, TRUTH[n]) for n in (1, 4, 6)]
    alice = journal_lines(*right, checkout="alice")
    handin(klass / "alice.zip", alice)
    handin(klass / "bob.zip", alice)  # alice's journal handed in as bob's
    carol = journal_lines(predicted(4, 10000), checkout="carol").replace(b"10000", b"1000")  # her answer, edited
    with tarfile.open(klass / "carol.tar.xz", "w:xz") as archive:
        info = tarfile.TarInfo("exercises/journal.jsonl")
        info.size = len(carol)
        archive.addfile(info, io.BytesIO(carol))
    (klass / "dave").mkdir()  # nothing handed in
    zoe = klass / unicodedata.normalize("NFD", "Zoë") / "exercises"  # macOS names it NFD; the roster says NFC
    zoe.mkdir(parents=True)
    (zoe / "journal.jsonl").write_bytes(journal_lines(predicted(1, WRONG[1]), {**predicted(1, TRUTH[1]), "attempt": 2},
                                                      predicted(4, 10000), checkout="zoe"))
    handin(klass / "frank.zip", journal_lines(checkout="frank"), SOLUTION, top="ch3.3-engine-main/")
    (klass / "notes.pdf").write_bytes(b"%PDF-1.4")
    roster.write_text("id\nalice\nbob\ncarol\ndave\nZoë\nfrank\nyann\n", encoding="utf-8")
    runs = [grade("--grade", klass, "--roster", roster, "--out", klass / "outputs") for _ in range(2)]
    assert [r.returncode for r in runs] == [0, 0] and "Traceback" not in runs[1].stderr
    assert "skipped notes.pdf: not a folder or an archive" in runs[0].stdout
    assert "skipped outputs: the grader's own output" in runs[1].stdout
    book = {row["Student"]: row for row in table(klass / "outputs" / "gradebook.csv")}
    assert {name: int(row["Chapter 3.3 exercises"]) for name, row in book.items()} == {
        "alice": 3, "bob": 3, "carol": 1, "dave": 0, "Zoë": 2, "frank": 1, "yann": 0}
    assert {row["Points Possible"] for row in book.values()} == {str(len(FOUND))}
    assert book["alice"]["Flags"] == "shares 4 journal lines with bob: one is a copy"
    assert book["carol"]["Flags"] == "edited by hand: line 2 does not follow from the one before"
    assert book["frank"]["Flags"] == "exercise 2: the file is the course's solution, byte for byte"
    assert book["dave"]["Flags"] == "no journal" and book["yann"]["Flags"] == "no submission"
    detail = {(r["student"], r["exercise"]): r for r in table(klass / "outputs" / "grades.csv")}
    assert (detail["Zoë", "1"]["right"], detail["Zoë", "1"]["items"], detail["Zoë", "1"]["attempts"]) == ("1", "3", "2")
    assert detail["carol", "4"]["right"] == "1"  # recomputed from the stored answer; her journal's marks are not read
    summary = (klass / "outputs" / "summary.txt").read_text()
    assert summary.startswith("Class summary: 2 journals counted; 3 left out as copies or hand edits.") and \
        summary in runs[0].stdout
    assert "  1. 0 of 1 first predictions wholly right; most common wrong: euler=grows, semi_implicit=grows," \
           " rk4=stays (1); 1 changed their answer" in summary


@pytest.mark.parametrize(("setup", "said"), [
    (lambda k: (handin(k / "alice.zip", None), (k / "alice").mkdir()), "alice and alice.zip are both alice's"),
    (lambda k: (k / "roster.txt").write_text("a\nb\na\n"), "--roster lists a more than once"),
])
def test_two_hand_ins_for_one_id_and_a_roster_that_repeats_are_refused(tmp_path, setup, said):
    klass = tmp_path / "class"
    klass.mkdir()
    setup(klass)
    roster = ["--roster", klass / "roster.txt"] if (klass / "roster.txt").exists() else []
    result = grade("--grade", klass, "--out", tmp_path / "out", *roster)
    assert result.returncode == 2 and said in result.stderr and not (tmp_path / "out").exists()
    assert grade("--grade", "", "--out", tmp_path / "out").returncode == 2  # never the course's own checkout


def test_gradescope_and_classroom_results_as_their_own_code_reads_them(tmp_path):
    """Gradescope's specs (autograder_samples docs/specs.md): text formats declared, a bad upload still a results.json
    with 0 and what to upload. Classroom: the reporter's getTestScore (passes / tests x max_score) gives our points."""
    good, empty, pdf, two = (tmp_path / name for name in ("good", "empty", "pdf", "two"))
    for folder in (good, empty, pdf, two):
        folder.mkdir()
    handin(good / "handin.zip", journal_lines(predicted(1, TRUTH[1]), predicted(4, 10000)))
    (pdf / "essay.pdf").write_bytes(b"%PDF")
    handin(two / "a.zip", None)
    handin(two / "b.zip", None)
    for folder, points in ((good, 2), (empty, 0), (pdf, 0), (two, 0)):
        assert grade("--grade", folder, "--format", "gradescope", "--out", folder / "r").returncode == 0
        results = json.loads((folder / "r" / "results.json").read_text())
        assert results["score"] == points and results["output_format"] == "text"
        assert all(t["output_format"] == t["name_format"] == "text" for t in results["tests"])
        assert ("Upload the one zip" in results["output"]) == (folder != good)
    assert "this upload holds essay.pdf" in json.loads((pdf / "r" / "results.json").read_text())["output"]
    assert grade("--grade", good, "--format", "classroom", "--out", good / "c").returncode == 0
    result = json.loads(base64.b64decode(base64.b64encode((good / "c" / "classroom.json").read_bytes())))
    assert result["version"] == 1 and result["max_score"] == len(FOUND) and result["status"] == "fail"
    assert all(set(t) == {"name", "status", "score", "message", "test_code", "filename", "line_no", "duration"}
               and t["line_no"] == 0 for t in result["tests"])
    passed = sum(t["status"] == "pass" for t in result["tests"])
    assert passed / len(result["tests"]) * result["max_score"] == 2 == sum(t["score"] for t in result["tests"])


def test_the_classroom_workflow_is_wired_to_the_reporters_contract():
    """classroom-resources/autograding-grading-reporter: it reads `${runner.toUpperCase()}_RESULTS`, base64, for each
    id in `runners` (src/main.js); Classroom takes the points from the job run-autograding-tests. The grade comes
    from the teacher's pinned checkout, reading the student's as a submission."""
    text = (REPO / "docs" / "classroom.yml").read_text()
    assert re.search(r"^jobs:\n  run-autograding-tests:", text, re.M)
    step = re.search(r"- name: Grade\n\s+id: (\w+)\n\s+working-directory: grader\n\s+run: \|\n((?:\s{10}.*\n)+)", text)
    assert step and "python -m exercises --grade ../submission --format classroom --out \"$RUNNER_TEMP/grade\"" in \
        step[2] and 'echo "result=$(base64 -w0 "$RUNNER_TEMP/grade/classroom.json")" >> "$GITHUB_OUTPUT"' in step[2]
    reporter = text[text.index("uses: classroom-resources/autograding-grading-reporter@v1"):]
    assert f'{step[1].upper()}_RESULTS: "${{{{ steps.{step[1]}.outputs.result }}}}"' in reporter
    assert re.search(rf"runners: {step[1]}$", reporter, re.M) and re.fullmatch(r"[a-zA-Z0-9]+", step[1])
    assert "repository: ${{ env.GRADER_REPOSITORY }}" in text and "ref: ${{ env.GRADER_REF }}" in text


def test_gradescopes_run_autograder_always_writes_results_json(tmp_path):
    """The zip laid out as /autograder (its root moved with AUTOGRADER), a good upload and a broken one."""
    root = tmp_path / "autograder"
    if not (REPO / ".git").exists():
        pytest.skip("docs/TEACHING.md's command builds the zip with git archive: this copy is not a git checkout")
    subprocess.run(["git", "archive", "--format=zip", "-o", tmp_path / "autograder.zip", "--prefix=",
                    "--add-file=docs/gradescope/setup.sh", "--add-file=docs/gradescope/run_autograder",
                    "--prefix=course/", "HEAD"], cwd=REPO, check=True)  # the course as committed: pinned
    zipfile.ZipFile(tmp_path / "autograder.zip").extractall(root / "source")
    (root / "venv" / "bin").mkdir(parents=True)
    (root / "venv" / "bin" / "python").symlink_to(sys.executable)
    for upload, points in ((journal_lines(predicted(4, 10000)), 1), (b"not a zip", 0)):
        shutil.rmtree(root / "submission", ignore_errors=True)
        (root / "submission").mkdir()
        (root / "submission" / "handin.zip").write_bytes(upload) if points == 0 else handin(
            root / "submission" / "handin.zip", upload)
        subprocess.run(["bash", root / "source" / "run_autograder"], env={**os.environ, "AUTOGRADER": str(root)},
                       capture_output=True, timeout=300)
        assert json.loads((root / "results" / "results.json").read_text())["score"] == points


def tar_with(pax_size: int, padding: int) -> bytes:
    header = tarfile.TarInfo("././@PaxHeader")
    header.type, header.size = tarfile.XHDTYPE, pax_size
    return gzip.compress(header.tobuf() + b"\0" * padding, compresslevel=1)


HOSTILE = {  # name in the class folder -> (what is in it, the flag it must get)
    "deep.zip": (lambda p: handin(p, journal_lines() + b"[" * 5000 + b"\n"), "1 unreadable line"),
    "no_right.zip": (lambda p: handin(p, journal_lines({"kind": "marks", "ex": 1, "prediction": "x", "items": 3})),
                     "1 unreadable line"),
    "parts.zip": (lambda p: handin(p, journal_lines(*({"kind": "check", "ex": 2, "solved": False, "parts": v,
                                                        "sha256": "", "own": True} for v in ([], None, "x")))),
                  "3 unreadable line"),
    "surrogate.zip": (lambda p: handin(p, journal_lines(predicted(4, 1000)).replace(b'"because": ""',
                                                                                  b'"because": "\\ud800"')),
                      "1 unreadable line"),
    "version.zip": (lambda p: handin(p, journal_lines(version=2)), "journal format 2; this course reads 1"),
    "cut.zip": (lambda p: p.write_bytes(_zipped()[:-30]), "could not be read"),
    "bad_name.zip": (lambda p: p.write_bytes(_zipped("journé").replace("é".encode(), b"\xff\xfe")),  # flagged UTF-8
                     "could not be read"),
    "corrupt.tar.xz": (lambda p: p.write_bytes(lzma.compress(b"x" * 5000)[:40]), "could not be read"),
    "pax.tar.gz": (lambda p: p.write_bytes(tar_with(512_000_000, 40_000_000)), "unpacks to more than 32 MB"),
    "big.zip": (lambda p: handin(p, b" " * 5_000_000), "over 4 MB, more than a hand-in holds: refused"),
    "\udcff\r=1+2": (lambda p: (p / "exercises").mkdir(parents=True), "no journal"),
    "formula.zip": (lambda p: handin(p, journal_lines(predicted(4, 1000, because="=cmd|' /C calc'!A0\r=1+2"))), ""),
}


def _zipped(name: str = "journal") -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as archive:
        archive.writestr(f"exercises/{name}.jsonl", journal_lines(predicted(4, 1000)))
    return out.getvalue()


def test_every_hand_in_is_hostile_and_each_is_a_flag_never_a_crash(tmp_path):
    klass = tmp_path / "class"
    klass.mkdir()
    for name, (make, _) in HOSTILE.items():
        make(Path(os.fsencode(klass / name).decode("utf-8", "surrogateescape")))
    result = grade("--grade", klass, "--out", tmp_path / "out")
    assert result.returncode == 0 and "Traceback" not in result.stderr
    book = {row["Student"]: row["Flags"] for row in table(tmp_path / "out" / "gradebook.csv")}
    for name, (_, flag) in HOSTILE.items():
        student = grading.cell(read.roster_id(name))  # "\udcff\r=1+2" is "\ufffd =1+2": no line end, no formula
        assert flag in book[student], (name, book[student])
    assert "\x1b" not in result.stdout and "\r" not in result.stdout
    assert all(safe(tmp_path / "out" / f) for f in ("grades.csv", "gradebook.csv"))


def test_a_students_code_changes_no_other_grade_and_nothing_it_prints_or_reads_reaches_the_grades(tmp_path):
    """It rewrites the checker's cases where it runs, prints a formula and raises with a file it read; the next
    student's right file is still solved, and the teacher's checkout is untouched."""
    klass = tmp_path / "class"
    klass.mkdir()
    attack = (b"import exercises.support.ex2_cases as cases\ntry:\n    open(cases.__file__, 'w').write('x')\n"
              b"except OSError:\n    pass  # as nobody it cannot\n"
              b"print('=cmd|calc!A0 PRINTED')\ndef semi_implicit_step(q, v, m, force, dt):\n"
              b"    raise ValueError(open(" + repr(str(REPO / 'pyproject.toml')).encode() + b").read())\n"
              b"rk4_step = semi_implicit_step\n")
    handin(klass / "a_mallory.zip", journal_lines(checkout="m"), attack)
    handin(klass / "b_honest.zip", journal_lines(checkout="h"), SOLUTION + b"\n# mine\n")
    cases = hashlib.sha256((EXERCISES / "support" / "ex2_cases.py").read_bytes()).hexdigest()
    assert grade("--grade", klass, "--out", tmp_path / "out").returncode == 0
    rows = {r["student"]: r for r in table(tmp_path / "out" / "grades.csv") if r["exercise"] == "2"}
    assert rows["b_honest"]["solved"] == "yes" and rows["a_mallory"]["solved"] == "no"
    text = "".join((tmp_path / "out" / f).read_text() for f in ("grades.csv", "gradebook.csv", "summary.txt"))
    assert "PRINTED" not in text and "build-system" not in text and "ValueError" in text
    assert hashlib.sha256((EXERCISES / "support" / "ex2_cases.py").read_bytes()).hexdigest() == cases


def test_students_code_runs_as_nobody_when_the_grader_is_root():
    user = recheck.unprivileged()
    if user is None:
        pytest.skip(f"not root, or the user nobody cannot run {sys.executable} (its folder is private, as pyenv's"
                    " under /root is): the grader said so in one line and ran the code as itself")
    probe = b"import os\nassert os.geteuid() != 0\n" + SOLUTION
    assert recheck.check("ex2_integrators", probe) == (True, "solved, checked again here")
