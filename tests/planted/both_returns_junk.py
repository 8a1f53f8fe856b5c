"""Returns strings / wrong tuple. EXPECT: sentence naming what was returned."""


def euler_step(q, v, m, force, dt):
    a = force(q, v) / m
    return q + dt * v, v + dt * a


def semi_implicit_step(q, v, m, force, dt):
    return "q", "v"


def rk4_step(q, v, m, force, dt):
    return q, v, None
