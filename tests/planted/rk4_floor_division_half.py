"""Planted mistake: half a step taken with floor division, dt // 2, which is 0.0 for any dt under 2."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)


def rk4_step(q, v, m, force, dt):
    half = dt // 2
    k1q, k1v = v, force(q, v) / m
    k2q, k2v = v + half * k1v, force(q + half * k1q, v + half * k1v) / m
    k3q, k3v = v + half * k2v, force(q + half * k2q, v + half * k2v) / m
    k4q, k4v = v + dt * k3v, force(q + dt * k3q, v + dt * k3v) / m
    return q + dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q), v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
