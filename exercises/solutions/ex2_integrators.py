"""Reference solution for exercise 2: the engine's own steps, written the same way as in engine.py."""


def euler_step(q, v, m, force, dt):
    """Explicit Euler: the position moves with the OLD velocity."""
    a = force(q, v) / m
    return q + dt * v, v + dt * a


def semi_implicit_step(q, v, m, force, dt):
    """Semi-implicit Euler: the same two lines as explicit Euler, velocity first."""
    a = force(q, v) / m
    v_next = v + dt * a
    q_next = q + dt * v_next  # the NEW velocity moves the position
    return q_next, v_next


def rk4_step(q, v, m, force, dt):
    """Classical RK4: four symmetric samples of one deriv, at the start, twice at the midpoint, at the end."""

    def deriv(q, v):  # the slope of the state: q changes at v, v at the acceleration
        return v, force(q, v) / m

    k1q, k1v = deriv(q, v)
    k2q, k2v = deriv(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v)
    k3q, k3v = deriv(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v)
    k4q, k4v = deriv(q + dt * k3q, v + dt * k3v)
    q_next = q + (dt / 6.0) * (k1q + 2.0 * k2q + 2.0 * k3q + k4q)
    v_next = v + (dt / 6.0) * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
    return q_next, v_next
