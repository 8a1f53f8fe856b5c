"""Planted mistake: calls sys.exit(0), which once made the checker report success."""

import sys

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)


def semi_implicit_step(q, v, m, force, dt):
    sys.exit(0)
