"""Planted mistake: semi-implicit Euler taking the force a step ahead, at q + dt * v."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    a = force(q + dt * v, v) / m  # oops: not where the step starts
    v_next = v + dt * a
    return q + dt * v_next, v_next
