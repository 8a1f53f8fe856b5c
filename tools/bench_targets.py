"""The whole-run speed targets of issue 23, measured as whole processes, side by side, medians.

    python tools/bench_targets.py                 # this checkout, 7 rounds (about 2 minutes)
    python tools/bench_targets.py --root . --root ../old   # two checkouts' engine.py, interleaved

Each round runs every command once, in turn, so a load that comes and goes touches all of them alike;
the table gives each command's median and the ratio the target is about:

    python engine.py                                   within 1.2x of python -c "import numpy, rerun"
    python engine.py --smoke --no-rerun                 at most 0.4x the chapter's engine (bench_baseline.py)
    100,000 semi-implicit orbit steps, --no-rerun       at most 0.6x the chapter's engine
    50,000 RK4 orbit steps, --no-rerun                  at most 0.9x the chapter's engine

tools/bench_baseline.py is the chapter's own listing, run as a script. Timings move with the machine:
this prints them and asserts nothing.
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
BASELINE = HERE / "bench_baseline.py"
CASES = [  # label, engine.py's flags, what it is held against (flags for the baseline, or None: the imports), target
    ("python engine.py", [], None, 1.2),
    ("--smoke --no-rerun", ["--smoke", "--no-rerun"], ["--smoke", "--no-rerun"], 0.4),
    ("100,000 semi_implicit steps", ["--integrator", "semi_implicit", "--steps", "100000", "--no-rerun"],
     ["--integrator", "semi_implicit", "--steps", "100000", "--no-rerun"], 0.6),
    ("50,000 rk4 steps", ["--integrator", "rk4", "--steps", "50000", "--no-rerun"],
     ["--integrator", "rk4", "--steps", "50000", "--no-rerun"], 0.9),
]


def seconds(command, cwd) -> float:
    started = time.perf_counter()
    subprocess.run(command, cwd=cwd, check=True, capture_output=True)
    return time.perf_counter() - started


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", type=Path, action="append", help="a checkout whose engine.py runs (repeatable;"
                        " default this one)")
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args(argv)
    roots = [root.resolve() for root in args.root or [HERE.parent]]
    with tempfile.TemporaryDirectory() as out:
        commands = {}
        for label, flags, against, _ in CASES:
            for root in roots:
                commands[label, root] = [sys.executable, str(root / "engine.py"), *flags, "--out", f"{out}/e"], root
            commands[label, "against"] = ([sys.executable, "-c", "import numpy, rerun"] if against is None else
                                          [sys.executable, str(BASELINE), *against, "--out", f"{out}/b"]), HERE
        times = {key: [] for key in commands}
        for _ in range(args.rounds):
            for key, (command, cwd) in commands.items():
                times[key].append(seconds(command, cwd))
    print(f"median of {args.rounds} rounds, seconds; against: the imports, or the chapter's engine")
    for root in roots:
        print(f"\n{root / 'engine.py'}")
        print(f"{'run':<30}{'engine.py':>10}{'against':>10}{'ratio':>8}")
        for label, _, _, target in CASES:
            mine, theirs = (statistics.median(times[label, side]) for side in (root, "against"))
            print(f"{label:<30}{mine:>10.3f}{theirs:>10.3f}{mine / theirs:>7.2f}x  (target <= {target}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
