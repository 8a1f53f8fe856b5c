"""Planted mistake: position first, then velocity from the force at the new position."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    q_next = q + v * dt
    v_next = v + force(q_next, v) / m * dt
    return q_next, v_next
