"""The usual mistakes in exercise 2, written as steps, so check_ex2 can recognise them by what they compute.

Each entry is (step, message). The checker runs the student's step and every entry here on the same
states; when the student's numbers equal an entry's on all of them, that entry's message is the verdict.
Messages speak to the student and say what the code does, then what the chapter's method does instead.
"""


def _acceleration(mass_rule):
    """force -> acceleration the right way (/ m) or one of the wrong ways."""
    return {"right": lambda f, m: f / m, "forgot": lambda f, m: f, "twice": lambda f, m: f / m / m,
            "times": lambda f, m: f * m}[mass_rule]


# --- semi-implicit Euler ---


def semi(mass_rule="right"):
    accel = _acceleration(mass_rule)

    def step(q, v, m, force, dt):
        v_next = v + dt * accel(force(q, v), m)
        return q + dt * v_next, v_next

    return step


def explicit_euler(q, v, m, force, dt):
    return q + dt * v, v + dt * force(q, v) / m


def position_first(q, v, m, force, dt):
    q_next = q + dt * v
    return q_next, v + dt * force(q_next, v) / m


def taylor_position(q, v, m, force, dt):
    a = force(q, v) / m
    return q + dt * v + 0.5 * dt * dt * a, v + dt * a


def new_velocity_without_dt(q, v, m, force, dt):
    v_next = v + dt * force(q, v) / m
    return q + v_next, v_next


def mass(how_far_off: str) -> str:
    """What a mass mistake does, said once for both steps."""
    return ("Where the force becomes an acceleration, the acceleration is force / m, once. With the chapter's mass"
            f" of 1 no run can tell the difference; on the checker's m = 2.5 spring your acceleration is"
            f" {how_far_off}.")

SEMI_MISTAKES = [
    (explicit_euler, "your step still moves the position with the old velocity: that is explicit Euler."
                     " {orbit_energy} Update the velocity first, then move the position with the new one."),
    (position_first, "you move the position first, then take the velocity from the force at the new position."
                     " That is the other symplectic Euler: valid, and bounded ({orbit_band}), but not MuJoCo's."
                     " mjINT_EULER updates the velocity first and moves the position with the new velocity."),
    (semi("forgot"), "you use force(q, v) itself as the acceleration: you forgot to divide by m. "
                     + mass("2.5 times too large")),
    (semi("twice"), "you divide the force by m twice. " + mass("2.5 times too small")),
    (semi("times"), "you multiply the force by m where the acceleration is force / m. "
                    + mass("6.25 times too large")),
    (taylor_position, "you move the position by v dt + a dt^2 / 2, the Taylor step that velocity Verlet uses: a"
                      " second-order idea, but your velocity update is first order, and this is not semi-implicit"
                      " Euler. Semi-implicit Euler moves the position with the NEW velocity: q + dt * v_next."),
    (new_velocity_without_dt, "your position update adds the new velocity without multiplying it by dt: a"
                              " velocity is metres per second, a position change is velocity times dt."),
]


# --- RK4 ---


def runge_kutta(stages, weights, mass_rule="right", stage_velocity=True, position_slope="stage", scale=None):
    """An explicit Runge-Kutta step on (q, v)' = (v, a) from a Butcher tableau.

    stages: rows of a (how far along each earlier slope a stage is sampled), weights: b.
    stage_velocity=False hands every stage the starting v (the stages never pass on their velocity);
    position_slope="start" uses the starting v as every stage's slope of q; scale multiplies the blend
    (None: dt, the right one; 1: dt forgotten; dt * 6/4: weights that sum to 1.5...).
    """
    accel = _acceleration(mass_rule)

    def step(q, v, m, force, dt):
        kq, kv = [], []
        for row in stages:
            qs, vs = q, v
            for a_ij, kqj, kvj in zip(row, kq, kv, strict=False):
                if a_ij:
                    qs, vs = qs + (a_ij * dt) * kqj, vs + (a_ij * dt) * kvj
            kq.append(vs if position_slope == "stage" else v)
            kv.append(accel(force(qs, vs if stage_velocity else v), m))
        h = dt if scale is None else scale(dt)
        q_next, v_next = q, v
        for b, kqj, kvj in zip(weights, kq, kv, strict=True):
            q_next, v_next = q_next + (b * h) * kqj, v_next + (b * h) * kvj
        return q_next, v_next

    return step


CLASSICAL = [[], [0.5], [0, 0.5], [0, 0, 1]]
RK4_WEIGHTS = [1 / 6, 1 / 3, 1 / 3, 1 / 6]
THREE_EIGHTHS = [[], [1 / 3], [-1 / 3, 1], [1, -1, 1]]

STAGES = ("Each stage asks force for the acceleration at that stage's own position AND velocity: k2 at"
          " (q + dt/2 k1q, v + dt/2 k1v), and so on.")

