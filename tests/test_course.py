"""The student's course flow: the journal (every prediction recorded before its answer), the board, reset and
hand-in, with real processes and real signals (the grader: tests/test_grading.py). Every test keeps its journal in
a scratch folder (COURSE_JOURNAL); conftest.py turns recording off for the rest and guards the checkout's journal."""

import getpass
import json
import os
import pty
import re
import select
import shutil
import signal
import socket
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest

from conftest import REPO
from curriculum.common import journal
from curriculum.common.cli import OneLineParser
from curriculum.common.exercise import EXERCISES, READ_FIRST, READ_ON, announce, command, exercises, titles
from curriculum.common.predict import OneOf, ask, verdict
from curriculum.grading import score

FOUND = exercises(EXERCISES)
STUB = EXERCISES / "support" / "pristine" / "ex2_integrators.py"
SOLUTION = EXERCISES / "solutions" / "ex2_integrators.py"
FIGURE = re.compile(r"\de[-+]\d|%|\d\.\d{2}")  # a measured number, as tests/test_exercises.py reads one


def run(*args, journal_path, cwd=REPO, stdin=None, timeout=120):
    """`python -m ARGS` as a student runs it, recording into `journal_path`."""
    env = {**os.environ, "COURSE_JOURNAL": str(journal_path), "PYTHONPATH": str(cwd)}
    return subprocess.run([sys.executable, "-m", *args], cwd=cwd, env=env, input=stdin, capture_output=True,
                          text=True, timeout=timeout)


def lines(path: Path) -> list:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def predicted(path: Path, module: str, answer: str, right: bool = True, because: str = "", monkeypatch=None):
    """One prediction through the predict helper, as an exercise's main() makes it, then its grade."""
    monkeypatch.setenv("COURSE_JOURNAL", str(path))
    parser = OneLineParser(prog=f"exercises.{module}")
    argv = ["--predict", answer, *(["--because", because] if because else [])]
    got = ask(parser, "Which?", OneOf(["a", "b", "c"]), argv)
    verdict(got if right else "c", "it is that")


# --- recorded before shown ---


def test_the_prediction_is_on_disk_before_the_first_figure_and_a_ctrl_c_keeps_it(tmp_path):
    """Exercise 1 measures for a second or more: its journal is read while it runs, before it has printed anything,
    then Ctrl-C stops it. The record stays, the line says so, and the journal names no user, host or path. The
    Ctrl-C comes 0.3 s after the record, once numpy.random has loaded: a SIGINT inside that import is numpy's."""
    path = tmp_path / "journal.jsonl"
    env = {**os.environ, "COURSE_JOURNAL": str(path), "PYTHONUNBUFFERED": "1", "USER": "student-name-x"}
    child = subprocess.Popen([sys.executable, "-m", "exercises.ex1_band", "--predict",
                              "euler=grows, semi_implicit=stays, rk4=stays", "--because", "energy leaks out"],
                             cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not (path.exists() and '"predict"' in path.read_text()) and time.monotonic() < deadline:
        time.sleep(0.005)
    time.sleep(0.3)
    assert child.poll() is None, "the exercise had already ended: nothing was read while it ran"
    assert select.select([child.stdout], [], [], 0)[0] == [], "a figure was printed before the record was read"
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=60)
    assert child.returncode == 130 and out == "" and "Traceback" not in err
    assert err == "interrupted: no file was written; your prediction is recorded in " + str(path) + "\n"
    header, record = lines(path)
    assert header["kind"] == "journal" and len(header["checkout"]) == 32
    assert record["answer"] == {"euler": "grows", "semi_implicit": "stays", "rk4": "stays"}
    assert (record["ex"], record["attempt"], record["because"]) == (1, 1, "energy leaks out")
    text = path.read_text()
    for private in {getpass.getuser(), "student-name-x", socket.gethostname(), str(REPO), str(tmp_path)}:
        assert private not in text, private
    assert journal.read(path.read_bytes()).edited is None


