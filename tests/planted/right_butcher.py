"""Right, written another way: RK4 as a loop over a Butcher tableau."""


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v = v + dt * a
    return q + dt * v, v


def rk4_step(q, v, m, force, dt):
    a = [[], [0.5], [0.0, 0.5], [0.0, 0.0, 1.0]]
    b = [1 / 6, 1 / 3, 1 / 3, 1 / 6]
    kq, kv = [], []
    for row in a:
        qs, vs = q.copy(), v.copy()
        for aij, kqj, kvj in zip(row, kq, kv):
            qs = qs + dt * aij * kqj
            vs = vs + dt * aij * kvj
        kq.append(vs)
        kv.append(force(qs, vs) / m)
    return q + dt * sum(bi * k for bi, k in zip(b, kq)), v + dt * sum(bi * k for bi, k in zip(b, kv))
