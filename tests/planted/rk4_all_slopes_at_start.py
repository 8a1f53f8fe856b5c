"""Planted mistake: four slopes, all taken at the start (explicit Euler in disguise)."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)


def rk4_step(q, v, m, force, dt):
    k1q, k1v = v, force(q, v) / m
    k2q, k2v = v, force(q, v) / m
    k3q, k3v = v, force(q, v) / m
    k4q, k4v = v, force(q, v) / m
    return q + (k1q + 2 * k2q + 2 * k3q + k4q) * (dt / 6), v + (k1v + 2 * k2v + 2 * k3v + k4v) * (dt / 6)
