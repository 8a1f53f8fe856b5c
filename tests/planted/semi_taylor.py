"""Planted mistake: q + v dt + a dt^2/2 in place of the new velocity."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    return q + v * dt + a * dt**2 / 2, v + a * dt
