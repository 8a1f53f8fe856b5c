"""Planted mistake: right arithmetic, but each step sleeps 5 ms: a whole run cannot finish in time."""

import time

from _right import rk4_step  # noqa: F401


def semi_implicit_step(q, v, m, force, dt):
    time.sleep(0.005)
    v_next = v + dt * force(q, v) / m
    return q + dt * v_next, v_next
