"""The banner a chapter prints first and the wall-clock line it prints last: a pasted log says where it ran and
how long it took. Neither goes into metrics.json."""

import platform
import sys
import time


def banner(chapter: str, device: str = "cpu", stream=None) -> str:
    """Print and return one line: chapter, tier (the free tier runs on any laptop's CPU), Python and numpy versions."""
    import numpy as np  # here, not at the top: importing curriculum.common stays light

    line = f"[{chapter}] tier: free ({device}) | python {platform.python_version()} | numpy {np.__version__}"
    print(line, file=stream or sys.stdout, flush=True)
    return line


def wall_clock(started: float, stream=None) -> str:
    """Print and return `wall-clock: 0.54 s`, the time since `started` (a time.perf_counter() reading)."""
    line = f"wall-clock: {time.perf_counter() - started:.2f} s"
    print(line, file=stream or sys.stdout, flush=True)
    return line
