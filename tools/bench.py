"""Benchmarks, printed and never asserted (timings vary with the machine); docs/DEVELOPING.md ("Speed") and
docs/ensembles.md paste them. `python tools/bench.py NAME`, NAME one of

    targets [--root DIR ...]  whole runs against `import numpy, rerun` or the chapter's engine, tools/bench_baseline.py
    ensemble                  many seeds at once against single runs and mujoco.rollout
    recording                 record()'s time and the .rrd's size
    exercises                 each exercise as a student runs it, and the board
"""

import argparse
import functools
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import timeit
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # the engine, and the MuJoCo models
import engine  # noqa: E402
import engine_ensembles  # noqa: E402

TARGETS = [  # label, engine.py's flags, held against the chapter's engine on the same flags (or the imports), at most
    ("python engine.py", "", False, 1.15),
    ("--smoke --no-rerun", "--smoke --no-rerun", True, 0.3),
    ("100,000 semi_implicit orbit steps", "--no-rerun --integrator semi_implicit --steps 100000", True, 0.58),
    ("50,000 rk4 orbit steps", "--no-rerun --integrator rk4 --steps 50000", True, 0.85),
]
FLOOR = [sys.executable, "-c", "import numpy, rerun"]  # what the default run cannot avoid


def best_seconds(fn, repeats=5):
    return min(timeit.repeat(fn, number=1, repeat=repeats))


def load():
    return f"load average {os.getloadavg()[0]:.1f}"


def targets(roots, rounds):
    env = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {max(os.sched_getaffinity(0))})  # children inherit the one core
    print(f"{load()}; {rounds} rounds, cores {sorted(os.sched_getaffinity(0))}")
    with tempfile.TemporaryDirectory() as out:
        commands = {}
        for label, flags, against_chapter, _ in TARGETS:
            for root in roots:
                commands[label, root] = [sys.executable, str(root / "engine.py"), *flags.split(), "--out", f"{out}/e"]
            chapter_run = [sys.executable, str(HERE / "bench_baseline.py"), *flags.split(), "--out", f"{out}/b"]
            commands[label, "against"] = chapter_run if against_chapter else FLOOR
        times = {key: [] for key in commands}
        for round_ in range(rounds + 1):  # round 0 writes the bytecode and warms the caches: not counted
            for key, command in commands.items():
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                subprocess.run(command, cwd=ROOT, check=True, capture_output=True, env=env)
                after = resource.getrusage(resource.RUSAGE_CHILDREN)  # CPU seconds: a load does not stretch them
                if round_:
                    times[key].append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    print(f"{load()}; medians, CPU seconds; against: the chapter's engine, or `import numpy, rerun` (the default run)")
    for root in roots:
        print(f"\n{root / 'engine.py'}\n{'run':<36}{'engine.py':>10}{'against':>10}{'ratio':>8}")
        for label, _, _, target in TARGETS:
            mine, theirs = (statistics.median(times[label, side]) for side in (root, "against"))
            verdict = "PASS" if mine / theirs <= target else "MISS"
            print(f"{label:<36}{mine:>10.3f}{theirs:>10.3f}{mine / theirs:>7.2f}x  (target <= {target}x: {verdict})")


def ensemble_ns(system_name, integrator, members, steps, repeats=3):
    """ns per member-step of simulate_long() on an ensemble, keeping the last state (--ensemble keeps few)."""
    system = engine_ensembles.build_ensemble(functools.partial(engine.build_system, system_name), range(members))
    step = engine.INTEGRATORS[integrator]
    return best_seconds(lambda: engine.simulate_long(step, system, 0.01, steps, every=steps), repeats) / (
        members * steps) * 1e9


