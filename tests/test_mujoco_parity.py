"""Our integrators against MuJoCo 3.10.0's own, on every conservative system.

Install with `pip install -e ".[test,mujoco]"`; without mujoco these tests skip.
"""


import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco", reason="MuJoCo parity needs the 'mujoco' extra: pip install -e '.[mujoco]'")

import engine  # noqa: E402
from conftest import run  # noqa: E402
from mujoco_models import mujoco_trajectory  # noqa: E402

SYSTEMS = list(engine.SYSTEMS)  # spring and freefall natively, the others through our force law


def ours(system_name, integrator, dt=0.01, steps=2000):
    positions, _, _ = run(system_name, integrator, dt, steps)
    return positions


def test_pinned_version():
    assert mujoco.__version__ == "3.10.0"


@pytest.mark.parametrize("system_name", SYSTEMS)
def test_semi_implicit_is_mujocos_euler_to_the_last_bit(system_name):
    """mjINT_EULER: velocity += h*qacc, then position += h*(new velocity). With unit mass and the
    same force arithmetic (the orbit's pull is our own function, called from mjcb_passive),
    every one of the 2000 positions is bit-for-bit the same."""
    theirs = mujoco_trajectory(system_name, "Euler")
    assert np.array_equal(ours(system_name, "semi_implicit"), theirs)
    # ...and MuJoCo's "Euler" is not explicit Euler, which parts ways at once (a run that blows up counts)
    assert not np.all(np.abs(ours(system_name, "euler") - theirs) <= 1e-3)


@pytest.mark.parametrize("system_name", SYSTEMS)
def test_rk4_matches_mujocos_rk4_to_round_off(system_name):
    """mj_RungeKutta sums its Butcher tableau (weights 1/6, 1/3, 1/3, 1/6) in another order than
    our (dt/6)*(k1 + 2k2 + 2k3 + k4), so the last bits differ; the measured gap is a few ulps of
    the position's size (largest: 6.8e-13 on freefall's 1952 m drop), far below any real change."""
    mine = ours(system_name, "rk4")
    theirs = mujoco_trajectory(system_name, "RK4")
    assert np.isfinite(theirs).all(), f"{system_name}: MuJoCo's RK4 blew up at dt 0.01; choose a system that does not"
    scale = np.max(np.abs(theirs))
    assert np.max(np.abs(mine - theirs)) <= 1e-13 * scale


def test_passive_callback_is_reset_afterwards():
    mujoco_trajectory("orbit", "Euler", steps=3)
    assert mujoco.get_mjcb_passive() is None
