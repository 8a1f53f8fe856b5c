"""Our integrators against MuJoCo 3.10.0's own, mj_step and mujoco.rollout (the 'mujoco' extra; else they skip)."""

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco", reason="MuJoCo parity needs the 'mujoco' extra: pip install -e '.[mujoco]'")

import engine  # noqa: E402
from conftest import ensemble_of, run  # noqa: E402
from figures import rollout_positions  # noqa: E402
from mujoco_models import mujoco_trajectory  # noqa: E402

SEEDS = np.arange(40)  # 40 distinct members x 2000 steps: every one compared, a few seconds


def test_pinned_version_and_the_passive_callback_is_reset_afterwards():
    assert mujoco.__version__ == "3.10.0"
    mujoco_trajectory("orbit", "Euler", steps=3)
    assert mujoco.get_mjcb_passive() is None


@pytest.mark.parametrize("system_name", list(engine.SYSTEMS))  # spring, freefall natively, others by our force law
def test_semi_implicit_is_mujocos_euler_to_the_last_bit_and_rk4_its_rk4_to_round_off(system_name):
    """mjINT_EULER: velocity += h*qacc, then position += h*(new velocity). With unit mass and the same force
    arithmetic (the orbit's pull is our own function, called from mjcb_passive), every one of the 2000 positions
    is bit for bit the same, and explicit Euler parts ways at once (a run that blows up counts).
    mj_RungeKutta sums its Butcher tableau (weights 1/6, 1/3, 1/3, 1/6) in another order than our
    (dt/6)*(k1 + 2k2 + 2k3 + k4), so the last bits differ: a few ulps of the position's size (largest: 6.8e-13
    on freefall's 1952 m drop), far below any real change."""
    theirs = mujoco_trajectory(system_name, "Euler")
    assert np.array_equal(run(system_name, "semi_implicit")[0], theirs)
    assert not np.all(np.abs(run(system_name, "euler")[0] - theirs) <= 1e-3)
    theirs = mujoco_trajectory(system_name, "RK4")
    assert np.isfinite(theirs).all(), f"{system_name}: MuJoCo's RK4 blew up at dt 0.01; choose a system that does not"
    assert np.max(np.abs(run(system_name, "rk4")[0] - theirs)) <= 1e-13 * np.max(np.abs(theirs))


@pytest.mark.parametrize("system_name", ["spring", "freefall"])
def test_an_ensemble_is_rollouts_euler_to_the_last_bit_and_its_rk4_to_round_off(system_name):
    """mujoco.rollout steps every member in C: mjINT_EULER gives every member's position and velocity at every
    step in the same bits, mjINT_RK4 within 1e-13 of the motion's size; and the members really differ, so this
    is 40 checks, not one, and explicit Euler is not what rollout does."""
    system = ensemble_of(system_name, SEEDS)
    for integrator in ("semi_implicit", "rk4", "euler"):
        mine = engine.simulate(engine.INTEGRATORS[integrator], system, 0.01, 2000)[:2]
        theirs = rollout_positions(system_name, integrator if integrator != "euler" else "semi_implicit",
                                   system["q0"], system["v0"], 0.01, 2000)
        assert mine[0].shape == theirs[0].shape == (2001, len(SEEDS), 3)
        gaps = [np.max(np.abs(ours - them)) for ours, them in zip(mine, theirs, strict=True)]
        sizes = [np.max(np.abs(them)) for them in theirs]
        assert {"semi_implicit": max(gaps) == 0, "rk4": all(np.array(gaps) <= 1e-13 * np.array(sizes)),
                "euler": gaps[0] > 1e-3}[integrator], (integrator, gaps)
    assert len(np.unique(mine[0][-1, :, 0])) == len(SEEDS)
