"""Right, written another way: both steps imported from a helper module in the same folder."""

from _right import rk4_step as _rk4
from _right import semi_implicit_step as _semi


def semi_implicit_step(q, v, m, force, dt):
    return _semi(q, v, m, force, dt)


def rk4_step(q, v, m, force, dt):
    return _rk4(q, v, m, force, dt)
