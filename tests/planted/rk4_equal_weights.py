"""Planted mistake for the checker tests: RK4 with weights 1-1-1-1."""


def euler_step(q, v, m, force, dt):
    """Explicit Euler: the position moves with the OLD velocity."""
    a = force(q, v) / m
    return q + v * dt, v + a * dt


def semi_implicit_step(q, v, m, force, dt):
    """Semi-implicit Euler: the same two lines as explicit Euler, velocity first."""
    a = force(q, v) / m
    v_next = v + a * dt
    return q + v_next * dt, v_next  # the NEW velocity moves the position


def rk4_step(q, v, m, force, dt):
    """Classical RK4: slopes of (q, v) at the start, twice at the midpoint, at the end."""
    k1q, k1v = v, force(q, v) / m
    k2q, k2v = v + k1v * (dt / 2), force(q + k1q * (dt / 2), v + k1v * (dt / 2)) / m
    k3q, k3v = v + k2v * (dt / 2), force(q + k2q * (dt / 2), v + k2v * (dt / 2)) / m
    k4q, k4v = v + k3v * dt, force(q + k3q * dt, v + k3v * dt) / m
    q_next = q + (k1q + k2q + k3q + k4q) * (dt / 4)
    v_next = v + (k1v + k2v + k3v + k4v) * (dt / 4)
    return q_next, v_next
