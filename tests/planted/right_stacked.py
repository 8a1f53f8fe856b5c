"""Right, written another way: a stacked 6-vector state (q, v) inside the step."""

import numpy as np


def semi_implicit_step(q, v, m, force, dt):
    v_next = v + force(q, v) / m * dt
    return q + v_next * dt, v_next


def rk4_step(q, v, m, force, dt):
    def f(y):
        return np.concatenate([y[3:], force(y[:3], y[3:]) / m])

    y = np.concatenate([q, v])
    k1 = f(y)
    k2 = f(y + dt / 2 * k1)
    k3 = f(y + dt / 2 * k2)
    k4 = f(y + dt * k3)
    y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return y[:3], y[3:]
