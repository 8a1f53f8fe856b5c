"""Planted mistake: semi-implicit Euler that still moves q with the old velocity."""

from exercises.solutions.ex2_integrators import euler_step, rk4_step  # noqa: F401  (the right ones)


def semi_implicit_step(q, v, m, force, dt):
    a = force(q, v) / m
    v_next = v + a * dt
    return q + v * dt, v_next  # oops: the old velocity
