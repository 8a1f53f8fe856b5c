"""MuJoCo habit: results written into module buffers that alias the inputs. EXPECT: fails on the run."""
import numpy as np

_q_out = None
_v_out = None


def _buffers(q):
    global _q_out, _v_out
    if _q_out is None or _q_out.shape != q.shape:
        _q_out, _v_out = np.empty_like(q), np.empty_like(q)
    return _q_out, _v_out


def euler_step(q, v, m, force, dt):
    a = force(q, v) / m
    return q + dt * v, v + dt * a


def semi_implicit_step(q, v, m, force, dt):
    qo, vo = _buffers(q)
    a = force(q, v) / m
    np.multiply(a, dt, out=vo)
    vo += v
    np.multiply(vo, dt, out=qo)
    qo += q
    return qo, vo


def rk4_step(q, v, m, force, dt):
    qo, vo = _buffers(q)
    k1q, k1v = v, force(q, v) / m
    k2q = v + 0.5 * dt * k1v
    k2v = force(q + 0.5 * dt * k1q, k2q) / m
    k3q = v + 0.5 * dt * k2v
    k3v = force(q + 0.5 * dt * k2q, k3q) / m
    k4q = v + dt * k3v
    k4v = force(q + dt * k3q, k4q) / m
    qo[...] = q
    qo += dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
    vo[...] = v
    vo += dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    return qo, vo
