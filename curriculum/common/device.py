"""The banner every chapter prints first, and the wall-clock line it prints last,
so that a pasted log says where it ran and how long it took."""

import platform
import sys
import time

# Every chapter has a free tier that runs on any laptop CPU; chapters with a GPU
# tier name it here. Chapter 3.3 is pure numpy, so it only ever runs on "cpu".
TIERS = {"cpu": "free"}


def banner(chapter: str, device: str = "cpu", stream=None) -> str:
    """Print and return one line: chapter id, tier and device, Python and numpy versions.

    Nothing here is measured and nothing goes into metrics.json: it is only there so
    that a log pasted into a forum post says which machine and versions produced it.
    """
    if device not in TIERS:
        raise ValueError(f"unknown device {device!r}; this course knows {sorted(TIERS)}")
    import numpy as np  # here, not at the top: importing curriculum.common stays light

    line = (
        f"[{chapter}] tier: {TIERS[device]} ({device}) | "
        f"python {platform.python_version()} | numpy {np.__version__}"
    )
    print(line, file=stream or sys.stdout, flush=True)
    return line


def wall_clock(started: float, stream=None) -> str:
    """Print and return `wall-clock: 0.54 s`, the time since `started` (a time.perf_counter() reading).

    Printed, never written to metrics.json: it differs from run to run.
    """
    line = f"wall-clock: {time.perf_counter() - started:.2f} s"
    print(line, file=stream or sys.stdout, flush=True)
    return line
