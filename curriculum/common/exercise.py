"""What every exercise shares: its first line, and how the course finds its exercises.

    import sys

    from curriculum.common.exercise import start

    start(__file__)  # first: Ctrl-C is one line from here on, and the exercise runs as a file too

- `start(__file__)` installs the signal guard (curriculum.common.interrupts) before anything heavy loads
  (only in the exercise being run: a test that imports one installs nothing),
  and, when the exercise is run as a file (`python exercises/ex1_band.py`, or from inside exercises/),
  puts the repo on the import path so `import engine` and `import exercises.support...` work as they do
  under `python -m exercises.ex1_band`. It loads nothing heavy.
- `exercises(folder)` lists a chapter's exercises by file name, `exN_topic.py`, in order. An exercise with a
  checker beside it (`check_exN.py`) is one the student writes; the others are predict-then-run. The tests
  and `tools/bench.py exercises` read this list, so a new exercise needs no list edited (see docs/DEVELOPING.md).
- `titles(folder)` reads each exercise's title from the headings of its README.md (`## 3. Halve the timestep`),
  `command(module, kind)` says how a student starts one, and `next_line(folder, number)` is the one line
  that ends every exercise's run: the next exercise's command, or after the last, where to read on.
"""

import re
import sys
from pathlib import Path

from curriculum.common.interrupts import install

EXERCISE_FILE = re.compile(r"ex(\d+)_\w+\.py")
EXERCISES = Path(__file__).resolve().parents[2] / "exercises"  # this chapter's: beside curriculum/
READ_ON = "exercises/solutions/ANSWERS.md, the answers with the commands that print them"  # after the last one


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
    return f'Next: exercise {n}, "{titles(folder).get(n, module)}": {command(module, kind)}'
