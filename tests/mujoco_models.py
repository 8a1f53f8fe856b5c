"""The engine's systems as MuJoCo models (for the parity tests and tools/): one body of mass 1 on slide joints, so
qpos/qvel are the engine's q/v. The spring: one joint with its stiffness; the freefall: three under gravity; others:
three, pulled by the engine's force law through the passive-force callback; the damped spring: one joint with
stiffness and damping, run in a temporary folder (on a blown-up state MuJoCo writes MUJOCO_LOG.TXT and resets).
"""

import contextlib
import tempfile
from pathlib import Path

import mujoco
import numpy as np

import engine

BODY = '<inertial pos="0 0 0" mass="{m}" diaginertia="1 1 1"/>'  # tests/test_ex7.py builds its spring with it
NATIVE = ("spring", "freefall")  # built from MuJoCo's own joint stiffness and gravity


def model_xml(joints: str, integrator: str, dt: float, m: float, gravity: str = "0 0 0", flag: str = "") -> str:
    return (f'<mujoco><option timestep="{dt!r}" integrator="{integrator}" gravity="{gravity}">{flag}</option>'
            f'<worldbody><body name="mass">{joints}{BODY.format(m=m)}</body></worldbody></mujoco>')


def xml_for(system_name: str, integrator: str, dt: float, m: float) -> str:
    if system_name == "spring":
        joints = '<joint name="x" type="slide" axis="1 0 0" stiffness="4"/>'
    else:
        joints = "".join(f'<joint name="{axis}" type="slide" axis="{vector}"/>'
                         for axis, vector in (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")))
    return model_xml(joints, integrator, dt, m, "0 0 -9.81" if system_name == "freefall" else "0 0 0")


def damped_xml(integrator: str, dt: float, system: dict, eulerdamp: bool = True) -> str:
    """eulerdamp=False sets mjDSBL_EULERDAMP: MuJoCo's Euler then takes the damping explicitly."""
    joint = f'<joint name="x" type="slide" axis="1 0 0" stiffness="{system["k"]!r}" damping="{system["b"]!r}"/>'
    return model_xml(joint, integrator, dt, system["m"], flag="" if eulerdamp else '<flag eulerdamp="disable"/>')


def mujoco_trajectory(system_name: str, integrator: str, dt: float = 0.01, steps: int = 2000, seed: int = 0):
    """(steps + 1, 3) positions from mj_step from the engine system's start, padded with zeros where the model has
    no joint; a force law MuJoCo has no native model for (the orbit's pull) is its passive-force callback,
    always reset afterwards."""
    system = engine.build_system(system_name, np.random.default_rng(seed))
    model = mujoco.MjModel.from_xml_string(xml_for(system_name, integrator, dt, system["m"]))
    data, dof = mujoco.MjData(model), model.nq  # 1 for the spring (x only), 3 otherwise
    data.qpos[:], data.qvel[:] = system["q0"][:dof], system["v0"][:dof]
    trajectory = np.zeros((steps + 1, 3))
    trajectory[0, :dof] = data.qpos

    def pull(model, data):
        data.qfrc_passive[:] += system["force"](data.qpos, data.qvel)

    mujoco.set_mjcb_passive(None if system_name in NATIVE else pull)
    try:
        for i in range(1, steps + 1):
            mujoco.mj_step(model, data)
            trajectory[i, :dof] = data.qpos
    finally:
        mujoco.set_mjcb_passive(None)
    return trajectory


@contextlib.contextmanager
def in_scratch_folder():
    """Run with a temporary working folder (MuJoCo's MUJOCO_LOG.TXT lands there), then go back."""
    with tempfile.TemporaryDirectory(prefix="mujoco-") as scratch, contextlib.chdir(scratch):
        yield Path(scratch)


def damped_trajectory(integrator: str, damping: float, dt: float = 0.01, steps: int = 2000, seed: int = 0,
                      eulerdamp: bool = True):
    """(positions, reset_at): mj_step's positions (steps + 1, 3) on the engine's damped spring, and the
    first step at which MuJoCo found the state blown up and reset it (None if it never did)."""
    system = engine.build_system("damped_spring", np.random.default_rng(seed), damping)
    model = mujoco.MjModel.from_xml_string(damped_xml(integrator, dt, system, eulerdamp))
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = system["q0"][:1], system["v0"][:1]
    positions, reset_at = np.zeros((steps + 1, 3)), None
    positions[0, 0] = data.qpos[0]
    with in_scratch_folder():
        for i in range(1, steps + 1):
            mujoco.mj_step(model, data)
            positions[i, 0] = data.qpos[0]
            if reset_at is None and data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
                reset_at = i
    return positions, reset_at
