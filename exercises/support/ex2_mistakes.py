"""Exercise 2's known mistakes and methods, as steps, with what the checker says (adding one: docs/DEVELOPING.md).

An entry (function, step, message, where) is the verdict when the student's single steps equal `step`'s on
all the checker's systems ("all"), or on those whose force ignores velocity ("velocity-free"). {orbit} and
{halving} are measured on the step's own runs. Messages never show the answer's code."""


def euler(ahead=0.0, sign=1.0, new=1.0):
    """Semi-implicit Euler varied: the force taken `ahead` steps along v, the kick's sign, and the share of the
    new velocity in the position's move (the rest: the old one's, so new=0 is explicit Euler)."""

    def step(q, v, m, force, dt):
        v_next = v + sign * dt * force(q + ahead * dt * v, v) / m
        return q + dt * (new * v_next + (1 - new) * v), v_next

    return step


def new_velocity_without_dt(q, v, m, force, dt):
    v_next = v + dt * force(q, v) / m
    return q + v_next, v_next


def velocity_verlet(q, v, m, force, dt):
    a = force(q, v) / m
    q_next = q + dt * v + 0.5 * dt * dt * a
    return q_next, v + 0.5 * dt * (a + force(q_next, v) / m)


def runge_kutta(stages, weights, start=(), scale=None):
    """An explicit Runge-Kutta step on (q, v)' = (v, a) from a Butcher tableau: rows of a, weights b. What
    `start` names stays the step's start in every stage: "force v" or "force q" (what force is given), "slope q"
    (the velocity that moves q). scale replaces dt in the final blend (lambda dt: 1.0 forgets it)."""

    def step(q, v, m, force, dt):
        kq, kv = [], []
        for row in stages:
            qs, vs = q, v
            for a_ij, kqj, kvj in zip(row, kq, kv, strict=False):
                if a_ij:
                    qs, vs = qs + (a_ij * dt) * kqj, vs + (a_ij * dt) * kvj
            kq.append(v if "slope q" in start else vs)
            kv.append(force(q if "force q" in start else qs, v if "force v" in start else vs) / m)
        h = dt if scale is None else scale(dt)
        q_next, v_next = q, v
        for b, kqj, kvj in zip(weights, kq, kv, strict=True):
            q_next, v_next = q_next + (b * h) * kqj, v_next + (b * h) * kvj
        return q_next, v_next

    return step


CLASSICAL, RK4_WEIGHTS = [[], [0.5], [0, 0.5], [0, 0, 1]], [1 / 6, 1 / 3, 1 / 3, 1 / 6]
SEMI, RK4 = "semi_implicit_step", "rk4_step"
HALVING = "halving dt divides its error by {halving} on a spring with m = 2.5."
SECOND = HALVING + " A fine second-order method, but not MuJoCo's Euler."
FLOOR = "Is something divided with //? Floor division rounds down to a whole number: 0.1 // 2 is 0."

