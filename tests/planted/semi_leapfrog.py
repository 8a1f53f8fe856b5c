"""Planted mistake: leapfrog, drift-kick-drift (second order)."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    q_half = q + 0.5 * dt * v
    v_next = v + dt * force(q_half, v) / m
    return q_half + 0.5 * dt * v_next, v_next
