"""Planted mistake: single precision: right arithmetic, float32 results."""

import numpy as np
from _right import rk4_step  # noqa: F401


def semi_implicit_step(q, v, m, force, dt):
    v_next = (v + dt * force(q, v) / m).astype(np.float32)
    return (q + dt * v_next).astype(np.float32), v_next
