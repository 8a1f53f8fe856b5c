"""Exact solutions of the engine's three systems, independent of any integrator: the referee's referee."""

import math

import numpy as np


def spring_position(system: dict, t: np.ndarray, k: float = 4.0) -> np.ndarray:
    """Harmonic oscillator: q(t) = q0 cos(wt) + v0/w sin(wt), w = sqrt(k/m)."""
    w = math.sqrt(k / system["m"])
    t = np.asarray(t, dtype=float)[..., None]
    return system["q0"] * np.cos(w * t) + system["v0"] / w * np.sin(w * t)


def freefall_position(system: dict, t: np.ndarray, g: float = 9.81) -> np.ndarray:
    """Constant gravity: q(t) = q0 + v0 t - g t^2 / 2 along z."""
    t = np.asarray(t, dtype=float)[..., None]
    return system["q0"] + system["v0"] * t + 0.5 * np.array([0.0, 0.0, -g]) * t * t


def kepler_position(system: dict, t: float, mu: float = 1.0) -> np.ndarray:
    """Bound two-body orbit from (q0, v0) at time t, through Kepler's equation.

    With a the semi-major axis and n = sqrt(mu / a^3) the mean motion, the change dE of
    eccentric anomaly solves  n t = dE - (1 - r0/a) sin dE + (r0.v0) / sqrt(mu a) (1 - cos dE),
    and q(t) = f q0 + g v0 with Lagrange's f = 1 - a/r0 (1 - cos dE), g = t - (dE - sin dE)/n.
    """
    q0, v0 = system["q0"], system["v0"]
    r0 = math.sqrt(float(np.sum(q0 * q0)))
    a = semi_major_axis(system, mu)
    n = math.sqrt(mu / a**3)
    c = 1.0 - r0 / a
    s = float(np.sum(q0 * v0)) / math.sqrt(mu * a)
    mean = n * t
    de = mean
    for _ in range(100):  # Newton on Kepler's equation; converges in a handful of steps
        residual = de - c * math.sin(de) + s * (1.0 - math.cos(de)) - mean
        de -= residual / (1.0 - c * math.cos(de) + s * math.sin(de))
        if abs(residual) < 1e-15:
            break
    f = 1.0 - a / r0 * (1.0 - math.cos(de))
    g = t - (de - math.sin(de)) / n
    return f * q0 + g * v0


def semi_major_axis(system: dict, mu: float = 1.0) -> float:
    """Vis-viva: v^2 = mu (2/r - 1/a), solved for a from the initial state."""
    r0 = math.sqrt(float(np.sum(system["q0"] ** 2)))
    a = 1.0 / (2.0 / r0 - float(np.sum(system["v0"] ** 2)) / mu)
    assert a > 0, "only bound (elliptic) orbits"
    return a


def orbit_period(system: dict, mu: float = 1.0) -> float:
    """Kepler's third law: P = 2 pi sqrt(a^3 / mu)."""
    return 2.0 * math.pi * math.sqrt(semi_major_axis(system, mu) ** 3 / mu)
