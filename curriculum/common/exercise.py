"""What every exercise shares: its first line, `start(__file__)`, and how the course finds its exercises
(`exN_topic.py`; one with a checker `check_exN.py` beside it is one the student writes), their titles and commands."""

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
    """The signal guard (in the exercise being run), and the repo importable however the exercise was started."""
    path = Path(file).resolve()
    if sys._getframe(1).f_globals.get("__name__") == "__main__":
        install(f"exercises.{path.stem}")
    repo = str(path.parents[1])
    if repo not in sys.path:
        sys.path.insert(0, repo)


def exercises(folder) -> list:
    """[(number, module name, "code" or "predict")] for every exN_topic.py in `folder`, by number."""
    found = [(match[1], path) for path in Path(folder).iterdir() if (match := EXERCISE_FILE.fullmatch(path.name))]
    return sorted((int(n), path.stem, "code" if (path.parent / f"check_ex{n}.py").exists() else "predict")
                  for n, path in found)


def titles(folder) -> dict:
    """{number: title} from README.md's headings: '## 1. Grow, or stay in a band? (predict, then run)'."""
    text = (Path(folder) / "README.md").read_text(encoding="utf-8")
    return {int(n): title for n, title in re.findall(r"^## (\d+)\. (.+?)(?: \([^)]*\))?\s*$", text, flags=re.M)}


def command(module: str, kind: str) -> str:
    if kind == "code":
        return f"write exercises/{module}.py, then python -m exercises.check_ex{EXERCISE_FILE.match(module + '.py')[1]}"
    return f"python -m exercises.{module}"


def announce(folder, n: int, module: str, kind: str) -> str:
    """The Next line that sends a student to exercise `n`, the same from a run and from the board."""
    return f'Next: {READ_FIRST.get(n, "")}exercise {n}, "{titles(folder).get(n, module)}": {command(module, kind)}'
