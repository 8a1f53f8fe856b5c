"""Planted mistake: a stacked 6-vector, returned whole instead of as (q_next, v_next)."""

import numpy as np
from _right import semi_implicit_step  # noqa: F401


def rk4_step(q, v, m, force, dt):
    def f(y):
        return np.concatenate([y[3:], force(y[:3], y[3:]) / m])

    y = np.concatenate([q, v])
    k1 = f(y)
    k2 = f(y + dt / 2 * k1)
    k3 = f(y + dt / 2 * k2)
    k4 = f(y + dt * k3)
    return y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
