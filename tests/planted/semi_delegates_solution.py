"""Planted mistake: hands the work to the reference solution, under another name."""

from _right import rk4_step  # noqa: F401  (the right one, from the helper beside this file)

from exercises.solutions.ex2_integrators import semi_implicit_step as reference


def semi_implicit_step(q, v, m, force, dt):
    return reference(q, v, m, force, dt)
