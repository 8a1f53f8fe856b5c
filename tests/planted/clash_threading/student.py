"""A right file with a scratch threading.py beside it. EXPECT: solved, and a sentence naming the clash."""
A = [[], [0.5], [0.0, 0.5], [0.0, 0.0, 1.0]]
B = [1 / 6, 1 / 3, 1 / 3, 1 / 6]


def euler_step(q, v, m, force, dt):
    a = force(q, v) / m
    return q + dt * v, v + dt * a


def semi_implicit_step(q, v, m, force, dt):
    f = force(q, v)
    v1 = v + f * (dt / m)
    return q + v1 * dt, v1


def rk4_step(q, v, m, force, dt):
    kq, kv = [], []
    for row in A:
        qs = q + dt * sum((c * k for c, k in zip(row, kq)), 0.0 * q)
        vs = v + dt * sum((c * k for c, k in zip(row, kv)), 0.0 * v)
        kq.append(vs)
        kv.append(force(qs, vs) / m)
    return (q + dt * sum(b * k for b, k in zip(B, kq)),
            v + dt * sum(b * k for b, k in zip(B, kv)))