RK4_MISTAKES = [
    (runge_kutta([[]] * 4, [1 / 6, 1 / 3, 1 / 3, 1 / 6]),
     "all four of your slopes are taken at the start of the step, so the blend (k1 + 2 k1 + 2 k1 + k1) / 6 is"
     " just k1: that is explicit Euler in disguise. k2 and k3 are sampled half a step out, k4 a whole step."),
    (runge_kutta(CLASSICAL, RK4_WEIGHTS, mass_rule="forgot"),
     "you use the force itself as the acceleration in your slopes: you forgot to divide by m. "
     + mass("2.5 times too large")),
    (runge_kutta(CLASSICAL, RK4_WEIGHTS, mass_rule="twice"),
     "you divide the force by m twice. " + mass("2.5 times too small")),
    (runge_kutta(CLASSICAL, RK4_WEIGHTS, mass_rule="times"),
     "you multiply the force by m where the acceleration is force / m. " + mass("6.25 times too large")),
    (runge_kutta(CLASSICAL, RK4_WEIGHTS, stage_velocity=False),
     "your stages never hand their velocity to the force: each calls force(q_stage, v) with the starting v."
     " With forces that ignore velocity (all three of the chapter's) nobody can tell; on the checker's damped"
     " spring, whose force is -k q - c v, you can. " + STAGES),
    (runge_kutta(CLASSICAL, RK4_WEIGHTS, position_slope="start"),
     "your position slopes are all the starting velocity (k2q = k3q = k4q = v). The slope of q at a stage is"
     " the velocity AT that stage: k2q = v + dt/2 k1v, and so on."),
    (runge_kutta([[], [0.5]], [0, 1]),
     "this is the midpoint method, RK2: one slope at the start, one at the midpoint, and the step taken with"
     " the midpoint slope. It is second order. RK4 adds a second midpoint sample and an end sample, and blends"
     " all four 1-2-2-1."),
    (runge_kutta([[], [1]], [0.5, 0.5]),
     "this is Heun's method, a second-order Runge-Kutta: slopes at the start and at the end, averaged. RK4"
     " samples the midpoint twice as well, and blends the four 1-2-2-1."),
    (runge_kutta(THREE_EIGHTHS, [1 / 8, 3 / 8, 3 / 8, 1 / 8]),
     "this is Kutta's 3/8 rule: a fourth-order method (stages at 1/3 and 2/3 of the step, weights 1-3-3-1 over"
     " 8), but not the classical RK4 the chapter and MuJoCo's mj_RungeKutta use: midpoints twice, weights"
     " 1-2-2-1 over 6. Its numbers differ from RK4's, so it does not pass."),
    (runge_kutta(CLASSICAL, [1 / 4] * 4),
     "your four slopes are weighted 1-1-1-1. The two midpoint slopes must count double:"
     " (k1 + 2 k2 + 2 k3 + k4) / 6."),
    (runge_kutta(CLASSICAL, RK4_WEIGHTS, scale=lambda dt: 1.0),
     "your final update has no dt in it: q + (k1q + 2 k2q + 2 k3q + k4q) / 6 adds a velocity to a position."
     " The blended slope is multiplied by dt: q + dt/6 (k1q + 2 k2q + 2 k3q + k4q)."),
    (runge_kutta([[], [1], [0, 1], [0, 0, 1]], RK4_WEIGHTS),
     "your midpoint stages are a full dt out. k2 is the slope half a step along k1, at q + (dt/2) k1q,"
     " v + (dt/2) k1v; k3 half a step along k2; only k4 goes the whole dt."),
    (runge_kutta([[], [1], [0, 0.5], [0, 0, 1]], RK4_WEIGHTS),
     "your k2 is sampled a whole dt out; it is a midpoint slope, half a step along k1:"
     " (q + dt/2 k1q, v + dt/2 k1v). Only k4 goes the whole dt."),
    (runge_kutta([[], [0.5], [0, 1], [0, 0, 1]], RK4_WEIGHTS),
     "your k3 is sampled a whole dt out; it is a midpoint slope, half a step along k2:"
     " (q + dt/2 k2q, v + dt/2 k2v). Only k4 goes the whole dt."),
    (runge_kutta([[], [0.5], [0.5], [0, 0, 1]], RK4_WEIGHTS),
     "your k3 steps along k1 instead of k2, so k3 is a copy of k2. The third sample is half a step along the"
     " SECOND slope: (q + dt/2 k2q, v + dt/2 k2v)."),
    (runge_kutta([[], [0.5], [0, 0.5], [0, 0, 0.5]], RK4_WEIGHTS),
     "your k4 is sampled half a step out; the last slope is taken at the end of the step, a whole dt along k3:"
     " (q + dt k3q, v + dt k3v)."),
]
