"""Right, written another way: np.add and np.multiply, semi-implicit Euler returning its pair as a list."""

import numpy as np


def semi_implicit_step(q, v, m, force, dt):
    v_next = np.add(v, np.multiply(dt, np.divide(force(q, v), m)))
    return [np.add(q, np.multiply(dt, v_next)), v_next]


def rk4_step(q, v, m, force, dt):
    def deriv(x, u):
        return u, np.divide(force(x, u), m)

    k1q, k1v = deriv(q, v)
    k2q, k2v = deriv(np.add(q, 0.5 * dt * k1q), np.add(v, 0.5 * dt * k1v))
    k3q, k3v = deriv(np.add(q, 0.5 * dt * k2q), np.add(v, 0.5 * dt * k2v))
    k4q, k4v = deriv(np.add(q, dt * k3q), np.add(v, dt * k3v))
    q_next = np.add(q, dt / 6 * np.add(np.add(k1q, 2 * k2q), np.add(2 * k3q, k4q)))
    v_next = np.add(v, dt / 6 * np.add(np.add(k1v, 2 * k2v), np.add(2 * k3v, k4v)))
    return q_next, v_next
