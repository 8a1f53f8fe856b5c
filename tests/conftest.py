"""Helpers shared by the tests: run engine.py the way a student does."""

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ENGINE = REPO / "engine.py"


def run_engine(*args, cwd=None, env=None, timeout=120):
    """`python engine.py ARGS` in a fresh interpreter; returns the CompletedProcess."""
    return subprocess.run([sys.executable, str(ENGINE), *map(str, args)], cwd=cwd or REPO, env=env,
                          capture_output=True, text=True, timeout=timeout)
