"""Planted mistake: hands the work to the engine."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)

import engine


def semi_implicit_step(q, v, m, force, dt):
    return engine.semi_implicit_step(q, v, m, force, dt)
