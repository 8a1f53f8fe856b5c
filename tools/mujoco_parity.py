"""Our integrators against MuJoCo 3.10.0's own: the parity figures docs/DEVELOPING.md and docs/damping.md quote.

    python tools/mujoco_parity.py                   # a few seconds; needs the 'mujoco' extra
    python tools/mujoco_parity.py --implicit-scan   # docs/damping.md's scan of implicit against mjINT_IMPLICIT

The models are the tests' (tests/mujoco_models.py): one body of mass 1 on slide joints, dt 0.01, 2000 steps.
"""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # engine, and the MuJoCo models the parity tests use
import mujoco  # noqa: E402

import engine  # noqa: E402
from mujoco_models import damped_trajectory, damped_xml, in_scratch_folder, mujoco_trajectory  # noqa: E402


def print_damped_parity(dampings=(0.5, 4.0, 300.0)) -> None:
    """The damped spring's parity figures: ours against MuJoCo's integrators, dt 0.01, 2000 steps."""
    pairs = (("Euler", "implicit"), ("implicitfast", "implicit"), ("implicit", "implicit"),
             ("Euler", "semi_implicit"), ("RK4", "rk4"))
    for b in dampings:
        system = engine.build_system("damped_spring", np.random.default_rng(0), b)
        ours = {name: engine.simulate(step, system, 0.01, 2000)[0]
                for name, step in engine.integrators_for(system).items()}
        for theirs, mine in pairs:
            positions, reset_at = damped_trajectory(theirs, b)
            blown = np.flatnonzero(~np.isfinite(ours[mine][:, 0]))
            upto = min(len(positions), reset_at or len(positions), blown[0] if blown.size else len(positions))
            gap = np.abs(ours[mine][:upto] - positions[:upto]).max()  # up to a reset or a blow-up
            notes = [f"our positions non-finite from step {blown[0]:,}; compared before that"] if blown.size else []
            if reset_at is not None:
                notes.append(f"MuJoCo blew up and reset at step {reset_at:,}; compared before that")
            print(f"damped_spring b {b:<4g} mujoco {theirs:<12} vs {mine:<14} max |q_ours - q_mujoco| = {gap:.3g}"
                  + (f" ({'; '.join(notes)})" if notes else ""))


def print_implicit_scan(start: float = 1.05, dt: float = 0.01, steps: int = 2000) -> None:
    """docs/damping.md's scan: b = 0.1, 0.2, ..., 9.9 from x = `start`, our implicit_step (it multiplies by a
    reciprocal) against mjINT_IMPLICIT (it divides): in how many runs positions and velocities differ at all,
    and by at most how many machine epsilons of the motion's own size."""
    runs, differ, worst = 99, {"positions": 0, "velocities": 0, "either": 0}, {"positions": 0.0, "velocities": 0.0}
    for tenths in range(1, runs + 1):
        system = engine.build_system("damped_spring", np.random.default_rng(0), tenths / 10)
        system["q0"] = np.array([start, 0.0, 0.0])
        model = mujoco.MjModel.from_xml_string(damped_xml("implicit", dt, system))
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:] = system["q0"][:1], system["v0"][:1]
        theirs = np.zeros((2, steps + 1))
        theirs[:, 0] = data.qpos[0], data.qvel[0]
        with in_scratch_folder():
            for i in range(1, steps + 1):
                mujoco.mj_step(model, data)
                theirs[:, i] = data.qpos[0], data.qvel[0]
        q, v, _ = engine.simulate(engine.integrators_for(system)["implicit"], system, dt, steps)
        gaps = {"positions": np.abs(q[:, 0] - theirs[0]), "velocities": np.abs(v[:, 0] - theirs[1])}
        for what, size in (("positions", theirs[0]), ("velocities", theirs[1])):
            differ[what] += bool(gaps[what].max() > 0)
            worst[what] = max(worst[what], gaps[what].max() / np.abs(size).max() / np.finfo(float).eps)
        differ["either"] += bool(max(gap.max() for gap in gaps.values()) > 0)
    print(f"damped_spring from x = {start}, b = 0.1 to 9.9 by 0.1, dt {dt}, {steps} steps: implicit vs mjINT_IMPLICIT")
    for what in ("positions", "velocities"):
        print(f"  {what:<10} differ in {differ[what]} of {runs} runs, by at most {worst[what]:.1f} epsilons of"
              f" the motion's size")
    print(f"  either     differ in {differ['either']} of {runs} runs")


if __name__ == "__main__":
    if sys.argv[1:] == ["--implicit-scan"]:  # docs/damping.md's scan
        print_implicit_scan()
        sys.exit(0)
    for name in ("spring", "freefall", "orbit"):
        system = engine.build_system(name, np.random.default_rng(0))
        for theirs, ours in (("Euler", "semi_implicit"), ("RK4", "rk4")):
            mine, _, _ = engine.simulate(engine.INTEGRATORS[ours], system, 0.01, 2000)
            gap = np.abs(mine - mujoco_trajectory(name, theirs)).max()
            print(f"{name:<9} mujoco {theirs:<6} vs {ours:<14} max |q_ours - q_mujoco| = {gap:.3g} over 2000 steps")
    print_damped_parity()
