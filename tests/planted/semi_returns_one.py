"""Planted mistake: returns only the position."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    v_next = v + force(q, v) / m * dt
    return q + v_next * dt
