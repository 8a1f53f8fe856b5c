"""Exercise 2: build them yourself. This is your file: fill in the two TODOs below.

Explicit Euler is handed to you whole. Turn it into semi-implicit Euler (MuJoCo's default)
and into RK4, changing exactly what the chapter says changes. Then check your work:

    python -m exercises.check_ex2

Everything else in exercises/ is support. Stuck? exercises/HINTS.md asks the questions that
lead there. The reference solution is in exercises/solutions/: open it after you have passed.
"""


def euler_step(q, v, m, force, dt):
    """Explicit Euler: the position moves with the OLD velocity. Given, as your starting point."""
    a = force(q, v) / m
    return q + dt * v, v + dt * a


def semi_implicit_step(q, v, m, force, dt):
    """Semi-implicit Euler, velocity first: MuJoCo's mjINT_EULER. Return (q_next, v_next)."""
    # TODO: start from euler_step. Which velocity should move the position?
    raise NotImplementedError("semi_implicit_step is not written yet")


def rk4_step(q, v, m, force, dt):
    """Classical RK4 on (q, v)' = (v, force(q, v) / m). Return (q_next, v_next)."""
    # TODO: four slopes (start, midpoint, midpoint, end), blended with weights 1-2-2-1 over 6.
    raise NotImplementedError("rk4_step is not written yet")
