"""The systems check_ex2 runs your steps on, and collect(), which runs them (in the child on yours, in the
checker on the engine's: the same code). The chapter's have m = 1 and forces that ignore velocity, so a step
that forgets `/ m` or hands a stage the wrong velocity looks right on them; the checker's own do not."""

import math

import numpy as np

import engine
from engine_referee import damped_oscillator

CHAPTER = ("orbit", "spring", "freefall")  # built by the engine, with the chapter's constants
# name: (what it is, m, spring constant k, damping c, inverse-square pull mu, quadratic drag)
OWN = {
    "heavy_spring": ("a spring with m = 2.5", 2.5, 3.0, 0.0, 0.0, 0.0),
    "damped_spring": ("a damped spring with m = 1, force -k q - c v", 1.0, 4.0, 0.5, 0.0, 0.0),
    "heavy_damped_spring": ("a damped spring with m = 2.5", 2.5, 3.0, 0.8, 0.0, 0.0),
    "dragged_orbit": ("an orbit with drag, m = 0.7", 0.7, 0.0, 0.0, 1.0, 0.3),
}
STATE = ("q_next", "v_next")  # what a step returns
BUILT = {name: engine.build_system(name, np.random.default_rng(0)) for name in CHAPTER}


def describe(name: str) -> str:
    return f"the chapter's {name} (m = 1)" if name in CHAPTER else OWN[name][0]


def mass(name: str) -> float:
    return BUILT[name]["m"] if name in CHAPTER else OWN[name][1]


def velocity_free(name: str) -> bool:  # the chapter's forces all ignore velocity
    return name in CHAPTER or not (OWN[name][3] or OWN[name][5])


def force_law(name: str):
    """force(q, v): the chapter's own, or Hooke, damping, an inverse-square pull and quadratic drag."""
    if name in CHAPTER:
        return BUILT[name]["force"]
    _, m, k, c, mu, drag = OWN[name]

    def spring(q, v):
        return q * -k - v * c if c else q * -k

    def orbit(q, v):
        x, y, z = q.tolist()
        r = math.sqrt(x * x + y * y + z * z)
        pull = -mu * m / (r * r * r) if r > 0.0 else math.nan
        vx, vy, vz = v.tolist()
        return q * pull - v * (drag * math.sqrt(vx * vx + vy * vy + vz * vz))

    return orbit if mu else spring


def exact_position(name: str, q0, v0, t: float) -> np.ndarray:
    """Where a spring of OWN (damped or not) is at time t, by the engine's closed form."""
    _, m, k, c, _, _ = OWN[name]
    return damped_oscillator(np.asarray(q0, dtype=float), np.asarray(v0, dtype=float), k, m, c, [t])[0]


class NotOutputs(Exception):
    """What a student's step returned is not what was asked for; the message says what."""


def as_arrays(result) -> tuple:
    """A step's outputs as float arrays of shape (3,), one per name in STATE, not copied (a reused input shows)."""
    wanted = f"({', '.join(STATE)})"
    if result is None:
        raise NotOutputs(f"returns None: the function ends without returning {wanted}")
    if isinstance(result, np.ndarray) and result.ndim == 1:
        raise NotOutputs(f"returns one array of shape {result.shape}; it must return {len(STATE)}, {wanted}")
    try:
        values = list(result)
    except TypeError:
        raise NotOutputs(f"returns one {type(result).__name__}, not {wanted}") from None
    if len(values) != len(STATE):
        raise NotOutputs(f"returns {len(values)} values; it must return {len(STATE)}, {wanted}")
    arrays = []
    for what, value in zip(STATE, values, strict=True):
        try:
            arrays.append(np.asarray(value, dtype=float))
        except (TypeError, ValueError):
            raise NotOutputs(f"returns a {what} that is not numbers: {type(value).__name__}") from None
        if arrays[-1].shape != (3,):
            raise NotOutputs(f"returns a {what} of shape {arrays[-1].shape}; it must have shape (3,)")
    return tuple(arrays)


def collect(steps, task: dict) -> dict:
    """Run one task with steps.<task["function"]>: single steps, each twice from the same fresh state ("probes"),
    or one whole run, each step fed exactly what the one before returned (lists stay lists, as in engine.simulate).
    Returns plain lists, which travel as JSON."""
    step = getattr(steps, task["function"], None)
    if not callable(step):
        return {"problem": "missing" if step is None else f"not a function: it is a {type(step).__name__}"}
    calls = [0]

    def force_of(name):
        law = force_law(name)

        def force(q, v):
            calls[0] += 1
            return law(q, v)

        force.__qualname__ = "force"  # a student's wrong call reads "force() takes 2 positional arguments"
        return force

    np.seterr(all="ignore")  # a diverging step is measured, not warned about
    try:
        if task["kind"] == "probes":
            outputs, again, counts, changed = [], [], [], set()
            for probe in task["probes"]:
                for kept in (outputs, again):  # twice from the same state: do its results vary between calls?
                    q, v = np.array(probe["q"]), np.array(probe["v"])
                    calls[0] = 0
                    step_taken = step(q, v, mass(probe["system"]), force_of(probe["system"]), probe["dt"])
                    q_next, v_next = as_arrays(step_taken)
                    kept.append([q_next.tolist(), v_next.tolist()])
                    changed |= {name for name, given in (("q", q), ("v", v)) if given.tolist() != probe[name]}
                counts.append(calls[0])
            return {"outputs": outputs, "again": again, "calls": counts, "changed": sorted(changed)}
        q, v = np.array(task["q0"]), np.array(task["v0"])
        m, force, rows, reused = mass(task["system"]), force_of(task["system"]), [q.tolist() + v.tolist()], None
        for k in range(1, task["steps"] + 1):
            try:
                returned = step(q, v, m, force, task["dt"])
            except Exception as error:
                if isinstance(q, np.ndarray):
                    raise
                raise NotOutputs(f"returns a {type(q).__name__}, not a numpy array; a whole run hands each step what"
                                 f" the one before returned, then it raised {type(error).__name__}: {error}") from None
            q_next, v_next = as_arrays(returned)
            if reused is None and any(np.shares_memory(a, b) for a in (q_next, v_next) for b in (q, v)):
                reused = k
            rows.append(q_next.tolist() + v_next.tolist())
            q, v = returned
        return {"rows": rows, "reused": reused}
    except NotOutputs as problem:
        return {"problem": str(problem)}
