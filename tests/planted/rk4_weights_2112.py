"""Planted mistake: weights 2-1-1-2 over 6: they sum to one, but the blend is second order."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)


def rk4_step(q, v, m, force, dt):
    k1q, k1v = v, force(q, v) / m
    k2q, k2v = v + k1v * (dt / 2), force(q + k1q * (dt / 2), v + k1v * (dt / 2)) / m
    k3q, k3v = v + k2v * (dt / 2), force(q + k2q * (dt / 2), v + k2v * (dt / 2)) / m
    k4q, k4v = v + k3v * dt, force(q + k3q * dt, v + k3v * dt) / m
    return q + (2 * k1q + k2q + k3q + 2 * k4q) * (dt / 6), v + (2 * k1v + k2v + k3v + 2 * k4v) * (dt / 6)
