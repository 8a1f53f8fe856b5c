"""Planted mistake: semi-implicit Euler that still moves q with the old velocity."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v_next = v + a * dt
    return q + v * dt, v_next  # oops: the old velocity
