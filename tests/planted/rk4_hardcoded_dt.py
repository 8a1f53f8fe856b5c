"""Slip: RK4 uses dt = 0.01 hard-coded. EXPECT: fails, no made-up order claim."""


def euler_step(q, v, m, force, dt):
    a = force(q, v) / m
    return q + dt * v, v + dt * a


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v = v + dt * a
    q = q + dt * v
    return q, v


def rk4_step(q, v, m, force, dt):
    dt = 0.01
    def deriv(q, v):
        return v, force(q, v) / m
    k1q, k1v = deriv(q, v)
    k2q, k2v = deriv(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v)
    k3q, k3v = deriv(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v)
    k4q, k4v = deriv(q + dt * k3q, v + dt * k3v)
    return q + dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q), v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
