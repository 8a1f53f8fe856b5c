"""Right, with a debugging print in every call of both steps: about 14,000 prints in one check."""

from _right import rk4_step as right_rk4_step
from _right import semi_implicit_step as right_semi_implicit_step


def semi_implicit_step(q, v, m, force, dt):
    print("semi", q, v, dt)
    return right_semi_implicit_step(q, v, m, force, dt)


def rk4_step(q, v, m, force, dt):
    print("rk4", q, v, dt)
    return right_rk4_step(q, v, m, force, dt)