@pytest.mark.parametrize("planted", ["symlink", "folder", "sticky"])
def test_a_journal_that_cannot_be_written_costs_one_line_and_the_exercise_runs(planted, tmp_path):
    """A symbolic link planted where the journal goes is never followed, nor another user's file in a sticky folder
    (like /tmp): what is there stays as it was."""
    path, target = tmp_path / "journal.jsonl", tmp_path / "elsewhere.txt"
    target.write_text("not the journal\n")
    if planted == "symlink":
        path.symlink_to(target)
    elif planted == "folder":
        path = tmp_path / "missing" / "journal.jsonl"
    else:
        if os.geteuid() != 0:
            pytest.skip("a file that belongs to another user needs root")
        (tmp_path / "shared").mkdir(mode=0o1777)
        (tmp_path / "shared").chmod(0o1777)
        path = target = target.rename(tmp_path / "shared" / "journal.jsonl")
        os.chown(path, 65533, 65533)
    result = run("exercises.ex6_stiff_damping", "--predict", "rk4", journal_path=path)
    assert result.returncode == 0 and "Not quite" in result.stdout
    assert result.stdout.splitlines()[-1] == journal.next_line(6, journal.Journal())  # the one after, the board blind
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("note: nothing was recorded in the journal")
    assert ("symbolic link" in result.stderr) == (planted == "symlink")
    assert ("sticky folder" in result.stderr) == (planted == "sticky")
    assert target.read_text() == "not the journal\n"


def test_with_recording_off_a_prediction_says_so_at_a_terminal():
    """COURSE_JOURNAL=off: one line on the terminal (stderr a tty); piped, stderr stays empty (test_exercises.py)."""
    leader, follower = pty.openpty()
    result = subprocess.run([sys.executable, "-m", "exercises.ex6_stiff_damping", "--predict", "rk4"], cwd=REPO,
                            env={**os.environ, "COURSE_JOURNAL": "off"}, stdout=subprocess.PIPE, stderr=follower,
                            timeout=300)
    os.close(follower)
    said = os.read(leader, 4096).decode()
    assert result.returncode == 0 and said == "note: recording is off (COURSE_JOURNAL=off): this prediction is not" \
        " recorded\r\n", said


@pytest.mark.parametrize("args, said", [
    (["exercises.ex5_phase_blob", "--predict", "euler=grows,semi_implicit=stays,rk4=stays", "--rrd", "x.txt"], ".rrd"),
    (["exercises.ex6_stiff_damping", "--because", "why not"], "--because goes with --predict"),
    (["exercises.ex6_stiff_damping", "--predict", "rk4, verlet"], "'verlet' is not an integrator here"),
    (["exercises.ex6_stiff_damping"], ""),  # the bare question: asking is not committing
])
def test_bad_input_or_a_bare_question_records_nothing(args, said, tmp_path):
    result, path = run(*args, journal_path=tmp_path / "journal.jsonl"), tmp_path / "journal.jsonl"
    assert result.returncode == (2 if said else 0) and said in result.stderr and not path.exists()


def test_a_changed_answer_is_attempt_2_the_same_one_a_replay_and_the_first_counts(tmp_path, monkeypatch, capsys):
    path = tmp_path / "journal.jsonl"
    predicted(path, "ex4_long_run", "a", right=False, because="=cmd|' /C calc'!A0", monkeypatch=monkeypatch)
    predicted(path, "ex4_long_run", "b", monkeypatch=monkeypatch)
    predicted(path, "ex4_long_run", "a", right=False, monkeypatch=monkeypatch)
    out = capsys.readouterr().out.splitlines()
    first_time = journal.when(lines(path)[1]["t"])
    assert out == ["Not quite: you said a, but it is that.", "Right: it is that.",
                   f"This was attempt 2: your first prediction, {first_time}, is the one that counts.",
                   "Not quite: you said a, but it is that.",
                   f"The same answer as your attempt 1 ({first_time}): a replay, not a new attempt."]
    kinds = [(r["kind"], r.get("attempt")) for r in lines(path)]
    assert kinds == [("journal", None), ("predict", 1), ("marks", None), ("predict", 2), ("marks", None),
                     ("replay", None)]  # the replay's marks are attempt 1's, already there
    book = journal.load()
    said, done = journal.status(book, 4, "ex4_long_run", "predict")
    assert done and said == f"predicted {first_time}: 0 of 1 right, 2 attempts"
    row = score._row("s", book, {}, {}, score.truths(), None, 4, "ex4_long_run", "predict")  # the grader's view
    assert (row["first_prediction"], row["attempts"], row["right"], row["points"]) == ("a", 2, 0, 1)
    # a bare run now shows what was committed and when, and no figure
    monkeypatch.setattr(sys, "argv", ["x"])
    from exercises import ex4_long_run

    with pytest.raises(SystemExit) as asked:
        ex4_long_run.main([])
    shown = capsys.readouterr().out
    assert asked.value.code == 0 and f"You committed a on {first_time}, because =cmd" in shown
    assert "(2 attempts: the first counts)" in shown and not FIGURE.search(shown)


