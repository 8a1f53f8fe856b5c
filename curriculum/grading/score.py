"""A row per student and exercise, the flags, the class summary. A prediction exercise's point is its first
prediction (resets included), `right` recomputed from the stored answer against ANSWERS.md's graded answer."""

import collections
import datetime
import re

import curriculum.grading.recheck as recheck
from curriculum.common import exercise, journal
from curriculum.common.cli import shown

POINT = ("A point is a prediction committed before its measurement, right or wrong, or a code exercise solved"
         " (checked again here). The journal is for learning, not proctoring: anyone can forge one; an edit or a"
         " copy within this batch is flagged, a careful forgery is not.")
SOLUTIONS = exercise.EXERCISES / "solutions"


def truths() -> dict:
    """{exercise: ANSWERS.md's graded answer, as the journal stores answers: a dict, a sorted list, an int or a str}."""
    text, found = (SOLUTIONS / "ANSWERS.md").read_text(encoding="utf-8"), {}
    for number, body in re.findall(r"^## Exercise (\d+)\b(.*?)(?=^## |\Z)", text, flags=re.M | re.S):
        if said := re.search(r"The graded answer is `([^`]+)`", body):
            items = [item.strip() for item in said[1].split(",")]
            value = lambda v: int(v) if v.isdigit() else v  # noqa: E731
            found[int(number)] = dict((k.strip(), value(v.strip())) for k, v in (i.split("=") for i in items)) \
                if "=" in said[1] else sorted(items) if len(items) > 1 else value(said[1].strip())
    return found


def marked(answer, truth) -> tuple[int, int] | None:
    """(items right, items) of a stored answer against the graded one; None if there is no graded answer."""
    if truth is None:
        return None
    if isinstance(truth, dict):
        return sum(isinstance(answer, dict) and answer.get(k) == v for k, v in truth.items()), len(truth)
    truth = [truth] if isinstance(answer, list) and not isinstance(truth, list) else truth
    return int(answer == truth), 1


def said(answer) -> str:
    return ", ".join(f"{k}={v}" for k, v in answer.items()) if isinstance(answer, dict) else \
        ", ".join(answer) or "none" if isinstance(answer, list) else str(answer)


def grade(submissions: dict, found: list, due) -> dict:
    titles, known, graded, chains = exercise.titles(exercise.EXERCISES), truths(), {}, {}
    for name, files in submissions.items():
        data = files["journal.jsonl"]
        book = journal.read(data) if data is not None else None  # None: no journal (one over 4 MB is refused)
        rows = [_row(name, book, files, titles, known, due, *item) for item in found]
        late = [str(r["exercise"]) for r in rows if r["flag"] == "late"]
        flags = [files["problem"] or not book and "no journal", *(book.notes() if book else []),
                 *(f"exercise {r['exercise']}: {r['flag']}" for r in rows if r["flag"] and r["flag"] != "late"),
                 late and f"late: the first prediction of exercise {', '.join(late)} came after --due"]
        graded[name] = {"rows": rows, "book": book, "flags": [f for f in flags if f],
                        "points": sum(r["points"] for r in rows)}
        chains[name] = {r["chain"] for r in book.records} if book else set()
    for name, result in graded.items():  # more than one line shared: a copy (a planted line alone flags nobody)
        result["flags"] += [f"shares {n} journal lines with {other}: one is a copy" for other in sorted(chains)
                            if other != name and (n := len(chains[name] & chains[other])) > 1]
    return graded


def missing(name: str, found: list, why: str = "no submission") -> dict:
    titles = exercise.titles(exercise.EXERCISES)
    return {"rows": [_empty(name, number, titles.get(number, module)) | {"detail": why} for number, module, _ in found],
            "book": None, "flags": [why], "points": 0}


def _empty(student: str, number: int, title: str) -> dict:
    return dict(student=student, exercise=number, title=title, question="", first_prediction="", first_time_utc="",
                attempts=0, resets=0, right="", items="", reason="", solved="", points=0, detail="", flag="")


def _row(student, book, files, titles, known, due, number, module, kind) -> dict:
    mine = book.of(number, everything=True) if book else []
    row = _empty(student, number, titles.get(number, module)) | {"resets": sum(r["kind"] == "reset" for r in mine)}
    if kind == "code":
        data = files[f"{module}.py"]
        solved, detail = recheck.check(module, data)
        copy = data == (SOLUTIONS / f"{module}.py").read_bytes()
        return row | {"attempts": sum(r["kind"] == "check" and r["own"] for r in mine), "points": int(solved),
                      "solved": "yes" if solved else "no", "detail": detail,
                      "flag": "the file is the course's solution, byte for byte" if copy else ""}
    predictions = [r for r in mine if r["kind"] == "predict"]
    if not predictions:
        return row | {"detail": "no prediction recorded"}
    first = predictions[0]
    score = marked(first["answer"], known.get(number))
    try:
        moment = datetime.datetime.fromisoformat(first["t"])
        moment = (moment if moment.tzinfo else moment.replace(tzinfo=datetime.UTC)).astimezone(datetime.UTC)
    except ValueError:  # a hand-written time: shown as written, never late
        moment = None
    row |= {"question": first["question"], "first_prediction": said(first["answer"]), "reason": first["because"],
            "first_time_utc": moment.isoformat() if moment else first["t"], "points": 1,
            "attempts": sum(r["question"] == first["question"] for r in predictions),
            "right": score[0] if score else "", "items": score[1] if score else "",
            "flag": "late" if due and moment and moment > due else ""}
    row["detail"] = (f"first prediction {row['first_time_utc']}: {row['first_prediction']}"
                     + (f" ({score[0]} of {score[1]} right)" if score else "") + f"; {row['attempts']} attempt(s)")
    return row


def summary(graded: dict, found: list) -> str:
    """Per exercise: first predictions wholly right, the commonest wrong one, how many changed; no copy or edit."""
    doubtful = {n for n, r in graded.items() if any(f.startswith(("shares", "edited")) for f in r["flags"])}
    counted = [r for n, r in graded.items() if n not in doubtful and r["book"]]
    lines = [f"Class summary: {len(counted)} journals counted; {len(doubtful)} left out as copies or hand edits."]
    for number, _, kind in found:
        rows = [row for r in counted for row in r["rows"] if row["exercise"] == number and row["first_prediction"]]
        if kind == "code":
            solved = sum(row["solved"] == "yes" for r in counted for row in r["rows"] if row["exercise"] == number)
            lines.append(f"  {number}. {solved} of {len(counted)} solved")
            continue
        right = [row for row in rows if row["right"] != "" and row["right"] == row["items"]]
        wrong = collections.Counter(row["first_prediction"] for row in rows if row not in right).most_common(1)
        lines.append(f"  {number}. {len(right)} of {len(rows)} first predictions wholly right; most common wrong:"
                     f" {shown(wrong[0][0], 80) + f' ({wrong[0][1]})' if wrong else 'none'};"
                     f" {sum(row['attempts'] > 1 for row in rows)} changed their answer")
    return "\n".join(lines) + "\n"
