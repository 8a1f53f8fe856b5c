"""Planted mistake: a sign slip that matches no known mistake."""

from exercises.solutions.ex2_integrators import euler_step, rk4_step  # noqa: F401  (the right ones)


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v_next = v - a * dt  # oops: minus
    return q + v_next * dt, v_next
