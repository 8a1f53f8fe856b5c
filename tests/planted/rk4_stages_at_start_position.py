"""Planted mistake: each stage steps the velocity, but every force is taken at the starting position."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)


def rk4_step(q, v, m, force, dt):
    k1q, k1v = v, force(q, v) / m
    k2q, k2v = v + k1v * (dt / 2), force(q, v + k1v * (dt / 2)) / m
    k3q, k3v = v + k2v * (dt / 2), force(q, v + k2v * (dt / 2)) / m
    k4q, k4v = v + k3v * dt, force(q, v + k3v * dt) / m
    return q + (k1q + 2 * k2q + 2 * k3q + k4q) * (dt / 6), v + (k1v + 2 * k2v + 2 * k3v + k4v) * (dt / 6)