MISTAKES = [
    (SEMI, euler(new=0), "your step still moves the position with the old velocity: that is explicit Euler. On the"
     " chapter's orbit its energy error reaches {orbit} in 2,000 steps. Which velocity should move the position?",
     "all"),
    (SEMI, euler(ahead=1, new=0), "you move the position first, then take the velocity from the force there: the other"
     " symplectic Euler, bounded too (on the chapter's orbit its energy error stays within {orbit} over 2,000"
     " steps), but not MuJoCo's. Which of the two does mjINT_EULER update first?", "all"),
    (SEMI, euler(sign=-1), "your velocity changes against the force: the spring pushes outward, the orbit's"
     " pull pushes away. Which way does a force change the velocity?", "all"),
    (SEMI, euler(ahead=1), "you take the force a step ahead, where the old velocity would carry the position, not where"
     " the step starts. Its order is 1 too, so the order cannot tell: at which position does mjINT_EULER evaluate"
     " the force?", "all"),
    (SEMI, euler(new=0.5), "you move the position by v dt + a dt^2 / 2, velocity Verlet's Taylor step. Which"
     " velocity moves the position in semi-implicit Euler?", "all"),
    (SEMI, new_velocity_without_dt, "your position update adds a velocity without multiplying it by dt. What"
     " turns a velocity into a change of position?", "all"),
    (SEMI, velocity_verlet, "on the systems whose force ignores velocity this is velocity Verlet (leapfrog's twin: a"
     " half kick, a drift, a half kick): " + SECOND + " How many times does mjINT_EULER ask for the force in one"
     " step, and which velocity moves its position?", "velocity-free"),
    (SEMI, euler(ahead=0.5, new=0.5), "on the systems whose force ignores velocity this is the drift-kick-drift"
     " leapfrog: " + SECOND + " Where does mjINT_EULER take the force, and how far does it move the position?",
     "velocity-free"),
    (RK4, runge_kutta([[]] * 4, RK4_WEIGHTS), "all four of your slopes are taken at the start of the step: explicit"
     " Euler in disguise. How far out is each later slope sampled?", "all"),
    (RK4, runge_kutta(CLASSICAL, RK4_WEIGHTS, start=["force v"]), "your stages never hand their velocity to the"
     " force: each asks with the starting v, which only a force that depends on v (the checker's damped spring)"
     " shows. Which position and which velocity does each stage hand to force(q, v)?", "all"),
    (RK4, runge_kutta(CLASSICAL, RK4_WEIGHTS, start=["force q"]), "your stages step the velocity, but every force"
     " is taken at the starting position. Which position does each stage hand to force(q, v)?", "all"),
    (RK4, runge_kutta([[], [0.5], [0.5, 0.5], [0.5, 0.5, 1]], RK4_WEIGHTS), "each of your stages steps from the"
     " stage before it, so every sample lands further out than RK4's. From which state does each stage step?", "all"),
    (RK4, runge_kutta([[], [0], [0, 0], [0, 0, 1]], RK4_WEIGHTS), "your two middle slopes are taken at the start of"
     " the step, as if half a step were 0. " + FLOOR, "all"),
    (RK4, runge_kutta(CLASSICAL, RK4_WEIGHTS, start=["slope q"]), "your position slopes are all the starting"
     " velocity. The slope of q is the velocity: which velocity, at a stage half a step out?", "all"),
    (RK4, runge_kutta([[], [0.5]], [0, 1]), "this is the midpoint method, RK2: " + HALVING + " How many samples does"
     " RK4 take, where, and how does it weigh them?", "all"),
    (RK4, runge_kutta([[], [1]], [0.5, 0.5]), "this is Heun's method, slopes at the start and the end averaged: "
     + HALVING + " Which samples does RK4 add, and how does it weigh them?", "all"),
    (RK4, runge_kutta([[], [1 / 3], [-1 / 3, 1], [1, -1, 1]], [1 / 8, 3 / 8, 3 / 8, 1 / 8]), "this is Kutta's 3/8"
     " rule: " + HALVING + " But it is not the classical RK4 of the chapter and MuJoCo's mj_RungeKutta: where does"
     " that sample its two middle slopes?", "all"),
    (RK4, runge_kutta(CLASSICAL, [1 / 4] * 4), "your four slopes are weighted equally. Which two count double in"
     " RK4?", "all"),
    (RK4, runge_kutta(CLASSICAL, [1 / 3, 1 / 6, 1 / 6, 1 / 3]), "your blend counts the end slopes double, the"
     " midpoint ones once: " + HALVING + " Which two count double in RK4?", "all"),
    (RK4, runge_kutta(CLASSICAL, RK4_WEIGHTS, scale=lambda dt: dt * dt), "every change your step makes is dt times"
     " RK4's. How many times does a slope need dt to become a change?", "all"),
    (RK4, runge_kutta(CLASSICAL, RK4_WEIGHTS, scale=lambda dt: 1.0), "your final update has no dt in it: it adds a"
     " blend of velocities to a position. What turns a slope into a change?", "all"),
    (RK4, runge_kutta([[], [1], [0, 1], [0, 0, 1]], RK4_WEIGHTS), "your midpoint stages are a full dt out. How far"
     " along the previous slope is a midpoint?", "all"),
    (RK4, runge_kutta([[], [1], [0, 0.5], [0, 0, 1]], RK4_WEIGHTS), "your k2 is sampled a whole dt out. How far"
     " along k1 is the midpoint?", "all"),
    (RK4, runge_kutta([[], [0.5], [0, 1], [0, 0, 1]], RK4_WEIGHTS), "your k3 is sampled a whole dt out. How far"
     " along k2 is the midpoint?", "all"),
    (RK4, runge_kutta([[], [0.5], [0.5], [0, 0, 1]], RK4_WEIGHTS), "your k3 steps along k1, so it repeats k2. Along"
     " which slope is the third sample taken?", "all"),
    (RK4, runge_kutta([[], [0.5], [0, 0.5], [0, 0, 0.5]], RK4_WEIGHTS), "your k4 is sampled half a step out. Where"
     " is the last slope taken?", "all"),
]
