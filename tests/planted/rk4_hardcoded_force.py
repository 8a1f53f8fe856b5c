"""Planted mistake: the spring's force typed in; force is never called."""

from _right import semi_implicit_step  # noqa: F401  (the right one, from the helper beside this file)


def rk4_step(q, v, m, force, dt):
    def accel(x):
        return -4.0 * x / m

    k1q, k1v = v, accel(q)
    k2q, k2v = v + k1v * (dt / 2), accel(q + k1q * (dt / 2))
    k3q, k3v = v + k2v * (dt / 2), accel(q + k2q * (dt / 2))
    k4q, k4v = v + k3v * dt, accel(q + k3q * dt)
    return q + (k1q + 2 * k2q + 2 * k3q + k4q) * (dt / 6), v + (k1v + 2 * k2v + 2 * k3v + k4v) * (dt / 6)