def test_each_variant_of_a_question_counts_its_own_attempts():
    """Exercise 3 on the orbit, then with --system spring: two questions, one attempt at each."""
    book = journal.Journal(records=[{"kind": "predict", "ex": 3, "question": "", "answer": {"rk4": 16}, "chain": "a",
                                     "because": "", "t": "2025-11-25T10:02:00+01:00"},
                                    {"kind": "predict", "ex": 3, "question": "system=spring", "answer": {"rk4": 32},
                                     "chain": "b", "because": "", "t": "2025-11-25T10:05:00+01:00"}])
    assert journal.status(book, 3, "ex3_halve_dt", "predict")[0] == "predicted Tue 25 Nov 10:02: not measured yet"
    row = score._row("s", book, {}, {}, {}, None, 3, "ex3_halve_dt", "predict")
    assert (row["question"], row["first_prediction"], row["attempts"]) == ("", "rk4=16", 1)


def test_a_line_cut_off_by_a_crash_is_skipped_and_noted(tmp_path, monkeypatch):
    path = tmp_path / "journal.jsonl"
    predicted(path, "ex1_band", "a", monkeypatch=monkeypatch)
    with open(path, "ab") as file:
        file.write(b'{"kind": "predict", "ex": 3, "answ')  # the process died inside its write
    predicted(path, "ex3_halve_dt", "b", monkeypatch=monkeypatch)
    book = journal.read(path.read_bytes())
    assert book.unreadable == 1 and book.edited is None and [r["ex"] for r in book.records[1:]] == [1, 1, 3, 3]
    board = run("exercises", journal_path=path)
    assert "Note: the journal: 1 unreadable line(s) (cut off by a crash, edited, or not of this format), skipped;" \
           " a teacher's grader flags it too." in board.stdout


