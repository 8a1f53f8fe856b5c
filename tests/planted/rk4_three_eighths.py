"""Planted mistake: Kutta's 3/8 rule."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)


def rk4_step(q, v, m, force, dt):
    k1q, k1v = v, force(q, v) / m
    k2q, k2v = v + dt / 3 * k1v, force(q + dt / 3 * k1q, v + dt / 3 * k1v) / m
    q3, v3 = q + dt * (k2q - k1q / 3), v + dt * (k2v - k1v / 3)
    k3q, k3v = v3, force(q3, v3) / m
    q4, v4 = q + dt * (k1q - k2q + k3q), v + dt * (k1v - k2v + k3v)
    k4q, k4v = v4, force(q4, v4) / m
    return q + dt / 8 * (k1q + 3 * k2q + 3 * k3q + k4q), v + dt / 8 * (k1v + 3 * k2v + 3 * k3v + k4v)
