"""Planted mistake: calls os._exit(0), which once made the checker exit 0 with no output."""

import os

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    os._exit(0)
