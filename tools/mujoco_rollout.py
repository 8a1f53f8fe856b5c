"""MuJoCo's own batch runner, mujoco.rollout, on the engine's spring and freefall ensembles.

rollout.rollout(model, data, initial_state, nstep=...) steps every row of initial_state through
mj_step in C and returns (nbatch, nstep, nstate) states after each step (not the start). The state
is mjSTATE_FULLPHYSICS: [time, qpos, qvel] for these models (no actuators, no mocap, no plugins).
With one MjData the rollout runs on the calling thread: one thread, as the benchmark compares.

    python tools/mujoco_rollout.py     # the parity figures docs/ensembles.md quotes
"""

import functools
import sys
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # engine, and the MuJoCo models the parity tests use
import engine  # noqa: E402
import engine_ensembles  # noqa: E402
from mujoco_models import xml_for  # noqa: E402

FULLPHYSICS = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
MUJOCO_NAME = {"semi_implicit": "Euler", "rk4": "RK4"}  # mjINT_EULER is semi-implicit Euler


def rollout_model(system_name: str, integrator: str, dt: float):
    """(model, data, dof) for one of the engine's systems; dof = number of slide joints (1 or 3)."""
    model = mujoco.MjModel.from_xml_string(xml_for(system_name, MUJOCO_NAME[integrator], dt, 1.0))
    return model, mujoco.MjData(model), model.nq


def initial_states(model, data, q0: np.ndarray, v0: np.ndarray) -> np.ndarray:
    """(N, nstate) full-physics states at time 0 from (N, 3) engine positions and velocities."""
    dof = model.nq
    states = np.empty((len(q0), mujoco.mj_stateSize(model, FULLPHYSICS)))
    for i in range(len(q0)):  # set-up only, once per member; the stepping is all in C
        mujoco.mj_resetData(model, data)
        data.qpos[:], data.qvel[:] = q0[i, :dof], v0[i, :dof]
        mujoco.mj_getState(model, data, states[i], FULLPHYSICS)
    return states


def rollout_positions(system_name: str, integrator: str, q0, v0, dt: float, steps: int):
    """(steps + 1, N, 3) positions and velocities from mujoco.rollout, the engine's layout.

    Axes the model has no joint for (the spring's y and z) are filled with the engine's start,
    which the engine never moves either."""
    model, data, dof = rollout_model(system_name, integrator, dt)
    start = initial_states(model, data, q0, v0)
    state, _ = rollout.rollout(model, data, start, nstep=steps)
    positions = np.broadcast_to(q0, (steps + 1, *q0.shape)).copy()
    velocities = np.broadcast_to(v0, (steps + 1, *v0.shape)).copy()
    positions[1:, :, :dof] = state[:, :, 1:1 + dof].transpose(1, 0, 2)
    velocities[1:, :, :dof] = state[:, :, 1 + dof:1 + 2 * dof].transpose(1, 0, 2)
    return positions, velocities


if __name__ == "__main__":
    seeds = np.arange(1000)
    for name in ("spring", "freefall"):
        system = engine_ensembles.build_ensemble(functools.partial(engine.build_system, name), seeds)
        for ours in ("semi_implicit", "rk4"):
            mine, mine_v, _ = engine.simulate(engine.INTEGRATORS[ours], system, 0.01, 2000)
            theirs, theirs_v = rollout_positions(name, ours, system["q0"], system["v0"], 0.01, 2000)
            gap = max(np.abs(mine - theirs).max(), np.abs(mine_v - theirs_v).max())
            scale = max(np.abs(theirs).max(), np.abs(theirs_v).max())
            same = np.array_equal(mine, theirs) and np.array_equal(mine_v, theirs_v)
            print(f"{name:<9} {len(seeds)} seeds x 2000 steps, {ours:<14} vs rollout mj{MUJOCO_NAME[ours]:<6}"
                  f" max gap {gap:.3g} = {gap / scale:.2g} of the motion's size ({scale:.4g})"
                  + ("  bit for bit" if same else ""))
