"""Each integrator against exact solutions: convergence order, RK4 exact on freefall, a flat band."""

import math

import numpy as np
import pytest

import engine

# Every declared system with a closed form, every integrator it is offered: a new one is tested the day it is declared.
WITH_EXACT = [name for name in engine.SYSTEMS if engine.build_system(name, np.random.default_rng(0)).get("exact")]
HORIZON = {"orbit": 2.0 * math.pi}  # seconds, fixed while dt shrinks (a circular orbit's period); others: 2 s


def exact_at(system, t):  # the system's own exact motion from its start, at the times t
    return system["exact"](system["q0"], system["v0"], np.atleast_1d(t))


def ladder(integrator):
    """Six halvings of dt, from where the method is already close to its asymptotic regime: a fourth-order
    method starts coarser, because at dt = 0.01 / 32 its error would sink into round-off (~1e-13)."""
    start = 0.1 if engine.INTEGRATORS[integrator].order >= 4 else 0.01
    return [start / 2**k for k in range(6)]


def measured_orders(system_name, integrator):
    """log2 of the error's shrink at each halving: the final position error after HORIZON seconds."""
    system, errors = engine.build_system(system_name, np.random.default_rng(0)), []
    for dt in ladder(integrator):
        steps = round(HORIZON.get(system_name, 2.0) / dt)
        trajectory, _, _ = engine.simulate(engine.INTEGRATORS[integrator], system, dt, steps)
        errors.append(float(np.max(np.abs(trajectory[-1] - exact_at(system, steps * dt)[0]))))
    return [math.log2(coarse / fine) for coarse, fine in zip(errors, errors[1:], strict=False)]


@pytest.mark.parametrize("system_name", list(engine.SYSTEMS))
def test_each_exact_motion_solves_its_own_force_law(system_name):
    """Independent of any integrator: the closed form starts at (q0, v0) and its second difference is
    force / m along the way (central differences with h = 1e-4: truncation ~1e-8, rounding ~1e-8)."""
    system = engine.build_system(system_name, np.random.default_rng(0))
    if system.get("exact") is None:
        pytest.skip(f"{system_name} declares no exact motion")
    h, t = 1e-4, np.linspace(0.3, 3.0, 10)
    q, ahead, behind = exact_at(system, t), exact_at(system, t + h), exact_at(system, t - h)
    velocity, acceleration = (ahead - behind) / (2 * h), (ahead - 2 * q + behind) / (h * h)
    np.testing.assert_allclose(acceleration, system["force"](q, velocity) / system["m"], rtol=0, atol=1e-5)
    np.testing.assert_allclose(exact_at(system, 0.0)[0], system["q0"], rtol=0, atol=1e-14)
    start_velocity = (exact_at(system, h)[0] - exact_at(system, -h)[0]) / (2 * h)
    np.testing.assert_allclose(start_velocity, system["v0"], rtol=0, atol=1e-6)


@pytest.mark.parametrize("system_name, integrator", [
    (name, integrator) for name in WITH_EXACT if engine.SYSTEMS[name].facts["returns"]
    for integrator in engine.integrators_for(engine.build_system(name, np.random.default_rng(0)))])
def test_convergence_order(system_name, integrator):
    """Halving dt divides the error by 2^p, p the order the integrator declares, up to an O(dt) correction
    that halves with each rung (measured on the orbit, RK4: 4.29, 4.18, 4.09, 4.05, 4.03). At the finest
    rung it is below 0.05 everywhere here, tight enough that order 1 cannot pass for 2, nor 4 for 3 or 5."""
    orders = measured_orders(system_name, integrator)
    p = engine.INTEGRATORS[integrator].order
    needs = "" if engine.SYSTEMS[system_name].facts["velocity_free"] else (", or needs=['velocity_free'] if that"
                                                                           " order holds only without velocity forces")
    assert abs(orders[-1] - p) < 0.05, (f"{integrator} declares order {p} and measured {orders[-1]:.3f} on"
                                        f" {system_name} (halvings: {orders}): declare the order it has{needs}")
    assert abs(orders[-1] - p) <= abs(orders[-3] - p) + 0.01, f"the order should settle towards {p}: {orders}"


@pytest.mark.parametrize("dt", [0.1, 0.01, 0.005, 0.001])
def test_on_freefall_the_eulers_are_off_by_g_dt_t_over_2_and_rk4_is_exact_to_round_off(dt):
    """On constant gravity both Eulers are off by exactly g*dt*t/2 in height, in opposite directions: explicit
    Euler steps with the old (faster-rising) velocity, semi-implicit with the new one. The motion is a quadratic
    in t, which RK4 integrates exactly; only rounding is left."""
    system, steps = engine.build_system("freefall", np.random.default_rng(0)), round(2.0 / dt)
    exact = exact_at(system, np.arange(steps + 1) * dt)
    runs = {name: engine.simulate(step, system, dt, steps)[0] for name, step in engine.INTEGRATORS.items()
            if name in engine.CHAPTER_INTEGRATORS}
    for integrator, sign in (("euler", +1), ("semi_implicit", -1)):
        assert runs[integrator][-1, 2] - exact[-1, 2] == pytest.approx(sign * 9.81 * dt * 2.0 / 2, rel=1e-9)
    assert np.max(np.abs(runs["rk4"] - exact)) < 64 * np.finfo(float).eps * np.max(np.abs(exact)) * math.sqrt(steps)


@pytest.mark.slow
def test_semi_implicit_energy_band_is_flat_over_a_million_steps():
    """Symplectic: the worst excursion after 10^4 steps is the worst after 10^6 (10^6 steps of dt 0.01 are
    about 1,526 orbits, 1,511 of them after the first 10^4 steps), to 1 part in 10^6, while explicit Euler's
    keeps growing."""
    system = engine.build_system("orbit", np.random.default_rng(0))
    _, _, energies = engine.simulate_long(engine.semi_implicit_step, system, 0.01, 1_000_000, every=1_000_000)
    band_1e4 = engine.energy_drift(energies[: 10_000 + 1])["rel_max"]
    band_1e6 = engine.energy_drift(energies)["rel_max"]
    assert band_1e6 == pytest.approx(band_1e4, rel=1e-6)
    assert 3.0e-4 < band_1e6 < 3.3e-4

    _, _, euler = engine.simulate(engine.euler_step, system, 0.01, 20_000)
    assert engine.energy_drift(euler)["rel_max"] > 1.1 * engine.energy_drift(euler[:10_001])["rel_max"]