def ensemble(members=10_000, steps=2_000, sample=100):
    """The ensemble against its first members run one by one and the spring's against mujoco.rollout on one thread
    (per member-step: every member does the same work); then the cost as N grows, and memory traffic's floor."""
    print(f"{load()}; ns per member-step, best of 3 (single runs and rollout: 1 pass over {sample} members)")
    print(f"\n1. {members:,} seeds x {steps:,} steps, dt 0.01\n{'system':<9}{'integrator':<15}{'ensemble':>10}"
          f"{'single runs':>13}{'speed-up':>10}")
    together = {}
    for system_name in ("spring", "orbit"):
        for integrator in ("semi_implicit", "rk4"):
            step = engine.INTEGRATORS[integrator]
            together[system_name, integrator] = ensemble_ns(system_name, integrator, members, steps)
            singles = [engine.build_system(system_name, np.random.default_rng(seed)) for seed in range(sample)]
            seconds = best_seconds(lambda: [engine.simulate_long(step, s, 0.01, steps) for s in singles], 1)  # noqa: B023
            alone, ours = seconds / (sample * steps) * 1e9, together[system_name, integrator]
            target = "  (target >= 100x)" if integrator == "semi_implicit" else ""
            print(f"{system_name:<9}{integrator:<15}{ours:>10.1f}{alone:>13.0f}{alone / ours:>9.0f}x{target}")
    try:
        from mujoco import rollout
    except ImportError:
        print("mujoco.rollout: skipped, mujoco is not installed (pip install -e '.[mujoco]')")
    else:
        from figures import rollout_start

        system = engine_ensembles.build_ensemble(functools.partial(engine.build_system, "spring"), range(sample))
        model, data, start = rollout_start("spring", "semi_implicit", 0.01, system["q0"], system["v0"])
        out = np.empty((sample, steps, start.shape[1]))
        theirs = best_seconds(lambda: rollout.rollout(model, data, start, nstep=steps, state=out), 1)
        theirs = theirs / (sample * steps) * 1e9
        print(f"spring semi-implicit ensemble vs mujoco.rollout mjINT_EULER, one thread ({theirs:.0f} ns):"
              f" {theirs / together['spring', 'semi_implicit']:.0f}x (target >= 50x)")
    print(f"\n2. cost per member-step as the ensemble grows (semi-implicit Euler)\n{'N':>9}{'steps':>7}{'spring':>10}"
          f"{'orbit':>10}")
    for n in (1, 10, 100, 1_000, 10_000, 100_000):
        count = min(steps, max(20, 2_000_000 // n))
        print(f"{n:>9,}{count:>7}" + "".join(f"{ensemble_ns(s, 'semi_implicit', n, count):>10.1f}"
                                             for s in ("spring", "orbit")))
    # the floor: the 800 bytes a spring member's step moves (counted in docs/ensembles.md) at numpy's bandwidth
    a, b, c = (np.ones(30_000_000) for _ in range(3))  # c = a + b reads 2 and writes 1: 24 bytes a value
    cache, dram = (24 * n / best_seconds(lambda n=n: np.add(a[:n], b[:n], out=c[:n])) / 1e9 for n in (30_000, len(a)))
    print(f"\nnumpy c = a + b: {cache:.0f} GB/s on 240 kB arrays (cache), {dram:.0f} GB/s on 240 MB arrays (memory)"
          f"\nspring semi-implicit moves about 800 bytes per member-step: floor {800 / cache:.1f} ns from cache,"
          f" {800 / dram:.1f} ns from memory")


def recording():
    """Targets: record() under 0.1 s for a default run, under 1 s for 200,000 steps, a default .rrd under 1 MB.
    The runs are simulated first; `import rerun` and numpy.ma (rerun's first point) are paid before any timing."""
    import engine_recording

    started = timeit.default_timer()
    import numpy.ma  # noqa: F401
    import rerun  # noqa: F401

    print(f"{load()}; import rerun, numpy.ma: {timeit.default_timer() - started:.2f} s, paid before any timing")
    print(f"{'run':<24}{'record() first':>16}{'best of rest':>14}{'.rrd size':>12}")
    for system_name, steps in [*((name, 2000) for name in engine.SYSTEMS), ("orbit", 200_000)]:
        system = engine.build_system(system_name, np.random.default_rng(0))
        every = -(-(steps + 1) // engine.MAX_POINTS_PER_SERIES)  # as main() thins them
        runs = {name: engine.simulate_long(step, system, 0.01, steps, every)
                for name, step in engine.integrators_for(system).items()}
        record = functools.partial(engine_recording.record, system, runs, engine.kept_steps(steps, every), 0.01,
                                   run_id="bench")
        times, (data, _) = timeit.repeat(record, number=1, repeat=5 if steps <= 2000 else 3), record()
        label = f"{system_name} {steps:,} steps"
        print(f"{label:<24}{times[0]:>14.3f} s{min(times[1:]):>12.3f} s{len(data) / 1e6:>9.2f} MB")


def exercises():
    """Each exercise bare, each checker, and every command ANSWERS.md pastes (without --more, then as pasted),
    best of 3, a fresh interpreter each (target: under 10 s); then the board on the journal they wrote (0.5 s)."""
    from curriculum.common.exercise import exercises as listed

    pasted = re.findall(r"`(python -m exercises\.\S+ [^`]+)`[^`\n]*\n\n```",
                        (ROOT / "exercises" / "solutions" / "ANSWERS.md").read_text())
    commands = [*(f"python -m exercises.{name}" for _, name, kind in listed(ROOT / "exercises") if kind == "predict"),
                *(f"python -m exercises.check_ex{n}" for n, _, kind in listed(ROOT / "exercises") if kind == "code"),
                *(short for command in pasted for short in dict.fromkeys([command.replace(" --more", ""), command]))]
    print(f"{load()}, {os.cpu_count()} cores\n{'best of 3, s':>12}  command")
    with tempfile.TemporaryDirectory() as scratch:
        env = {**os.environ, "COURSE_JOURNAL": str(Path(scratch) / "journal.jsonl")}  # never the checkout's
        run = functools.partial(subprocess.run, cwd=ROOT, capture_output=True, check=False, env=env)
        slowest = 0.0
        for command in commands:
            best = best_seconds(lambda c=command: run([sys.executable, *c.split()[1:]]), 3)
            slowest = max(slowest, best)
            print(f"{best:>12.2f}  {command}")
        print(f"slowest {slowest:.2f} s (target: every exercise under 10 s)")
        board = best_seconds(lambda: run([sys.executable, "-m", "exercises"]))
        lines = len(Path(env["COURSE_JOURNAL"]).read_text().splitlines())
        print(f"{board:>12.2f}  python -m exercises, best of 5, on the {lines} journal lines those runs wrote"
              " (target: under 0.5 s)")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bench", choices=["targets", "ensemble", "recording", "exercises"])
    parser.add_argument("--root", type=Path, action="append", help="targets: a checkout whose engine.py runs"
                        " (repeatable; default this one)")
    parser.add_argument("--rounds", type=int, default=11, help="targets: rounds (default 11)")
    args = parser.parse_args()
    {"targets": lambda: targets([root.resolve() for root in args.root or [ROOT]], args.rounds),
     "ensemble": ensemble, "recording": recording, "exercises": exercises}[args.bench]()
