"""What every chapter script shares: the banner, flag parsing, progress lines, safe output files,
predict-then-run, the signal guard a script installs first; and the course flow: the journal of every
prediction and check (journal.py, written by predict.py and student_code.py, never by an exercise), the
board, reset, hand-in and grader of `python -m exercises` (course.py), and the "Next:" line that ends
every exercise's run, the next exercise's command (`exercise.next_line`, from the exercises on disk and
the titles in exercises/README.md; printed by predict.ask's run once main() returned 0, and by the
checker harness).

Importing this package loads nothing heavy (no numpy, no Rerun): a script's first line can import the
guard from it before anything else. The names below load their module on first use.
"""

import importlib

_HOMES = {"OneLineParser": "cli", "int_in": "cli", "name_arg": "cli", "positive_finite": "cli",
          "progress_printer": "cli", "banner": "device", "wall_clock": "device", "write_atomic": "outputs"}
__all__ = sorted(_HOMES)


def __getattr__(name):
    if name in _HOMES:
        return getattr(importlib.import_module(f"curriculum.common.{_HOMES[name]}"), name)
    raise AttributeError(f"module 'curriculum.common' has no attribute {name!r}")
