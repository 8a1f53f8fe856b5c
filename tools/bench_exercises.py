"""How long each exercise takes to answer, run as a student runs it: a fresh interpreter, imports included.

    python tools/bench_exercises.py            # best of 3 per command; the target is under 10 s each

Not collected by pytest (no test_ prefix): timings are measured, never asserted. exercises/README.md
quotes its output.
"""

import os
import platform
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TARGET_SECONDS = 10.0
COMMANDS = [
    "python -m exercises.ex1_band",
    "python -m exercises.ex1_band --predict euler=grows,semi_implicit=grows,rk4=grows",
    "python -m exercises.check_ex2",
    "python -m exercises.check_ex2 exercises/solutions/ex2_integrators.py",
    "python -m exercises.ex3_halve_dt --predict euler=1,semi_implicit=1,rk4=1",
    "python -m exercises.ex3_halve_dt --predict euler=1,semi_implicit=1,rk4=1 --system spring",
    "python -m exercises.ex4_long_run --predict 10",
    "python -m exercises.ex5_phase_blob --predict euler=stays,semi_implicit=stays,rk4=stays",
    "python -m exercises.ex6_stiff_damping --predict none",
]


def wall_seconds(command: str) -> float:
    started = time.perf_counter()
    subprocess.run([sys.executable, *command.split()[1:]], cwd=REPO, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - started


def main() -> int:
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"python {platform.python_version()}, {os.cpu_count()} cores, load average {load:.1f} at the start")
    print(f"{'best of 3, s':>12}  command")
    slowest = 0.0
    for command in COMMANDS:
        best = min(wall_seconds(command) for _ in range(3))
        slowest = max(slowest, best)
        print(f"{best:>12.2f}  {command}")
    verdict = "PASS" if slowest < TARGET_SECONDS else "MISS"
    print(f"slowest {slowest:.2f} s (target: every exercise under {TARGET_SECONDS:g} s: {verdict})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
