"""How long each exercise takes to answer, run as a student runs it: a fresh interpreter, imports included.

    python tools/bench_exercises.py            # best of 3 per command; the target is under 10 s each

Then the board, `python -m exercises`, on the journal those runs wrote (a scratch one, never the checkout's):
its target is half a second. Not collected by pytest (no test_ prefix): timings are measured, never asserted.
docs/DEVELOPING.md quotes its output.
"""

import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from curriculum.common.exercise import exercises  # noqa: E402  (the repo is importable from here on)

TARGET_SECONDS, BOARD_SECONDS = 10.0, 0.5


def commands() -> list:
    """Each exercise bare, and every command ANSWERS.md pastes (the ones that measure), as a student first runs
    it (without --more) and as pasted: found, not listed."""
    answers = (REPO / "exercises" / "solutions" / "ANSWERS.md").read_text()
    pasted = re.findall(r"`(python -m exercises\.\S+ [^`]+)`[^`\n]*\n\n```", answers)
    pasted = [short for command in pasted for short in dict.fromkeys([command.replace(" --more", ""), command])]
    bare = [f"python -m exercises.{name}" for _, name, kind in exercises(REPO / "exercises") if kind == "predict"]
    checkers = [f"python -m exercises.check_ex{number}" for number, _, kind in exercises(REPO / "exercises")
                if kind == "code"]
    return [*bare, *checkers, *pasted]


def wall_seconds(command: str, journal: Path) -> float:
    started = time.perf_counter()
    subprocess.run([sys.executable, *command.split()[1:]], cwd=REPO, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, check=False, env={**os.environ, "COURSE_JOURNAL": str(journal)})
    return time.perf_counter() - started


def main() -> int:
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"python {platform.python_version()}, {os.cpu_count()} cores, load average {load:.1f} at the start")
    print(f"{'best of 3, s':>12}  command")
    slowest = 0.0
    with tempfile.TemporaryDirectory() as scratch:
        journal = Path(scratch) / "journal.jsonl"
        for command in commands():
            best = min(wall_seconds(command, journal) for _ in range(3))
            slowest = max(slowest, best)
            print(f"{best:>12.2f}  {command}")
        verdict = "PASS" if slowest < TARGET_SECONDS else "MISS"
        print(f"slowest {slowest:.2f} s (target: every exercise under {TARGET_SECONDS:g} s: {verdict})")
        board = min(wall_seconds("python -m exercises", journal) for _ in range(5))
        lines = len(journal.read_text().splitlines())
        verdict = "PASS" if board < BOARD_SECONDS else "MISS"
        print(f"{board:>12.2f}  python -m exercises, best of 5, on the {lines} lines those runs recorded"
              f" (target: under {BOARD_SECONDS:g} s: {verdict})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