@pytest.mark.skipif(sys.platform == "win32", reason="flock")
def test_ten_runs_started_together_leave_every_record_once(tmp_path):
    """Ten exercise 6 runs at once, eight different answers and two repeated: every answer is one attempt, numbered
    once, every repeat a replay, every answer graded once, and the chain holds."""
    path = tmp_path / "journal.jsonl"
    names = ["euler", "semi_implicit", "rk4", "implicit"]
    answers = [",".join(n for i, n in enumerate(names) if k >> i & 1) or "none" for k in [*range(8), 0, 1]]
    env = {**os.environ, "COURSE_JOURNAL": str(path)}
    runs = [subprocess.Popen([sys.executable, "-m", "exercises.ex6_stiff_damping", "--predict", answer], cwd=REPO,
                             env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            for answer in answers]
    assert [(r.wait(timeout=300), r.stderr.read()) for r in runs] == [(0, "")] * 10
    book = journal.read(path.read_bytes())
    assert book.edited is None and book.unreadable == 0 and sum(r["kind"] == "journal" for r in book.records) == 1
    predictions = [r for r in book.records if r["kind"] == "predict"]
    assert sorted(r["attempt"] for r in predictions) == list(range(1, 9))
    assert {frozenset(r["answer"]) for r in predictions} == {frozenset(a.split(",")) - {"none"} for a in answers}
    replays = [r for r in book.records if r["kind"] == "replay"]
    assert len(replays) == 2 and {r["prediction"] for r in replays} <= {r["chain"] for r in predictions}
    marks = [r["prediction"] for r in book.records if r["kind"] == "marks"]
    assert sorted(marks) == sorted(r["chain"] for r in predictions)


# --- the board, Next:, reset, hand-in ---


def board_row(number: int, path: Path, cwd: Path = REPO) -> str:
    return next(line for line in run("exercises", journal_path=path, cwd=cwd).stdout.splitlines()
                if line.startswith(f"{number:>3}."))


def test_next_lines_come_from_the_exercises_on_disk_and_their_readme():
    """With no journal to read (recording off), a run's Next line names the exercise after it."""
    named, blind = titles(EXERCISES), journal.Journal()
    assert sorted(named) == [n for n, _, _ in FOUND] and named[3] == "Halve the timestep"
    for (number, _, _), (following, module, kind) in zip(FOUND, FOUND[1:], strict=False):
        first = READ_FIRST.get(following, "")  # engine.py, where README sends the student to read it
        said = f'Next: {first}exercise {following}, "{named[following]}": {command(module, kind)}'
        assert journal.next_line(number, blind) == said
    assert READ_ON in journal.next_line(FOUND[-1][0], blind) and (REPO / READ_ON.split(",")[0]).is_file()
    for _, module, kind in FOUND:
        if kind == "code":  # what --reset puts back and what the grader recognises
            assert (EXERCISES / "support" / "pristine" / f"{module}.py").is_file(), module


def test_the_board_counts_to_seven_with_the_next_command_at_each_step(tmp_path, monkeypatch):
    """The board, after each exercise in turn (predictions through the predict helper, exercise 2's check through
    the checker harness's record), names the next command; it loads neither numpy nor the engine."""
    path = tmp_path / "journal.jsonl"
    first = run("exercises", journal_path=path)
    assert first.returncode == 0 and first.stderr == "" and not path.exists()
    assert first.stdout.startswith(f"0 of {len(FOUND)} exercises done.")
    assert first.stdout.splitlines()[-1] == announce(EXERCISES, *FOUND[0])
    monkeypatch.setenv("COURSE_JOURNAL", str(path))
    for at, (_, module, kind) in enumerate(FOUND):
        if kind == "code":
            journal.checked(EXERCISES / f"{module}.py", EXERCISES / f"{module}.py", {"a": True, "b": True})
        else:
            predicted(path, module, "a", monkeypatch=monkeypatch)
        board = run("exercises", journal_path=path).stdout.splitlines()
        assert board[0] == f"{at + 1} of {len(FOUND)} exercises done."
        assert f"  {'predicted' if kind == 'predict' else 'solved'} " in board[1 + at], board[1 + at]
        later = FOUND[at + 1:]
        assert board[-1] == (announce(EXERCISES, *later[0]) if later else f"Next: read {READ_ON}.")
    loaded = subprocess.run([sys.executable, "-c", "import runpy, sys\ntry:\n runpy.run_module('exercises',"
                             " run_name='__main__')\nexcept SystemExit: pass\nprint([m for m in sys.modules if"
                             " m.split('.')[0] in ('numpy', 'engine', 'rerun') or 'grading' in m])"], cwd=REPO,
                            capture_output=True, text=True, env={**os.environ, "COURSE_JOURNAL": str(path)})
    assert loaded.stdout.splitlines()[-1] == "[]"


def test_the_checker_records_each_check_and_the_board_follows_the_own_file(tmp_path):
    """Each check is a record (its parts and the file's sha256, never its code); the checker ends with its own
    command until solved, then with the board's Next line. Checking a scratch file (as exercises/README.md invites)
    leaves a solved exercise solved; changing the exercise's own file since says so."""
    root, path = scratch_checkout(tmp_path), tmp_path / "journal.jsonl"
    mine, planted = root / "exercises" / "ex2_integrators.py", REPO / "tests" / "planted" / "rk4_equal_weights.py"
    shutil.copyfile(SOLUTION, mine)
    solved = run("exercises.check_ex2", journal_path=path, cwd=root)
    assert solved.returncode == 0 and solved.stdout.splitlines()[-1] == announce(EXERCISES, *FOUND[0])
    scratch = run("exercises.check_ex2", str(planted), journal_path=path, cwd=root)  # its own command, until solved
    assert scratch.returncode == 1 and scratch.stdout.endswith(f"Next: python -m exercises.check_ex2 {planted}\n")
    checks = [r for r in lines(path) if r["kind"] == "check"]
    assert [(r["own"], r["solved"]) for r in checks] == [(True, True), (False, False)]
    assert checks[1]["parts"] == {"semi_implicit_step": True, "rk4_step": False}
    assert len(checks[1]["sha256"]) == 64 and "def " not in path.read_text()
    elsewhere = run("exercises.check_ex2", str(SOLUTION), journal_path=path, cwd=root)  # solved, but not the file
    assert elsewhere.stdout.splitlines()[-2:] == [f"(This file is not exercises/{mine.name}, the one the board and"
                                                  " the grade read.)", announce(EXERCISES, *FOUND[0])]
    assert " solved " in board_row(2, path, root) + " " and "changed" not in board_row(2, path, root)
    shutil.copyfile(STUB, mine)
    assert board_row(2, path, root).endswith(", but the file has changed since")
    assert run("exercises.check_ex2", journal_path=path, cwd=root).returncode == 1
    assert board_row(2, path, root).endswith(": semi_implicit_step not yet, rk4_step not yet")


def scratch_checkout(tmp_path: Path) -> Path:
    """The course's own files in a scratch folder, so that a reset can rewrite exercise 2's file."""
    root = tmp_path / "checkout"
    for part in ("curriculum", "exercises"):
        shutil.copytree(REPO / part, root / part, ignore=shutil.ignore_patterns("__pycache__", "journal.jsonl"))
    for engine in REPO.glob("engine*.py"):
        shutil.copyfile(engine, root / engine.name)
    shutil.copyfile(STUB, root / "exercises" / "ex2_integrators.py")
    return root


def test_reset_starts_over_keeps_the_records_and_asks_before_touching_exercise_2(tmp_path, monkeypatch):
    root, path = scratch_checkout(tmp_path), tmp_path / "journal.jsonl"
    predicted(path, "ex3_halve_dt", "a", monkeypatch=monkeypatch)
    reset = run("exercises", "--reset", "3", journal_path=path, cwd=root)
    assert reset.returncode == 0 and "Exercise 3 starts over" in reset.stdout
    assert board_row(3, path, root).endswith("  not tried")
    predicted(path, "ex3_halve_dt", "b", monkeypatch=monkeypatch)
    assert [r.get("attempt") for r in lines(path) if r["kind"] == "predict"] == [1, 1]  # a new round
    row = board_row(3, path, root)  # what the grade counts: the first prediction, made before the reset
    assert row.endswith(": 1 of 1 right, 2 attempts; the grade counts this first one, from before your reset"), row

    mine = root / "exercises" / "ex2_integrators.py"
    mine.write_text(SOLUTION.read_text())
    declined = run("exercises", "--reset", "2", journal_path=path, cwd=root, stdin="n\n")
    assert "Nothing was changed." in declined.stdout and mine.read_text() == SOLUTION.read_text()
    accepted = run("exercises", "--reset", "2", journal_path=path, cwd=root, stdin="y\n")
    assert accepted.returncode == 0 and mine.read_bytes() == STUB.read_bytes()
    (kept,) = (root / "exercises").glob("ex2_integrators.before-reset-*.py")
    assert kept.read_text() == SOLUTION.read_text() and f"yours is exercises/{kept.name}." in accepted.stdout
    assert [r["ex"] for r in lines(path) if r["kind"] == "reset"] == [3, 2]


def test_handin_writes_one_archive_of_the_journal_and_exercise_2(tmp_path, monkeypatch):
    path = tmp_path / "journal.jsonl"
    predicted(path, "ex1_band", "a", monkeypatch=monkeypatch)
    made = [run("exercises", "--handin", "--out", str(tmp_path / f"h{i}.zip"), journal_path=path) for i in (1, 2)]
    assert all(m.returncode == 0 and m.stderr == "" for m in made)
    with zipfile.ZipFile(tmp_path / "h1.zip") as archive:
        assert archive.namelist() == ["exercises/journal.jsonl", "exercises/ex2_integrators.py"]
        assert archive.read("exercises/journal.jsonl") == path.read_bytes()
        assert archive.read("exercises/ex2_integrators.py") == (EXERCISES / "ex2_integrators.py").read_bytes()
    assert (tmp_path / "h1.zip").read_bytes() == (tmp_path / "h2.zip").read_bytes()  # the same files, the same bytes
