"""Exercise 7's physics: the shadow energy E~ that semi-implicit Euler keeps, measured on the engine's systems.

    E~ = E - (dt/2) v . grad V(q) = E + (dt/2) v . F(q)        for a force F = -grad V

This is the first term of backward error analysis's modified energy for semi-implicit Euler, velocity
first (Hairer, Lubich and Wanner, Geometric Numerical Integration, ch. IX): the steps are, very nearly,
the exact motion of a slightly different system, and E~ is that system's energy. It lives here, beside
the exercise, and not in engine.py: the chapter measures E, the referee; E~ is exercise 7's lesson.
"""

import numpy as np

import engine
from engine_referee import dot3, relative_energy_error

SEED, DT, STEPS = 0, 0.01, 2000  # the chapter's run: 20 s of simulated time
SYSTEMS = ("spring", "orbit", "freefall")  # the spring first: exercise 5's quadratic is where E~ starts
ROUNDOFF_ULPS_PER_STEP = 8  # see roundoff_floor()


def shadow_energy(system: dict, q, v, dt: float):
    """E~ = E + (dt/2) v . F(q), one number per state: what semi-implicit Euler keeps (nearly, or exactly).

    The force is the system's own force law, so F = -grad V for every conservative system in the engine.
    """
    return system["energy"](q, v) + 0.5 * dt * dot3(v, system["force"](q, v))


def relative_change(values) -> np.ndarray:
    """|x - x0| / |x0| at every step: how far a quantity has moved from where it started."""
    return np.abs(relative_energy_error(np.asarray(values, dtype=float)))


def band(values) -> float:
    """The worst |x - x0| / |x0| over the run (engine.energy_drift's rel_max, for any quantity)."""
    return engine.energy_drift(np.asarray(values, dtype=float))["rel_max"]


def roundoff_floor(system: dict, q, v, dt: float, shadow) -> float:
    """The most that rounding alone can move E~ over this run, relative to |E~0|.

    Each step rounds every component of q and v a couple of times (a product by dt, a sum), and
    evaluating E~ rounds each of its three terms (kinetic, potential, the dt/2 correction) a few
    times more. Each of those roundings changes E~ by at most a few units in the last place (ulps,
    2.2e-16 relative) of its largest term: we allow ROUNDOFF_ULPS_PER_STEP of them per step. If
    they never cancelled they would add up linearly with the number of steps, and that is what this
    bound assumes, so real round-off (which mostly cancels) stays far below it. What scales it is the
    size of the terms, not of E~: on the freefall, E~ (about 103 J) is the difference of a kinetic
    and a potential energy that each reach about 19,000 J two kilometres down, and each rounds at
    that size.
    """
    kinetic = 0.5 * system["m"] * dot3(v, v)
    potential = system["energy"](q, v) - kinetic
    correction = 0.5 * dt * dot3(v, system["force"](q, v))
    terms = np.max(np.abs(kinetic) + np.abs(potential) + np.abs(correction))
    steps = len(shadow) - 1
    return float(ROUNDOFF_ULPS_PER_STEP * (steps + 1) * np.finfo(float).eps * terms / abs(shadow[0]))


def measure(system_name: str, integrator: str = "semi_implicit", dt: float = DT, steps: int = STEPS,
            system: dict | None = None) -> dict:
    """One run, E and E~ side by side: {"energy", "shadow" (one per step), "energy_band", "shadow_band",
    "roundoff" (the floor above), "positions", "velocities", "dt", "system"}.

    `system` replaces the engine's own (tests pass a spring of another stiffness and mass)."""
    system = system or engine.build_system(system_name, np.random.default_rng(SEED))
    q, v, energies = engine.simulate(engine.INTEGRATORS[integrator], system, dt, steps)
    shadow = shadow_energy(system, q, v, dt)
    return {"energy": energies, "shadow": shadow, "energy_band": band(energies), "shadow_band": band(shadow),
            "roundoff": roundoff_floor(system, q, v, dt, shadow), "positions": q, "velocities": v, "dt": dt,
            "system": system}


def how_far(run: dict) -> str:
    """What E~ did, in the exercise's words: 'roundoff' (it moved no more than rounding can move it),
    'smaller' (a real change, but at most half of E's) or 'as_far' (as far as E, or farther)."""
    if run["shadow_band"] <= run["roundoff"]:
        return "roundoff"
    return "smaller" if run["shadow_band"] <= 0.5 * run["energy_band"] else "as_far"


def halving_ladder(system_name: str = "orbit", seconds: float = DT * STEPS, halvings: int = 3) -> list:
    """[(dt, steps, E's band, E~'s band)] at a fixed simulated time while dt halves `halvings` times."""
    ladder = []
    for k in range(halvings + 1):
        dt = DT / 2**k
        steps = round(seconds / dt)
        run = measure(system_name, dt=dt, steps=steps)
        ladder.append((dt, steps, run["energy_band"], run["shadow_band"]))
    return ladder


def spring_of(k: float, m: float) -> dict:
    """A Hooke spring of stiffness k and mass m, stretched as the chapter's (seed 0): the same contract as
    engine.build_system's, so that the tests can show E~'s mass and stiffness enter where the formula says."""
    chapter = engine.build_system("spring", np.random.default_rng(SEED))

    def force(q, v):
        return -k * q

    def energy(q, v):
        return 0.5 * m * dot3(v, v) + 0.5 * k * dot3(q, q)

    return {"name": f"spring (k {k:g}, m {m:g})", "q0": chapter["q0"], "v0": chapter["v0"], "m": m,
            "force": force, "energy": energy}


def worst_so_far(values, floor: float) -> np.ndarray:
    """The recording's curve: log10 of the worst |x - x0| / |x0| up to each step, floored at `floor` (the run's
    round-off bound).

    The running maximum never comes down, so round-off reads as a flat line instead of noise, and a
    quantity that moved no more than rounding can sits on the floor."""
    return np.log10(np.maximum(np.maximum.accumulate(relative_change(values)), floor))
