"""Planted mistake: replaces the engine's integrators at import time (once reported 'All solved.')."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)

import engine


def semi_implicit_step(q, v, m, force, dt):
    return q + v * dt, v + force(q, v) / m * dt  # explicit Euler


engine.semi_implicit_step = semi_implicit_step
engine.INTEGRATORS["semi_implicit"] = semi_implicit_step
