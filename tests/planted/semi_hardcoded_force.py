"""Planted mistake: the chapter's spring force typed in instead of calling force."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    a = -4.0 * q / m
    v_next = v + a * dt
    return q + v_next * dt, v_next
