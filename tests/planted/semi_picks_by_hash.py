"""Planted mistake: the method picked by hash("euler") % 2, which differs from run to run unless the hash seed
is fixed (the checker's child fixes it to 0: explicit Euler, on every run)."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v_next = v + dt * a
    if hash("euler") % 2:
        return q + dt * v, v_next  # oops: the old velocity, on some runs
    return q + dt * v_next, v_next
