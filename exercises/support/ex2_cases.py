"""The systems check_ex2 runs your steps on, and the exact motion of the ones that have one.

The chapter's systems all have mass 1 and forces that ignore velocity, so a step that forgets
`/ m`, or hands a stage the wrong velocity, still looks right on them. These cases add a mass
other than 1 and forces that depend on velocity (a damped spring, an orbit with drag), so that
every way of mishandling m or v changes the numbers. Springs, damped or not, are solved exactly.
"""

import math

import numpy as np

# name: (what it is, m, spring constant k, damping c, inverse-square pull mu, quadratic drag)
CASES = {
    "spring": ("the chapter's spring (m = 1)", 1.0, 4.0, 0.0, 0.0, 0.0),
    "orbit": ("the chapter's orbit (m = 1)", 1.0, 0.0, 0.0, 1.0, 0.0),
    "heavy_spring": ("a spring with m = 2.5", 2.5, 3.0, 0.0, 0.0, 0.0),
    "damped_spring": ("a damped spring with m = 1, force -k q - c v", 1.0, 4.0, 0.5, 0.0, 0.0),
    "heavy_damped_spring": ("a damped spring with m = 2.5", 2.5, 3.0, 0.8, 0.0, 0.0),
    "dragged_orbit": ("an orbit with drag, m = 0.7", 0.7, 0.0, 0.0, 1.0, 0.3),
}
MASS_ONE = ("spring", "orbit", "damped_spring")
VELOCITY_FREE = ("spring", "orbit", "heavy_spring")


def mass(name: str) -> float:
    return CASES[name][1]


def force_law(name: str):
    """force(q, v) for the case: Hooke, damping, an inverse-square pull, quadratic drag."""
    _, m, k, c, mu, drag = CASES[name]

    def spring(q, v):
        return q * -k - v * c if c else q * -k

    def orbit(q, v):
        x, y, z = q.tolist()
        r = math.sqrt(x * x + y * y + z * z)
        pull = -mu * m / (r * r * r) if r > 0.0 else math.nan
        if not drag:
            return q * pull
        vx, vy, vz = v.tolist()
        return q * pull - v * (drag * math.sqrt(vx * vx + vy * vy + vz * vz))

    return orbit if mu else spring


def energy(name: str, q, v):
    """Kinetic + potential over the last axis (springs and orbits; drag and damping make it fall)."""
    _, m, k, _, mu, _ = CASES[name]
    q, v = np.asarray(q), np.asarray(v)
    potential = 0.5 * k * (q * q).sum(axis=-1)
    if mu:
        potential = potential - mu * m / np.sqrt((q * q).sum(axis=-1))
    return 0.5 * m * (v * v).sum(axis=-1) + potential


def exact_spring(name: str, q0, v0, t: float):
    """Exact (q, v) at time t of a spring, damped or not: each axis is x'' = -(k/m) x - (c/m) x'.

    With g = c / 2m and w the damped frequency sqrt(k/m - g^2):
    x(t) = e^-gt (x0 cos wt + (v0 + g x0) / w sin wt),  v(t) = e^-gt (v0 cos wt - (k/m x0 + g v0) / w sin wt).
    """
    _, m, k, c, mu, drag = CASES[name]
    assert not mu and not drag, "only springs have a closed form here"
    g, w0_sq = c / (2.0 * m), k / m
    w = math.sqrt(w0_sq - g * g)
    decay, cos, sin = math.exp(-g * t), math.cos(w * t), math.sin(w * t)
    q0, v0 = np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)
    q = decay * (q0 * cos + (v0 + g * q0) / w * sin)
    v = decay * (v0 * cos - (w0_sq * q0 + g * v0) / w * sin)
    return q, v
