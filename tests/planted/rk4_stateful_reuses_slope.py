"""Stateful: RK4 reuses the last call's k4 as k1 when fed its own output. EXPECT: fails on the run."""
import numpy as np

_last = {}


def euler_step(q, v, m, force, dt):
    a = force(q, v) / m
    return q + dt * v, v + dt * a


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v = v + dt * a
    q = q + dt * v
    return q, v


def rk4_step(q, v, m, force, dt):
    if _last and np.array_equal(_last["q"], q) and np.array_equal(_last["v"], v):
        k1v = _last["k4v"]
    else:
        k1v = force(q, v) / m
    k1q = v
    k2q, k2v = v + 0.5 * dt * k1v, force(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v) / m
    k3q, k3v = v + 0.5 * dt * k2v, force(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v) / m
    k4q, k4v = v + dt * k3v, force(q + dt * k3q, v + dt * k3v) / m
    qn = q + dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
    vn = v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    _last.update(q=qn.copy(), v=vn.copy(), k4v=k4v)
    return qn, vn
