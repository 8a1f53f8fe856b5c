"""Planted mistake: right arithmetic, but the caller's arrays are updated in place."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    v += force(q, v) / m * dt
    q += v * dt
    return q, v
