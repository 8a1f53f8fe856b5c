"""What every exercise shares: its first line, and how the course finds its exercises.

- `start(__file__)`, an exercise's first line: the signal guard (only in the exercise being run), and the repo on
  the import path, so `python exercises/ex1_band.py` works as `python -m exercises.ex1_band` does.
- `exercises(folder)`: a chapter's exercises from their file names, `exN_topic.py`, in order; one with a checker
  beside it (`check_exN.py`) is one the student writes. `titles(folder)` reads their titles from README.md's
  headings, `command(module, kind)` says how a student starts one, and `next_line(folder, number)` is the line that
  ends every exercise's run: the next exercise's command, or after the last, where to read on.
"""

import re
import sys
from pathlib import Path

from curriculum.common.interrupts import install

EXERCISE_FILE = re.compile(r"ex(\d+)_\w+\.py")
EXERCISES = Path(__file__).resolve().parents[2] / "exercises"  # this chapter's: beside curriculum/
READ_ON = "exercises/solutions/ANSWERS.md, the answers with the commands that print them"  # after the last one
# Where README.md sends the student to read engine.py: after exercise 5, whose answers (and 3's) its declarations state
READ_FIRST = {6: "read engine.py top to bottom (README.md maps the chapter's code to it), then "}


def start(file: str) -> None:
    """The first line of an exercise: the signal guard, then the repo importable however it was started."""
    path = Path(file).resolve()
    if sys._getframe(1).f_globals.get("__name__") == "__main__":  # the exercise being run, not one imported
        install(f"exercises.{path.stem}")
    repo = str(path.parents[1])
    if repo not in sys.path:
        sys.path.insert(0, repo)


def exercises(folder) -> list:
    """[(number, module name, kind)] for every exN_topic.py in `folder`, by number; kind is "code" for an
    exercise with a checker check_exN.py beside it, "predict" for a predict-then-run one."""
    found = []
    for path in Path(folder).iterdir():
        match = EXERCISE_FILE.fullmatch(path.name)
        if match:
            kind = "code" if (path.parent / f"check_ex{match.group(1)}.py").exists() else "predict"
            found.append((int(match.group(1)), path.stem, kind))
    return sorted(found)


def titles(folder) -> dict:
    """{number: title} from README.md's headings: '## 1. Grow, or stay in a band? (predict, then run)'."""
    text = (Path(folder) / "README.md").read_text(encoding="utf-8")
    return {int(n): title for n, title in re.findall(r"^## (\d+)\. (.+?)(?: \([^)]*\))?\s*$", text, flags=re.M)}


def command(module: str, kind: str) -> str:
    """How a student starts an exercise: the bare question, or, for code, the file to write and its checker."""
    if kind == "code":
        return f"write exercises/{module}.py, then python -m exercises.check_ex{EXERCISE_FILE.match(module + '.py')[1]}"
    return f"python -m exercises.{module}"


def next_line(folder, number: int) -> str:
    """'Next: exercise 3, "Halve the timestep": python -m exercises.ex3_halve_dt'; after the last, where to read on."""
    later = [(n, module, kind) for n, module, kind in exercises(folder) if n > number]
    if not later:
        return f"Next: that was the last one. python -m exercises shows what is left; then read {READ_ON}."
    n, module, kind = later[0]
    return f'Next: {READ_FIRST.get(n, "")}exercise {n}, "{titles(folder).get(n, module)}": {command(module, kind)}'
