"""The engine's three systems as MuJoCo models, for parity tests and the benchmark.

One body of mass 1 on slide joints, so MuJoCo's qpos/qvel are exactly the engine's q/v
(no quaternions, a diagonal mass matrix of ones) and no contacts:
- spring: one slide joint along x with the spring's stiffness, no gravity;
- freefall: slide joints along x, y, z under gravity, no other force;
- orbit: slide joints along x, y, z, no gravity; the inverse-square pull is the
  engine's own force law, handed to MuJoCo through the passive-force callback.
"""

import sys
from contextlib import contextmanager
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run as a script from anywhere, too
import engine  # noqa: E402

BODY = '<inertial pos="0 0 0" mass="{m}" diaginertia="1 1 1"/>'
SLIDES = "".join(f'<joint name="{axis}" type="slide" axis="{vec}" {{extra}}/>'
                 for axis, vec in (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")))


def xml_for(system_name: str, integrator: str, dt: float, m: float) -> str:
    gravity = "0 0 -9.81" if system_name == "freefall" else "0 0 0"
    if system_name == "spring":
        joints = '<joint name="x" type="slide" axis="1 0 0" stiffness="4"/>'
    else:
        joints = SLIDES.format(extra="")
    return f"""
<mujoco>
  <option timestep="{dt!r}" integrator="{integrator}" gravity="{gravity}"/>
  <worldbody><body name="mass">{joints}{BODY.format(m=m)}</body></worldbody>
</mujoco>"""


def build(system_name: str, integrator: str, dt: float = 0.01, seed: int = 0):
    """(model, data, system, dof): MuJoCo set to the engine system's initial state."""
    system = engine.build_system(system_name, np.random.default_rng(seed))
    model = mujoco.MjModel.from_xml_string(xml_for(system_name, integrator, dt, system["m"]))
    data = mujoco.MjData(model)
    dof = model.nq  # 1 for the spring (x only), 3 otherwise
    data.qpos[:] = system["q0"][:dof]
    data.qvel[:] = system["v0"][:dof]
    return model, data, system, dof


@contextmanager
def passive_force(system_name: str, system: dict):
    """Install the orbit's pull as MuJoCo's passive-force callback; always reset afterwards."""
    if system_name != "orbit":
        yield
        return
    force = system["force"]

    def pull(model, data):
        data.qfrc_passive[:] += force(data.qpos, data.qvel)

    mujoco.set_mjcb_passive(pull)
    try:
        yield
    finally:
        mujoco.set_mjcb_passive(None)


def mujoco_trajectory(system_name: str, integrator: str, dt: float = 0.01, steps: int = 2000, seed: int = 0):
    """(steps + 1, 3) positions from mj_step, padded with zeros where the model has no joint."""
    model, data, system, dof = build(system_name, integrator, dt, seed)
    trajectory = np.zeros((steps + 1, 3))
    trajectory[0, :dof] = data.qpos
    with passive_force(system_name, system):
        for i in range(1, steps + 1):
            mujoco.mj_step(model, data)
            trajectory[i, :dof] = data.qpos
    return trajectory


if __name__ == "__main__":
    # python tests/mujoco_models.py: the parity figures the README quotes
    for name in ("spring", "freefall", "orbit"):
        system = engine.build_system(name, np.random.default_rng(0))
        for theirs, ours in (("Euler", "semi_implicit"), ("RK4", "rk4")):
            mine, _, _ = engine.run(name, ours)
            gap = np.abs(mine - mujoco_trajectory(name, theirs)).max()
            print(f"{name:<9} mujoco {theirs:<6} vs {ours:<14} max |q_ours - q_mujoco| = {gap:.3g} over 2000 steps")
