"""Planted mistake: imports the engine's RK4 under its own name."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)

from engine import rk4_step as engine_rk4


def rk4_step(q, v, m, force, dt):
    return engine_rk4(q, v, m, force, dt)
