"""Right steps the planted files import, so each planted file holds only its one mistake.

Written unlike the reference solution on purpose (dt first, a deriv helper), and importing it
tests that the student's own folder is importable when the checker runs a file.
"""


def semi_implicit_step(q, v, m, force, dt):
    v_next = v + dt * (force(q, v) / m)
    return q + dt * v_next, v_next


def deriv(force, m, q, v):
    return v, force(q, v) / m


def rk4_step(q, v, m, force, dt):
    k1q, k1v = deriv(force, m, q, v)
    k2q, k2v = deriv(force, m, q + 0.5 * dt * k1q, v + 0.5 * dt * k1v)
    k3q, k3v = deriv(force, m, q + 0.5 * dt * k2q, v + 0.5 * dt * k2v)
    k4q, k4v = deriv(force, m, q + dt * k3q, v + dt * k3v)
    return q + dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q), v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
