"""Our ensembles against MuJoCo 3.10.0's own batch runner, mujoco.rollout.

Install with `pip install -e ".[test,mujoco]"`; without mujoco these tests skip.
"""

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="rollout parity needs the 'mujoco' extra: pip install -e '.[mujoco]'")

import engine  # noqa: E402
from conftest import ensemble_of
from figures import rollout_positions  # noqa: E402

SEEDS = np.arange(40)  # 40 distinct members x 2000 steps: every one compared, a few seconds
STEPS = 2000


def both(system_name, integrator):
    system = ensemble_of(system_name, SEEDS)
    positions, velocities, _ = engine.simulate(engine.INTEGRATORS[integrator], system, 0.01, STEPS)
    theirs = rollout_positions(system_name, integrator, system["q0"], system["v0"], 0.01, STEPS)
    return (positions, velocities), theirs


@pytest.mark.parametrize("system_name", ["spring", "freefall"])
def test_semi_implicit_ensemble_is_rollouts_euler_to_the_last_bit(system_name):
    """mjINT_EULER in rollout: every member, every step, position and velocity, the same bits."""
    (positions, velocities), (their_positions, their_velocities) = both(system_name, "semi_implicit")
    assert positions.shape == their_positions.shape == (STEPS + 1, len(SEEDS), 3)
    assert np.array_equal(positions, their_positions)
    assert np.array_equal(velocities, their_velocities)
    # the members really differ, so this is 40 checks, not one
    assert len(np.unique(positions[-1, :, 0])) == len(SEEDS)


@pytest.mark.parametrize("system_name", ["spring", "freefall"])
def test_rk4_ensemble_matches_rollouts_rk4_to_round_off(system_name):
    """mj_RungeKutta sums its tableau in another order, so the last bits differ: 1e-13 of the motion's size."""
    (positions, velocities), (their_positions, their_velocities) = both(system_name, "rk4")
    for mine, theirs in ((positions, their_positions), (velocities, their_velocities)):
        scale = np.max(np.abs(theirs))
        assert np.max(np.abs(mine - theirs)) <= 1e-13 * scale


def test_rollout_is_not_explicit_euler():
    """The bit-for-bit match above is specific: explicit Euler parts ways with mjINT_EULER at once."""
    (_, _), (their_positions, _) = both("spring", "semi_implicit")
    system = ensemble_of("spring", SEEDS)
    explicit, _, _ = engine.simulate(engine.euler_step, system, 0.01, STEPS)
    assert np.max(np.abs(explicit - their_positions)) > 1e-3
