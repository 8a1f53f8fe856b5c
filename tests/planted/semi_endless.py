"""Planted mistake: a loop that never ends."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    while True:
        q = q + v * dt
