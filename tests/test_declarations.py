"""What each system and integrator declares is measured (the order in test_closed_form.py and test_damping.py),
and the modules import one way. A test that needs something a system does not
have skips it and says why."""

import ast
import graphlib
import math
from pathlib import Path

import numpy as np
import pytest

import engine
import engine_registry
from conftest import REPO

SYSTEMS = list(engine.SYSTEMS)
PAIRS = [(system, name) for system in SYSTEMS
         for name in engine.integrators_for(engine.build_system(system, np.random.default_rng(0)))]


def built(system_name: str) -> dict:
    return engine.build_system(system_name, np.random.default_rng(0))


def nearby_states(system: dict, count: int = 5):  # the start moved by up to 0.2 in each component
    rng = np.random.default_rng(1)
    for _ in range(count):
        yield system["q0"] + rng.uniform(-0.2, 0.2, 3), system["v0"] + rng.uniform(-0.2, 0.2, 3)


@pytest.mark.parametrize("system_name, integrator", PAIRS)
def test_each_step_asks_for_the_force_as_often_as_its_passport_says(system_name, integrator):
    system = built(system_name)
    calls = []

    def counted(q, v):
        calls.append(1)
        return system["force"](q, v)

    step = engine.integrators_for(system)[integrator]
    step(system["q0"], system["v0"], system["m"], counted, 0.01)
    assert len(calls) == engine.INTEGRATORS[integrator].force_evaluations, (
        f"{integrator} declares {engine.INTEGRATORS[integrator].force_evaluations} force evaluations per step"
        f" and made {len(calls)} on {system_name}: declare force_evaluations={len(calls)}")


@pytest.mark.parametrize("system_name", SYSTEMS)
def test_the_force_is_what_the_system_declares(system_name):
    """velocity_free=True: the force ignores the velocity, and only then; a declared dforce_dv is d force / d v;
    potential=True: force = -grad of the energy, or the energy is not the referee of the motion (independent of any
    closed form; central differences, h = 1e-6: error ~1e-9 of the force)."""
    system, h = built(system_name), 1e-6
    for q, v in nearby_states(system):
        force = system["force"](q, v)
        same = np.array_equal(force, system["force"](q, v + 0.5))
        assert same == system["velocity_free"], (
            f"{system_name} declares velocity_free={system['velocity_free']}, but its force"
            f" {'does not depend' if same else 'depends'} on the velocity")
        for axis in np.eye(3) if system.get("dforce_dv") is not None else ():
            derivative = (system["force"](q, v + h * axis) - system["force"](q, v - h * axis)) / (2 * h)
            np.testing.assert_allclose(derivative, system["dforce_dv"] * axis, rtol=0, atol=1e-6, err_msg=(
                f"{system_name} declares dforce_dv={system['dforce_dv']}, which is not d force / d v: declare the"
                " derivative its force has"))
        gradient = np.array([system["energy"](q + d, v) - system["energy"](q - d, v) for d in h * np.eye(3)]) / (2 * h)
        minus_gradient = np.allclose(force, -gradient, rtol=0, atol=1e-6 * (1 + np.abs(force).max()))
        assert minus_gradient or not system["potential"], (
            f"{system_name} declares potential=True: its force must be -grad of its energy's potential part (or"
            " declare potential=False)")


@pytest.mark.parametrize("system_name", SYSTEMS)
def test_a_damped_system_loses_energy_at_the_rate_its_dissipation_says(system_name):
    """dE/dt = -dissipation along the motion (central differences over a fine RK4 run)."""
    system = built(system_name)
    if not system["damped"]:
        pytest.skip(f"{system_name} is not damped")
    assert "dissipation" in system, f"{system_name} declares damped=True: give it dissipation(q, v), the power lost"
    positions, velocities, energies = engine.simulate(engine.rk4_step, system, dt := 1e-4, 2000)
    rate = (energies[2:] - energies[:-2]) / (2 * dt)
    power = system["dissipation"](positions[1:-1], velocities[1:-1])
    np.testing.assert_allclose(rate, -power, rtol=0, atol=1e-6 * power.max(),  # central differences: ~1e-8
                               err_msg=f"{system_name}'s dissipation(q, v) is not the rate its energy() drains at")


@pytest.mark.parametrize("system_name", SYSTEMS)
def test_a_fine_run_does_what_the_system_declares(system_name):
    """The chapter's 20 s in fine RK4 steps (dt 0.002). returns=True: the body leaves its start and comes back
    within 5% of the farthest it went; returns=False: it never does. Not damped: the energy it declares is kept
    (at most 3e-11 measured: the freefall's round-off), whether or not its force has a potential (a constraint
    force does no work)."""
    system = built(system_name)
    positions, _, energies = engine.simulate(engine.rk4_step, system, 0.002, 10_000)
    away = np.sqrt(np.sum((positions - positions[0]) ** 2, axis=1))
    farthest = np.maximum.accumulate(away)
    closest = float(np.min(away[farthest > 0] / farthest[farthest > 0]))  # nearest return, as a share of the reach
    assert (closest < 0.05) == system["returns"], (
        f"{system_name} declares returns={system['returns']}, but in 20 s it came back to within"
        f" {closest:.1%} of the farthest it went from its start")
    drift = engine.energy_drift(energies)
    assert system["damped"] or (not drift["diverged"] and drift["rel_max"] < 1e-9), (
        f"{system_name} is not damped, yet its energy() moves by {drift['rel_max']} of E0 on a fine RK4 run:"
        " is energy() the quantity its force keeps? (or declare damped=True and its dissipation)")


