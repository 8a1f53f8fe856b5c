"""Planted mistake: the midpoint method."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)


def rk4_step(q, v, m, force, dt):
    k1q, k1v = v, force(q, v) / m
    k2q, k2v = v + k1v * (dt / 2), force(q + k1q * (dt / 2), v + k1v * (dt / 2)) / m
    return q + k2q * dt, v + k2v * dt
