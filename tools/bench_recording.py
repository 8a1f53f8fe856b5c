"""Benchmark: what engine_recording.record() costs, and how big the .rrd is, for the default runs and a long one.

    python tools/bench_recording.py        # about a minute on 2 cores (the 200,000-step runs dominate)

Not a test (pytest does not collect it): timings vary with the machine. Targets (issue 8): record()
under 0.1 s for a default run and under 1 s for 200,000 steps; the default run's .rrd under 1 MB.
record() builds the .rrd in memory; writing it to disk is write_run()'s job and is not timed here.
The runs are simulated first and not timed; `import rerun` is paid once, before any timing, and
reported on its own line, because main() pays it whether the recording is cheap or not; so is
numpy.ma, which rerun imports on the first point it converts. "first" is a record() call in a fresh
process after those imports, "best of rest" the fastest of the repeats that follow.
"""

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import engine  # noqa: E402
import engine_recording  # noqa: E402

REPEATS = 5


def simulated(system_name, steps, dt=0.01):
    system = engine.build_system(system_name, np.random.default_rng(0))
    every = math.ceil((steps + 1) / engine.MAX_POINTS_PER_SERIES)  # as main() thins them
    steps_of = engine.integrators_for(system)
    runs = {name: engine.simulate_long(step, system, dt, steps, every) for name, step in steps_of.items()}
    return system, runs, engine.kept_steps(steps, every), dt


def main() -> int:
    started = time.perf_counter()
    import rerun  # noqa: F401

    print(f"import rerun: {time.perf_counter() - started:.2f} s (paid once per process, before any timing)")
    started = time.perf_counter()
    import numpy.ma  # noqa: F401  (rerun imports it lazily, on the first point it converts)

    print(f"import numpy.ma: {time.perf_counter() - started:.2f} s (the same, for rerun's first point)")
    print(f"{'run':<24}{'record() first':>16}{'best of rest':>14}{'.rrd size':>12}")
    cases = [(name, 2000) for name in engine.SYSTEMS] + [("orbit", 200_000)]
    for system_name, steps in cases:
        system, runs, kept, dt = simulated(system_name, steps)
        times = []
        for _ in range(REPEATS if steps <= 2000 else 3):
            start = time.perf_counter()
            data, _ = engine_recording.record(system, runs, kept, dt, run_id=f"bench-{system_name}-{steps}")
            times.append(time.perf_counter() - start)
        label = f"{system_name} {steps:,} steps"
        print(f"{label:<24}{times[0]:>14.3f} s{min(times[1:]):>12.3f} s{len(data) / 1e6:>9.2f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