BAND_SLACK = 0.01  # a worst error that grows by less than 1% when the run is 8 times longer stays in a band


@pytest.mark.parametrize("system_name, integrator", PAIRS)
def test_a_symplectic_step_keeps_the_energy_in_a_band_and_no_other_does(system_name, integrator):
    """symplectic=True: on a motion that returns under a potential, the worst energy error after 8 times the run
    is the first run's, to 1%; a step that is not symplectic grows (as exercise 1 measures at dt 0.01)."""
    system = built(system_name)
    if not (system["returns"] and system["potential"] and system["velocity_free"]):
        pytest.skip(f"{system_name}: a band is a claim about a motion that returns under a velocity-free potential")
    _, _, energies = engine.simulate(engine.INTEGRATORS[integrator], system, 0.05, 16_000)
    first, whole = (engine.energy_drift(energies[: steps + 1]) for steps in (2_000, 16_000))
    growth = math.inf if whole["diverged"] else whole["rel_max"] / first["rel_max"]
    symplectic = engine.INTEGRATORS[integrator].symplectic
    assert (growth < 1 + BAND_SLACK) == symplectic, (
        f"{integrator} declares symplectic={symplectic}, but on {system_name} (dt 0.05) its worst energy error grew"
        f" {growth:.4g} times when the run was 8 times longer: declare symplectic={not symplectic}")


@pytest.mark.parametrize("system_name", SYSTEMS)
def test_no_two_integrators_are_the_same_step(system_name):
    """A step that calls another (a "new" method that is RK4 underneath) would pass every figure it copies."""
    system = built(system_name)
    runs = {name: engine.simulate(step, system, 0.05, 20)[0] for name, step in engine.integrators_for(system).items()}
    same = [(a, b) for a in runs for b in runs if a < b and np.array_equal(runs[a], runs[b])]
    assert not same, (f"on {system_name} these integrators take the very same steps: {same}: a new integrator"
                      " needs a step of its own, not another one's under a new name")


def test_an_integrator_is_offered_exactly_where_its_needs_are_met():
    """A step that needs nothing more is offered on every system; the implicit step where dforce_dv is declared;
    one that needs a velocity-free force (velocity Verlet, say) on the conservative systems, not on the damped
    spring, and asking for a step where it is not offered is one line naming the declaration that is missing."""
    assert engine.CHAPTER_INTEGRATORS == ("euler", "semi_implicit", "rk4")
    needs_nothing = {name for name, step in engine.INTEGRATORS.items() if not step.needs}
    assert all(needs_nothing <= set(engine.integrators_for(built(name))) for name in SYSTEMS)
    implicit = [name for name in SYSTEMS if "implicit" in engine.integrators_for(built(name))]
    assert implicit == [name for name in SYSTEMS if built(name).get("dforce_dv") is not None] == ["damped_spring"]

    @engine_registry.integrator("needs_velocity_free", order=1, force_evaluations=1, chapter=False,
                                needs=["velocity_free"])
    def step(q, v, m, force, dt):
        return engine.semi_implicit_step(q, v, m, force, dt)

    try:
        offered = [name for name in SYSTEMS if "needs_velocity_free" in engine.integrators_for(built(name))]
        assert offered == [name for name in SYSTEMS if built(name)["velocity_free"]]
        assert engine_registry.flag_problem("damped_spring", "needs_velocity_free", None, None) == (
            "argument --integrator: needs_velocity_free needs a system that declares velocity_free (a force that"
            f" ignores the velocity), which --system damped_spring does not: try --system {' or '.join(offered)}")
        assert engine_registry.flag_problem("spring", "implicit", None, None) == (
            "argument --integrator: implicit needs a system that declares dforce_dv (the force's derivative in the"
            " velocity), which --system spring does not: try --system damped_spring")
    finally:
        del engine.INTEGRATORS["needs_velocity_free"]


# --- the import rule ---

PROJECT = sorted([*REPO.glob("engine*.py"), *REPO.glob("curriculum/**/*.py"), *REPO.glob("exercises/**/*.py")])


def module_name(path: Path) -> str:
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, known: set) -> set:
    """The project's modules `path` imports anywhere in it, at the top or inside a function (the project
    writes no relative imports: a test below says so)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert not node.level, f"{path.relative_to(REPO)}: a relative import"
            names = [f"{node.module}.{alias.name}" if f"{node.module}.{alias.name}" in known else node.module
                     for alias in node.names]  # `from package import module` imports the module, not the package
        else:
            continue
        for name in names:
            while name and name not in known:  # a.b.c -> the longest project module it names
                name = name.rpartition(".")[0]
            if name and name != module_name(path):
                found.add(name)
    return found


def test_no_module_imports_one_that_imports_it():
    """engine imports its extensions, and none of them imports engine back: no cycle among the project's
    modules (tests and tools aside), counting imports inside functions too."""
    known = {module_name(path) for path in PROJECT}
    graph = {module_name(path): imports(path, known) for path in PROJECT}
    assert graph["engine"] >= {"engine_damping", "engine_ensembles", "engine_recording", "engine_referee",
                               "engine_registry"}

    try:
        tuple(graphlib.TopologicalSorter(graph).static_order())
    except graphlib.CycleError as cycle:
        pytest.fail(f"an import cycle: {' -> '.join(reversed(cycle.args[1]))}")
    assert "sys.modules" not in (REPO / "engine.py").read_text()  # no registering itself under another name
