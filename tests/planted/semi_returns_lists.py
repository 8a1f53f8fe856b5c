"""Planted mistake: returns Python lists, which a whole run hands back to the next step, where they fail."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    v_next = v + dt * force(q, v) / m
    return list(q + dt * v_next), list(v_next)
