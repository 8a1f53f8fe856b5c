"""The declarations behind engine.py's systems and integrators, and the check of the batch contract.

`@system(name, returns=..., ...)` on a function build(rng) and `@integrator(name, order=..., ...)` on a
step put them in SYSTEMS and INTEGRATORS with the facts the run, the verdict, the exercises and the tests
read; nothing keeps a second list. A system's facts (build.facts, copied into the system by
engine.build_system):

- returns: the motion comes back (orbit, spring), so the drift ordering is judged on it;
- potential: the force is minus the gradient of the energy's potential part (so energy is conserved);
- velocity_free: the force ignores the velocity;
- damped: the energy drains by design (the system gives `dissipation` and `dforce_dv`), and its exact
  motion referees the run instead.

An integrator's passport (attributes of the step): order, force_evaluations (per step), symplectic (its
energy error stays in a band on a motion that comes back), chapter (one of the chapter's three, which the
verdict and the exercises compare by name) and needs: what a system must
declare for the step to be offered on it, a fact that must be true (velocity_free, for a method whose order
holds only for forces that ignore the velocity) or a value the step takes as an argument (dforce_dv, for
implicit_step). `integrators_for(system)` offers exactly those. tests/test_declarations.py measures every
declared figure and fact (the order in tests/test_closed_form.py and tests/test_damping.py, potential in
tests/test_engine.py).

It imports numpy and nothing of the project's: engine.py imports it.
"""

import functools

import numpy as np

SYSTEMS = {}  # name -> build(rng), in the order declared: what --system offers
INTEGRATORS = {}  # name -> step(q, v, m, force, dt), in the order declared


def system(name: str, returns=False, potential=True, velocity_free=True, damped=False):
    """Declare the decorated build(rng) as the system `name`, with its facts (see above)."""
    def declare(build):
        build.facts = {"returns": returns, "potential": potential, "velocity_free": velocity_free, "damped": damped}
        SYSTEMS[name] = build
        return build

    return declare


def integrator(name: str, order: int, force_evaluations: int, symplectic=False, chapter=True, needs=()):
    """Declare the decorated step under `name`, with its passport (see above)."""
    def declare(step):
        vars(step).update(order=order, force_evaluations=force_evaluations, symplectic=symplectic, chapter=chapter,
                          needs=tuple(needs))
        INTEGRATORS[name] = step
        return step

    return declare


def build_system(name: str, rng, damping: float | None = None) -> dict:
    """The system `name` as a dict {name, its facts, q0, v0, m, force, energy, exact, ...}; `damping`, if given,
    is the damped spring's b. The seed jitters one number of the start (orbit speed, spring stretch, launch
    speed), so --seed matters while the ordering of the drifts does not change."""
    build = SYSTEMS.get(name)
    if build is None:
        raise ValueError(f"unknown system {name!r}; choose one of {', '.join(SYSTEMS)}")
    settings = {} if damping is None else {"damping": damping}
    return {"name": name, **build.facts, **build(rng, **settings)}


def integrators_for(system: dict) -> dict:
    """{name: step(q, v, m, force, dt)} for every integrator whose needs `system` meets; a need that is one of
    the step's arguments (implicit_step's dforce_dv) is passed in from the system."""
    offered = {}
    for name, step in INTEGRATORS.items():
        if all(meets(system, need) for need in step.needs):
            given = {need: system[need] for need in step.needs if need in step.__code__.co_varnames}
            offered[name] = functools.partial(step, **given) if given else step
    return offered


def check_contract(system: dict, q, v) -> None:
    """Fail at once, with a sentence, if a system breaks the batch contract (engine.py states it): q and v
    (3,) or (N, 3), force(q, v) of q's shape, energy(q, v) one number per body. Tried on at most 3 bodies; the
    energy on 2 or 3 even for one body, since simulate() hands it every state at once."""
    name = system.get("name", "this system")
    if q.ndim not in (1, 2) or q.shape[-1] != 3 or v.shape != q.shape:
        raise ValueError(f"{name}: q0 and v0 must both be (3,) for one body or (N, 3) for N bodies, "
                         f"got {q.shape} and {v.shape}")
    few = slice(None) if q.ndim == 1 else slice(0, 3)  # per-body laws: a few bodies show the shapes
    force = returned(system["force"], q[few], v[few])
    if force != q[few].shape:
        raise ValueError(f"{name}: force(q, v) must return one force per body, shape {q[few].shape}, got {force}")
    states_q, states_v = np.reshape(q, (-1, 3))[:3], np.reshape(v, (-1, 3))[:3]
    if len(states_q) == 1:
        states_q, states_v = np.concatenate([states_q] * 2), np.concatenate([states_v] * 2)
    energy = returned(system["energy"], states_q, states_v)
    if energy != states_q.shape[:-1]:  # `v @ v`, the chapter's one-body energy, sums over the whole batch or fails
        raise ValueError(f"{name}: energy(q, v) must return one number per body, shape {states_q.shape[:-1]} for"
                         f" {len(states_q)} bodies, got {energy} (sum the three components with dot3, not over the"
                         " whole array)")


def returned(law, q, v):
    """The shape of what law(q, v) returns, or the exception it raised, in words."""
    try:
        with np.errstate(all="ignore"):
            return np.shape(law(q, v))
    except Exception as error:  # a law written for one body only, such as v @ v, may fail on a batch
        return f"a {type(error).__name__}"


NEEDS = {"dforce_dv": "the force's derivative in the velocity", "velocity_free": "a force that ignores the velocity"}


def meets(system: dict, need: str) -> bool:
    """Whether `system` declares `need`: a fact that is true, or a value (0.0 is a value)."""
    return system.get(need) is not None and system.get(need) is not False


def flag_problem(system_name: str, integrator_name: str, damping, ensemble) -> str | None:
    """What is wrong with engine.py's --system, --integrator, --damping and --ensemble together, or None."""
    damped = [name for name, build in SYSTEMS.items() if build.facts["damped"]]
    if damping is not None and system_name not in damped:
        return f"argument --damping: only --system {' or '.join(damped)} has a damper"
    if ensemble and system_name in damped:
        return ("argument --ensemble: ensembles compare energy drift on the conservative systems"
                f" ({', '.join(name for name in SYSTEMS if name not in damped)})")
    if integrator_name == "all":
        return None
    built = {name: build_system(name, np.random.default_rng(0)) for name in SYSTEMS}
    if integrator_name in integrators_for(built[system_name]):
        return None
    offered = [name for name, system in built.items() if integrator_name in integrators_for(system)]
    need = next(need for need in INTEGRATORS[integrator_name].needs if not meets(built[system_name], need))
    elsewhere = f"try --system {' or '.join(offered)}" if offered else "no system declares it yet"
    return (f"argument --integrator: {integrator_name} needs a system that declares {need} ({NEEDS.get(need, need)}),"
            f" which --system {system_name} does not: {elsewhere}")
