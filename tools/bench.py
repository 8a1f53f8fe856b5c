"""Benchmark: what a whole run costs against the imports it cannot avoid, per step against the
chapter's plain loop, and against MuJoCo's mj_step.

    python tools/bench.py            # about a minute on 2 cores

Not a test (pytest does not collect it): timings vary with the machine, so nothing here is
asserted in CI. What matters to a student is the first section: a whole run next to the time
it takes just to import numpy (and rerun, when recording). engine.py is written to read like
the chapter, not to win nanoseconds per step: the per-step table is information, compared with
tools/bench_baseline.py (the chapter's loop written plainly, one rr.log per step).
"""

import contextlib
import io
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE), str(HERE.parent / "tests")]  # the engine, the baseline, the MuJoCo models

import bench_baseline as baseline  # noqa: E402
import engine  # noqa: E402

SYSTEMS = ["orbit", "spring", "freefall"]
STEPS = 20_000
REPEATS = 5


def best_seconds(fn, repeats=REPEATS):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def ns_per_step(simulate, step_fn, system):
    return best_seconds(lambda: simulate(step_fn, system, 0.01, STEPS)) / STEPS * 1e9


def whole_run_seconds(script, *flags):
    """Best-of-N wall time of a fresh `python script flags` (interpreter start and imports included)."""
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, str(script), *flags, "--out", out]
        return best_seconds(lambda: subprocess.run(cmd, check=True, capture_output=True))


def mujoco_rows(steps=STEPS, repeats=REPEATS):
    """ns/step of mj_step on the same one-body models (tests/mujoco_models.py): a Python loop, and nstep in C."""
    try:
        import mujoco
    except ImportError:
        return None
    from mujoco_models import build, passive_force  # not under the try: a missing model module is a bug to see

    rows = {}
    for system_name in SYSTEMS:
        for integrator in ("Euler", "RK4"):
            model, data, system, _ = build(system_name, integrator)
            with passive_force(system_name, system):
                loop = best_seconds(lambda m=model, d=data: [mujoco.mj_step(m, d) for _ in range(steps)], repeats)
                nstep = best_seconds(lambda m=model, d=data: mujoco.mj_step(m, d, nstep=steps), repeats)
            rows[system_name, integrator] = (loop / steps * 1e9, nstep / steps * 1e9)
    return rows, mujoco.__version__


def import_seconds(*modules):
    """Best-of-N wall time of a fresh interpreter that only imports `modules`."""
    code = "import " + ", ".join(modules)
    return best_seconds(lambda: subprocess.run([sys.executable, "-c", code], check=True, capture_output=True))


def main():
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, {STEPS:,} steps, best of {REPEATS}")
    print("\nwhole runs, seconds (fresh interpreter), against the imports they cannot avoid")
    engine_py = HERE.parent / "engine.py"
    for label, flags, modules in (("python engine.py", [], ("numpy", "rerun")),
                                  ("python engine.py --smoke --no-rerun", ["--smoke", "--no-rerun"], ("numpy",))):
        run, imports = whole_run_seconds(engine_py, *flags), import_seconds(*modules)
        print(f"{label:<38}{run:>7.3f} vs import {', '.join(modules):<13}{imports:>6.3f}: {run / imports:.2f}x")

    print("\nper step, ns (both loops evaluate the energy every step, as the chapter does)")
    print(f"{'system':<10}{'integrator':<15}{'ours':>9}{'baseline':>10}{'ratio':>8}")
    per_step = {}
    for system_name in SYSTEMS:
        ours_system = engine.build_system(system_name, np.random.default_rng(0))
        base_system = baseline.build_system(system_name, np.random.default_rng(0))
        for name in engine.CHAPTER_INTEGRATORS:  # the baseline has the chapter's three
            mine = ns_per_step(engine.simulate, engine.INTEGRATORS[name], ours_system)
            theirs = ns_per_step(baseline.simulate, baseline.INTEGRATORS[name], base_system)
            per_step[system_name, name] = mine
            print(f"{system_name:<10}{name:<15}{mine:>9.0f}{theirs:>10.0f}{mine / theirs:>8.2f}")

    print("\nwhole runs in this process, seconds (imports already paid; output discarded)")
    with tempfile.TemporaryDirectory() as out:
        for label, flags in (("engine.main()", []), ("engine.main(--smoke --no-rerun)", ["--smoke", "--no-rerun"])):
            with contextlib.redirect_stdout(io.StringIO()):
                mine = best_seconds(lambda: engine.main([*flags, "--out", out]))  # noqa: B023
                theirs = best_seconds(lambda: baseline.main([*flags, "--out", out]))  # noqa: B023
            print(f"{label:<38}{mine:>7.3f} vs baseline {theirs:>6.3f}: {mine / theirs:.2f}x")

    found = mujoco_rows()
    if found is None:
        print("\nMuJoCo: not installed (pip install -e '.[mujoco]'), skipped")
        return
    rows, version = found
    print(f"\nagainst MuJoCo {version} mj_step on the same one-body model, ns/step")
    print(f"{'system':<10}{'MuJoCo':<8}{'ours':>9}{'mj loop':>9}{'mj nstep':>10}{'ours/loop':>11}{'ours/nstep':>12}")
    for (system_name, integrator), (loop, nstep) in rows.items():
        mine = per_step[system_name, "semi_implicit" if integrator == "Euler" else "rk4"]
        print(f"{system_name:<10}{integrator:<8}{mine:>9.0f}{loop:>9.0f}{nstep:>10.0f}"
              f"{mine / loop:>11.1f}{mine / nstep:>12.1f}")
    print("(orbit: MuJoCo calls our Python force law through mjcb_passive at every force evaluation)")


if __name__ == "__main__":
    main()
