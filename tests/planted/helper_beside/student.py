"""Correct file using its own helper module. EXPECT: solved."""
from mysteps import weights


def euler_step(q, v, m, force, dt):
    a = force(q, v) / m
    return q + dt * v, v + dt * a

def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v = v + dt * a
    q = q + dt * v
    return q, v

def rk4_step(q, v, m, force, dt):
    def deriv(q, v):
        return v, force(q, v) / m
    k1q, k1v = deriv(q, v)
    k2q, k2v = deriv(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v)
    k3q, k3v = deriv(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v)
    k4q, k4v = deriv(q + dt * k3q, v + dt * k3v)
    w1, w2, w3, w4 = weights()
    return q + dt * (w1 * k1q + w2 * k2q + w3 * k3q + w4 * k4q), v + dt * (w1 * k1v + w2 * k2v + w3 * k3v + w4 * k4v)
