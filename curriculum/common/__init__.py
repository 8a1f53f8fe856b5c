"""What every chapter script shares: the banner, flag parsing, progress lines, safe output files,
predict-then-run, the signal guard a script installs first.

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
