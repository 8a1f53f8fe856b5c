"""Planted mistake: Heun's method."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)


def rk4_step(q, v, m, force, dt):
    k1q, k1v = v, force(q, v) / m
    k2q, k2v = v + k1v * dt, force(q + k1q * dt, v + k1v * dt) / m
    return q + (k1q + k2q) * (dt / 2), v + (k1v + k2v) * (dt / 2)
