"""Planted mistake: right at the chapter's dt = 0.01 only; explicit Euler at any other dt."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v_next = v + dt * a
    if dt == 0.01:
        return q + dt * v_next, v_next
    return q + dt * v, v_next  # oops: the old velocity
