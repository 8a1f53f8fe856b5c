"""Planted mistake: right numbers, returned as (v_next, q_next)."""

from _right import rk4_step  # noqa: F401


def semi_implicit_step(q, v, m, force, dt):
    v_next = v + dt * force(q, v) / m
    return v_next, q + dt * v_next
