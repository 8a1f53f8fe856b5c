"""Planted mistake: each stage steps from the previous stage's state instead of from (q, v)."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)


def rk4_step(q, v, m, force, dt):
    k1q, k1v = v, force(q, v) / m
    q2, v2 = q + k1q * (dt / 2), v + k1v * (dt / 2)
    k2q, k2v = v2, force(q2, v2) / m
    q3, v3 = q2 + k2q * (dt / 2), v2 + k2v * (dt / 2)
    k3q, k3v = v3, force(q3, v3) / m
    q4, v4 = q3 + k3q * dt, v3 + k3v * dt
    k4q, k4v = v4, force(q4, v4) / m
    return q + (k1q + 2 * k2q + 2 * k3q + k4q) * (dt / 6), v + (k1v + 2 * k2v + 2 * k3v + k4v) * (dt / 6)
