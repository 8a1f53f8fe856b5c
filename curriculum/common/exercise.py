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
  and tools/bench_exercises.py read this list, so a new exercise needs no list edited (see docs/DEVELOPING.md).
"""

import re
import sys
from pathlib import Path

from curriculum.common.interrupts import install

EXERCISE_FILE = re.compile(r"ex(\d+)_\w+\.py")


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
