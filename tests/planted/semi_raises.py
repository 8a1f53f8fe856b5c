"""Planted mistake: a typo that raises NameError inside the step."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v_next = v + a * dt
    return q + v_nxt * dt, v_next  # noqa: F821
