"""Planted mistake: position first, then velocity from the force at the new position."""

from exercises.solutions.ex2_integrators import euler_step, rk4_step  # noqa: F401  (the right ones)


def semi_implicit_step(q, v, m, force, dt):
    q_next = q + v * dt
    v_next = v + force(q_next, v) / m * dt
    return q_next, v_next
