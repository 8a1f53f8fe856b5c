"""Benchmark: what stepping many seeds at once buys, against single runs and MuJoCo's own batch runner.

    python tools/bench_ensemble.py           # about two minutes on a quiet machine
    python tools/bench_ensemble.py --full    # single runs and rollout on all 10,000 members (much longer)

Not a test (pytest does not collect it: the name does not start with test_): timings vary with the
machine, so targets are printed as PASS/MISS and never asserted. Everything is one process, side by side:
  1. 10,000 spring seeds x 2,000 steps, semi-implicit Euler: the ensemble against single runs of the same
     members (target: >= 100x less time per member-step) and against mujoco.rollout on one thread with
     the same initial states (target: >= 50x less); the orbit ensemble against single runs likewise.
  2. cost per member-step as N grows, 1 to 100,000, and the floor that memory traffic puts under it.
Single runs and rollout are timed on the first members only unless --full: the figure compared is time
per member-step, which does not depend on how many members are timed (every member does the same work).
"""

import argparse
import functools
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE)]

import engine  # noqa: E402
import engine_ensembles  # noqa: E402
from bench import best_seconds  # noqa: E402  (one timing helper for every bench)

MEMBERS, STEPS, DT = 10_000, 2_000, 0.01
SAMPLE = 100  # members timed one by one (single runs, rollout) unless --full
SIZES = [1, 10, 100, 1_000, 10_000, 100_000]


def ensemble_ns(system_name, integrator, members, steps, repeats=3):
    """ns per member-step of simulate() on an ensemble, energy every step as the engine does it."""
    system = engine_ensembles.build_ensemble(functools.partial(engine.build_system, system_name), range(members))
    # keep only the first and last states, as --ensemble keeps few: what is timed is the stepping
    seconds = best_seconds(lambda: engine.simulate_long(engine.INTEGRATORS[integrator], system, DT, steps, every=steps),
                           repeats)
    return seconds / (members * steps) * 1e9


def singles_ns(system_name, integrator, members, steps):
    """ns per member-step of the same members run one at a time (build_system and simulate_long, as main() does)."""
    step = engine.INTEGRATORS[integrator]
    singles = [engine.build_system(system_name, np.random.default_rng(seed)) for seed in range(members)]
    seconds = best_seconds(lambda: [engine.simulate_long(step, system, DT, steps) for system in singles], repeats=1)
    return seconds / (members * steps) * 1e9


def rollout_ns(system_name, members, steps):
    """ns per member-step of mujoco.rollout (mjINT_EULER, one thread) from the same initial states."""
    from mujoco import rollout

    from mujoco_rollout import initial_states, rollout_model

    system = engine_ensembles.build_ensemble(functools.partial(engine.build_system, system_name), range(members))
    model, data, _ = rollout_model(system_name, "semi_implicit", DT)
    start = initial_states(model, data, system["q0"], system["v0"])
    out = np.empty((members, steps, start.shape[1]))
    seconds = best_seconds(lambda: rollout.rollout(model, data, start, nstep=steps, state=out), repeats=1)
    return seconds / (members * steps) * 1e9


def bandwidth_gbs(values):
    """Sustained bytes/s of one numpy pass c = a + b over arrays of `values` doubles (read 2, write 1)."""
    a, b, c = np.ones(values), np.ones(values), np.empty(values)
    seconds = best_seconds(lambda: [np.add(a, b, out=c) for _ in range(20)], repeats=5) / 20
    return 3 * 8 * values / seconds / 1e9


def verdict(ratio, target):
    return f"(target >= {target}x: {'PASS' if ratio >= target else 'MISS'})"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--full", action="store_true", help="time single runs and rollout on all 10,000 members")
    args = parser.parse_args(argv)
    sample = MEMBERS if args.full else SAMPLE
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}; ns per member-step, best of 3 (singles: 1 pass)")

    print(f"\n1. {MEMBERS:,} seeds x {STEPS:,} steps, dt {DT}")
    print(f"{'system':<9}{'integrator':<15}{'ensemble':>10}{'single runs':>13}{'speed-up':>10}")
    rows = {}
    for system_name in ("spring", "orbit"):
        for integrator in ("semi_implicit", "rk4"):
            together = ensemble_ns(system_name, integrator, MEMBERS, STEPS)
            alone = singles_ns(system_name, integrator, sample, STEPS)
            rows[system_name, integrator] = together, alone
            print(f"{system_name:<9}{integrator:<15}{together:>10.1f}{alone:>13.0f}{alone / together:>9.0f}x")
    spring, orbit = rows["spring", "semi_implicit"], rows["orbit", "semi_implicit"]
    for name, (together, alone) in (("spring", spring), ("orbit", orbit)):
        print(f"{name} semi-implicit ensemble vs single runs: {alone / together:.0f}x {verdict(alone / together, 100)}")
    try:
        theirs = rollout_ns("spring", sample, STEPS)
    except ImportError:
        print("mujoco.rollout: skipped, mujoco is not installed (pip install -e '.[mujoco]')")
    else:
        ratio = theirs / spring[0]
        print(f"spring semi-implicit ensemble vs mujoco.rollout mjINT_EULER, one thread ({theirs:.0f} ns):"
              f" {ratio:.0f}x {verdict(ratio, 50)}")
    if not args.full:
        print(f"(single runs and rollout timed on the first {sample} members; --full times all {MEMBERS:,})")

    print("\n2. cost per member-step as the ensemble grows (semi-implicit Euler, energy every step)")
    print(f"{'N':>9}{'steps':>7}{'spring':>10}{'orbit':>10}")
    for members in SIZES:
        steps = min(STEPS, max(20, 2_000_000 // members))
        print(f"{members:>9,}{steps:>7}{ensemble_ns('spring', 'semi_implicit', members, steps):>10.1f}"
              f"{ensemble_ns('orbit', 'semi_implicit', members, steps):>10.1f}")

    # The floor: the spring's semi-implicit step and energy are ~20 numpy passes over (N, 3) or (N,)
    # arrays (see FLOOR_BYTES); at large N each pass streams its operands through memory.
    cache, dram = bandwidth_gbs(30_000), bandwidth_gbs(30_000_000)
    print(f"\nnumpy c = a + b: {cache:.0f} GB/s on 240 kB arrays (cache), {dram:.0f} GB/s on 240 MB arrays (memory)")
    print(f"spring semi-implicit moves about {FLOOR_BYTES} bytes per member-step: floor {FLOOR_BYTES / cache:.1f} ns"
          f" from cache, {FLOOR_BYTES / dram:.1f} ns from memory")


# Bytes one spring member moves per semi-implicit step in simulate(), each numpy pass's reads and writes:
# the step, 4 passes that read one (N, 3) array and write one (-k*q, /m, dt*a, dt*v: 4 * 48) and 2 that
# read two (v+, q+: 2 * 72) = 336; recording the state, q and v (2 * 48) = 96; the energy, once over the
# recorded states, per dot3 three products whose strided reads pull whole 24-byte rows and write 8 (3 * 32)
# and two adds (2 * 24), then a scale (16), twice, and the sum (24) = 344; storing it, 16. About 800 bytes,
# and no pass can go faster than the bandwidth it streams at.
FLOOR_BYTES = 800


if __name__ == "__main__":
    main()
