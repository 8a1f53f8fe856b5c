"""Planted mistake: velocity Verlet (second order) in place of semi-implicit Euler."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    q_next = q + v * dt + 0.5 * a * dt * dt
    a_next = force(q_next, v) / m
    return q_next, v + 0.5 * (a + a_next) * dt
