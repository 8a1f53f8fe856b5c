"""Planted mistake: right on every other call, explicit Euler on the others (a counter kept between calls)."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)

calls = 0


def semi_implicit_step(q, v, m, force, dt):
    global calls
    calls += 1
    a = force(q, v) / m
    v_next = v + dt * a
    if calls % 2:
        return q + dt * v_next, v_next
    return q + dt * v, v_next
