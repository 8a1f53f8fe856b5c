"""Our integrators against MuJoCo 3.10.0's own: the parity figures docs/DEVELOPING.md and docs/damping.md quote.

    python tools/mujoco_parity.py     # a few seconds; needs the 'mujoco' extra

The models are the tests' (tests/mujoco_models.py): one body of mass 1 on slide joints, dt 0.01, 2000 steps.
"""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # engine, and the MuJoCo models the parity tests use
import engine  # noqa: E402
from mujoco_models import damped_trajectory, mujoco_trajectory  # noqa: E402


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
            notes = [f"ours non-finite from step {blown[0]:,}; compared before that"] if blown.size else []
            if reset_at is not None:
                notes.append(f"MuJoCo blew up and reset at step {reset_at:,}; compared before that")
            print(f"damped_spring b {b:<4g} mujoco {theirs:<12} vs {mine:<14} max |q_ours - q_mujoco| = {gap:.3g}"
                  + (f" ({'; '.join(notes)})" if notes else ""))


if __name__ == "__main__":
    for name in ("spring", "freefall", "orbit"):
        system = engine.build_system(name, np.random.default_rng(0))
        for theirs, ours in (("Euler", "semi_implicit"), ("RK4", "rk4")):
            mine, _, _ = engine.simulate(engine.INTEGRATORS[ours], system, 0.01, 2000)
            gap = np.abs(mine - mujoco_trajectory(name, theirs)).max()
            print(f"{name:<9} mujoco {theirs:<6} vs {ours:<14} max |q_ours - q_mujoco| = {gap:.3g} over 2000 steps")
    print_damped_parity()
