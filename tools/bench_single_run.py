"""Benchmark: what batched force laws cost the default run, which steps one body.

    python tools/bench_single_run.py                    # wall-clock, interleaved, best of 9 (about a minute)
    python tools/bench_single_run.py --instructions     # and instructions under valgrind (a few minutes)
    python tools/bench_single_run.py --before 5646fd7   # and a whole run of an earlier commit (git archive)

Every force law takes one body, (3,), or a batch, (N, 3), with the same code (the system contract in
engine.py). `python engine.py` steps one body, so the question is what that generality costs it. The
same default run (orbit, three integrators, 2,000 steps, with its recording) is run in three forms, each
in a fresh interpreter by tools/single_run_forms.py:

  batched     engine.py as it is
  one body    the orbit's force written for one body only: `/ (r * r * r)` without `[..., None]`
  chapter     one body, and energy evaluated at every step as the chapter's loop does: a contract for one
              body cannot hand simulate() a chunk of states to evaluate at once

All three must write the same metrics.json, byte for byte (checked): only the cost differs. Beside them:
`python engine.py` itself (run as a script, it is compiled again on every run) and, with --before, the
engine of an earlier commit, imported the same way as the three forms. Wall-clock
on these virtual machines moves with the host, so the forms are interleaved and the best of 9 is kept;
instructions (`valgrind --tool=callgrind`) do not move, and are the figure to compare. They are counted
with OPENBLAS_NUM_THREADS=1, so that OpenBLAS's idle threads, which spin for as long as a run lasts, do
not count. Not a test (pytest does not collect it): nothing here is asserted in CI.
"""

import argparse
import concurrent.futures
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FORMS = ("batched", "one body", "chapter")
ROUNDS = 9


def command(form: str, out: Path, before: Path | None) -> list[str]:
    if form == "script":  # what the student types: __main__ is compiled afresh on every run
        return [sys.executable, str(ROOT / "engine.py"), "--out", str(out)]
    if form == "before":
        return [sys.executable, str(HERE / "single_run_forms.py"), "batched", str(before), str(out)]
    return [sys.executable, str(HERE / "single_run_forms.py"), form, str(ROOT), str(out)]


def environment() -> dict:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONHASHSEED": "0"}
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # compiled once, like a student's second run
    return env


def instructions(cmd: list[str]) -> int:
    done = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", *cmd],
                          capture_output=True, text=True, env=environment(), check=True)
    return int(re.search(r"Collected : (\d+)", done.stderr).group(1))


def seconds(cmd: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=environment())
    return time.perf_counter() - start


def export(commit: str, into: Path) -> Path:
    """The tree of `commit`, unpacked under `into` (git archive: no checkout is touched)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit], check=True, capture_output=True).stdout
    folder = into / commit
    folder.mkdir()
    with tempfile.TemporaryFile() as tar:
        tar.write(archive)
        tar.seek(0)
        tarfile.open(fileobj=tar).extractall(folder, filter="data")
    return folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--instructions", action="store_true", help="also count instructions under valgrind")
    parser.add_argument("--before", metavar="COMMIT", help="also run engine.py as it was at COMMIT")
    args = parser.parse_args()
    if args.instructions and shutil.which("valgrind") is None:
        sys.exit("--instructions needs valgrind (apt-get install valgrind)")

    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        before = export(args.before, scratch) if args.before else None
        forms = [*FORMS, "script", *(["before"] if before else [])]
        outs = {form: scratch / f"out-{i}" for i, form in enumerate(forms)}
        cmds = {form: command(form, outs[form], before) for form in forms}
        floor = [sys.executable, "-c", "import numpy, rerun"]
        for cmd in [*cmds.values(), floor]:
            subprocess.run(cmd, check=True, capture_output=True, env=environment())  # compiles, warms caches
        metrics = {form: (outs[form] / "metrics.json").read_bytes() for form in [*FORMS, "script"]}
        assert len(set(metrics.values())) == 1, "every form must write the same metrics.json"
        print("every form of today's engine wrote the same metrics.json, byte for byte")

        best = dict.fromkeys([*forms, "floor"], float("inf"))
        for _ in range(ROUNDS):  # interleaved: a slow spell of the host hits every form alike
            for form, cmd in [*cmds.items(), ("floor", floor)]:
                best[form] = min(best[form], seconds(cmd))
        counted = {}
        if args.instructions:
            with concurrent.futures.ThreadPoolExecutor(os.cpu_count() or 1) as pool:
                counted = dict(zip([*forms, "floor"], pool.map(instructions, [*cmds.values(), floor]), strict=True))

    labels = {"batched": "batched (engine.py)", "one body": "orbit force for one body",
              "chapter": "one body, energy every step", "script": "python engine.py itself",
              "before": f"engine.py at {args.before}", "floor": "import numpy, rerun"}
    print(f"\nthe default run, whole, in a fresh interpreter (engine imported as a module, so compiled once,"
          f" except in\n'python engine.py itself'); wall-clock best of {ROUNDS}, interleaved")
    header = f"{'form':<32}{'seconds':>9}{'vs batched':>12}"
    print(header + (f"{'instructions':>17}{'vs batched':>12}" if counted else ""))
    for form in [*forms, "floor"]:
        row = f"{labels[form]:<32}{best[form]:>9.3f}{best[form] / best['batched']:>12.3f}"
        if counted:
            row += f"{counted[form]:>17,}{counted[form] / counted['batched']:>12.3f}"
        print(row)


if __name__ == "__main__":
    main()
