"""The damped spring and the implicit step (issue 12), against independent truth: the closed-form solution, the
damper's work, the one-step eigenvalues (the stability map), MuJoCo 3.10.0's own integrators, and exercise 6.
"""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import engine
import engine_damping
import engine_referee
from conftest import REPO
from exercises import ex6_stiff_damping
from exercises.support import stability_map

STIFF = 300.0  # b at dt 0.01: dt b/m = 3, the stiff case of the issue


def damped(b=engine_damping.DAMPING, seed=0):
    return engine.build_system("damped_spring", np.random.default_rng(seed), b)


def run_all(system, dt, steps):  # every integrator the system is offered (tools/figures.py damped too)
    return {name: engine.simulate(step, system, dt, steps) for name, step in engine.integrators_for(system).items()}


def ours(name, b, steps=2000, dt=0.01):
    system = damped(b)
    return engine.simulate(engine.integrators_for(system)[name], system, dt, steps)[0]


# --- the system and the step ---


def test_closed_form_matches_a_fine_rk4_run_and_is_continuous_across_critical_damping():
    """The closed form in its three regimes (b 0.5, 4, 300) against RK4 at a small step (dt b/m <= 0.3, inside its
    bound): measured gaps 3e-13, 2e-13, 1.4e-9 m over 2 s; a wrong formula is off by 1e-2 or more."""
    for b in (0.5, 4.0, STIFF):
        system, dt = damped(b), 1e-3
        positions, _, _ = engine.simulate(engine.rk4_step, system, dt, 2000)
        assert np.abs(positions - system["exact"](system["q0"], system["v0"], np.arange(2001) * dt)).max() < 1e-8, b
    t = np.linspace(0.0, 5.0, 101)
    q0, v0 = np.array([1.0, 0.0, 0.0]), np.array([0.3, 0.0, 0.0])
    critical = engine_referee.damped_oscillator(q0, v0, 4.0, 1.0, 4.0, t)
    for b in (4.0 - 1e-7, 4.0 + 1e-7):
        assert np.abs(engine_referee.damped_oscillator(q0, v0, 4.0, 1.0, b, t) - critical).max() < 1e-6


def test_implicit_step_solves_for_the_damping_at_the_new_velocity_and_without_it_is_semi_implicit():
    """What the docstring says it solves: m (v' - v) / dt = -k q - b v' and q' = q + dt v', to round-off."""
    system, dt = damped(STIFF), 0.01
    q, v = np.array([0.7, -0.2, 0.1]), np.array([1.5, 0.0, -3.0])
    q1, v1 = engine.integrators_for(system)["implicit"](q, v, system["m"], system["force"], dt)
    assert np.allclose(system["m"] * (v1 - v) / dt, -4.0 * q - STIFF * v1, rtol=0, atol=1e-12)
    assert np.array_equal(q1, q + dt * v1)
    spring = engine.build_system("spring", np.random.default_rng(0))
    implicit = engine.simulate(lambda q, v, m, f, dt: engine_damping.implicit_step(q, v, m, f, dt, 0.0), spring,
                               0.01, 500)
    assert np.array_equal(implicit[0], engine.simulate(engine.semi_implicit_step, spring, 0.01, 500)[0])


def test_position_error_and_energy_audit_converge_at_each_integrators_order():
    """Against the closed form, every integrator offered on the damped spring (a new one too), over dt 0.02 ..
    0.0025: the final position error at 2 s, and (E0 - E(t)) - Simpson's integral of b|v|^2, which shrinks like
    dt^1 for the Eulers and the implicit step and dt^4 for RK4 (the quadrature is order 4, so it does not cap
    RK4's order). The audit is the worst mismatch at t = 1, 2, 3, 4, 5 s: at any single time the first-order
    error's coefficient can pass through zero (semi-implicit's does near t = 4 s). Simpson's rule is exact on
    cubics, with an even or odd number of intervals."""
    for n in (6, 7):
        t = np.linspace(0.0, 2.0, n + 1)
        assert math.isclose(engine_damping.simpson(t * t * t - t, t[1] - t[0]), 4.0 - 2.0, rel_tol=1e-13)
    system = damped()
    errors, worst = {}, {}
    for dt in (0.02, 0.01, 0.005, 0.0025):
        steps = round(5.0 / dt)
        for name, (p, v, e) in run_all(system, dt, steps).items():
            audits = [engine_damping.against_exact(system, p[:n + 1], v[:n + 1], e[:n + 1], engine.kept_steps(n), dt)
                      for n in (round(seconds / dt) for seconds in (1.0, 2.0, 3.0, 4.0, 5.0))]
            errors.setdefault(name, []).append(audits[1]["err_final"])
            worst.setdefault(name, []).append(max(abs(audit["work_mismatch"]) for audit in audits))
    wrong = []
    for what, within, series in (("position error at 2 s", 0.15, errors), ("the damper's work", 0.05, worst)):
        for name, values in series.items():
            order, declared = math.log2(values[-2] / values[-1]), engine.INTEGRATORS[name].order
            if abs(order - declared) >= within:
                wrong.append(f"{name} declares order {declared} and measured {order:.3f} ({what})")
    assert not wrong, ("; ".join(wrong) + " on the damped spring: declare the order it has, or needs=['velocity_free']"
                       " if that order holds only without velocity forces")


# --- the run: report and metrics.json (refused flags: tests/test_cli.py) ---


def test_stiff_and_default_runs_report_who_stayed_bounded(tmp_path, capsys):
    assert engine.main(["--system", "damped_spring", "--damping", f"{STIFF:g}", "--no-rerun", "--out",
                        str(tmp_path / "stiff")]) == 0
    out = capsys.readouterr()
    metrics = json.loads((tmp_path / "stiff" / "metrics.json").read_text())
    assert metrics["damping"] == STIFF and set(metrics["solution"]) == set(engine.integrators_for(damped()))
    assert {name: metrics["solution"][name]["bounded"] for name in ("euler", "semi_implicit", "rk4", "implicit")} == {
        "euler": False, "semi_implicit": False, "rk4": False, "implicit": True}
    assert metrics["solution"]["implicit"]["err_max"] < 1e-4 and out.err == ""
    assert "euler           diverged" in out.out and "over-damped" in out.out
    assert engine.main(["--system", "damped_spring", "--smoke", "--no-rerun", "--out", str(tmp_path / "b")]) == 0
    solution = json.loads((tmp_path / "b" / "metrics.json").read_text())["solution"]
    assert all(d["bounded"] for d in solution.values())
    # the ordering the chapter measures holds here too, against the closed form instead of energy
    assert solution["rk4"]["err_max"] < solution["implicit"]["err_max"] < solution["euler"]["err_max"]


def test_blew_up_at_step_n_is_one_step_named_the_same_everywhere(tmp_path, capsys):
    """Exercise 6's b = 250 (issue 24): the step a run blew up at is the step its energy overflowed (886; its state
    stays finite until step 1,748: the energy squares the speed), and the table, metrics.json, the recording and
    exercise 6 all name that one."""
    pytest.importorskip("rerun.chunk", reason="rerun-sdk is a core dependency; install the project")
    from test_recording import column, read_recording

    b = ex6_stiff_damping.DAMPING
    assert engine.main(["--system", "damped_spring", "--damping", f"{b:g}", "--out", str(tmp_path)]) == 0
    table = capsys.readouterr().out
    metrics = json.loads((tmp_path / engine.METRICS_FILE).read_text())
    _, entities, _ = read_recording(tmp_path / engine.RECORDING_FILE)
    key = " ".join(column(entities["/phase/key"], "Points3D:labels")[0])
    exercise = ex6_stiff_damping.measure()
    for name in ("euler", "semi_implicit"):  # both Eulers blow up together on this spring
        positions, velocities, energies = engine.simulate(engine.INTEGRATORS[name], damped(b), 0.01, 2000)
        if name == "semi_implicit":
            assert np.argmin(np.isfinite(positions).all(axis=-1) & np.isfinite(velocities).all(axis=-1)) == 1748
        step = int(np.flatnonzero(~np.isfinite(energies))[0])
        assert step == 886 == metrics["drift"][name]["energy_overflow_step"] == exercise[name][1]
        assert engine.energy_drift(energies)["energy_overflow_step"] == 886
        assert re.search(rf"{name} +diverged: energy overflowed at step 886\n", table)
        assert "energy overflowed at step 886" in key
        assert column(entities[f"/position_error/{name}"], "SeriesLines:names")[0][0].endswith(
            "energy overflowed at step 886")
    assert metrics["drift"]["rk4"]["energy_overflow_step"] is None and exercise["rk4"][1] is None


# --- the stability map ---


@pytest.mark.parametrize("name", stability_map.NAMES)
def test_closed_form_bounds_are_the_eigenvalues_of_the_engines_one_step_matrix(name):
    """The analytic intervals against the spectral radius of the 2x2 matrix read off the engine's own step."""
    checked = 0
    for w in (0.02, 0.5, 1.0, 1.9, 2.5, 3.0):
        interval = stability_map.analytic_interval(name, w)
        for c in (0.0, 1e-3, 0.1, 0.5, 1.0, 1.5, 2.2, 2.6, 3.1, 4.0, 10.0, 100.0):
            if interval and min(abs(c - interval[0]), abs(c - interval[1])) < 1e-6:
                continue  # on an edge the radius is 1 to round-off
            radius = max(abs(np.linalg.eigvals(stability_map.one_step_matrix(name, w, c))))
            inside = interval is not None and interval[0] <= c < interval[1]
            assert (radius <= 1.0 + 1e-12) == inside, (w, c, radius, interval)
            checked += 1
    assert checked > 60


def test_the_bounded_intervals_are_closed_except_at_w_2():
    """docs/damping.md and exercise 6: at an interval's end an eigenvalue has modulus 1 and the run stays bounded
    (the four end cells of exercise 6's map), except at w = 2, where both eigenvalues are -1 and it grows."""
    cells = {"euler": [(1.0, 1.0, True), (1.0, 2.5, True), (2.0, 4.0, False)],  # (w, c, bounded)
             "semi_implicit": [(1.0, 1.5, True), (2.0, 0.0, False)], "implicit": [(3.0, 2.5, True), (2.0, 0.0, False)]}
    for name, rows in cells.items():
        assert all(c in stability_map.analytic_interval(name, w) for w, c, bounded in rows if bounded)
        w, c, bounded = map(np.array, zip(*rows, strict=True))
        assert np.array_equal(stability_map.stays_bounded(name, w, c, steps=20_000), bounded), name
    assert [stability_map.analytic_interval(name, 2.0) for name in ("euler", "semi_implicit")] == [None, None]
    text = " ".join((REPO / "docs" / "damping.md").read_text().split())
    assert "every interval is closed" in text and "w² ≤ c ≤ 2 + w²/2" in text


@pytest.mark.slow
def test_the_whole_stability_table_agrees():
    """Measured bounds (runs of the engine's step, bisected) against the analytic ones to 1e-3, every integrator,
    every stiffness of the table, the course's spring at dt 0.01 (w = 0.02) included. Runs half as long and a
    grid half as fine as the printed table's (4.6 s of CPU instead of 13.9) still agree everywhere."""
    def agree(measured, analytic):
        if measured is None or analytic is None:
            return measured is analytic
        return all(m == a or abs(m - a) <= 1e-3 * abs(a) + 1e-6 for m, a in zip(measured, analytic, strict=True))

    for name in stability_map.NAMES:
        ws = stability_map.STIFFNESSES
        for w, measured in zip(ws, stability_map.measured_intervals(name, ws, 2000, 61, 14), strict=True):
            assert agree(measured, stability_map.analytic_interval(name, w)), (name, w, measured)


# --- parity with MuJoCo 3.10.0 ---

DAMPINGS = [0.5, 1.3, 4.0, 37.0, STIFF]


@pytest.fixture
def models():
    pytest.importorskip("mujoco", reason="MuJoCo parity needs the 'mujoco' extra: pip install -e '.[mujoco]'")
    import mujoco_models

    return mujoco_models


def test_implicit_step_is_mujocos_euler_and_implicitfast_to_the_bit_and_its_implicit_to_the_last_ulps(models):
    """mj_EulerSkip with damping and mj_implicitSkip for implicitfast both factorize M + h b (mj_factorI stores
    1 / diagonal) and multiply by it (mj_solveLD): our `force * (1 / (m - dt dforce_dv))`. mjINT_IMPLICIT solves
    with mju_solveLUSparse, which divides, x / d: the same step written with a division is it to the bit, and the
    two differ in the last bit now and then (seen at some damping here, or "last ulps" would be a claim unseen)."""
    differing = 0
    for b in DAMPINGS:
        mine, system = ours("implicit", b), damped(b)
        assert np.array_equal(mine, models.damped_trajectory("Euler", b)[0])
        assert np.array_equal(mine, models.damped_trajectory("implicitfast", b)[0])
        theirs = models.damped_trajectory("implicit", b)[0]
        assert np.abs(mine - theirs).max() <= 4 * np.finfo(float).eps * np.abs(theirs).max()
        differing += np.abs(mine - theirs).max() > 0

        def dividing(q, v, m, force, dt, system=system):
            v_next = v + dt * (force(q, v) / (m - dt * system["dforce_dv"]))
            return q + dt * v_next, v_next

        assert np.array_equal(engine.simulate(dividing, system, 0.01, 2000)[0], theirs)
    assert differing > 0


@pytest.mark.parametrize("b", [0.5, 4.0])
def test_explicit_damping_is_mujocos_euler_only_with_eulerdamp_disabled(b, models):
    """mjDSBL_EULERDAMP turns mj_EulerSkip's damping branch off: the damper is then an explicit force."""
    assert np.abs(ours("semi_implicit", b) - models.damped_trajectory("Euler", b)[0]).max() > 1e-3
    assert np.array_equal(ours("semi_implicit", b), models.damped_trajectory("Euler", b, eulerdamp=False)[0])


def test_stiff_damping_mujocos_euler_creeps_to_rest_while_rk4_blows_up_and_leaves_no_log_behind(tmp_path, models,
                                                                                                  monkeypatch):
    """At b = 300 MuJoCo's RK4 (no implicit damping) blows up, warns, resets and writes MUJOCO_LOG.TXT where it
    runs: our runs keep it in a folder that goes away with them."""
    import mujoco

    euler, reset_at = models.damped_trajectory("Euler", STIFF)
    assert reset_at is None and np.all(np.diff(euler[:, 0]) < 0) and euler[-1, 0] > 0  # over-damped creep
    assert not np.isfinite(ours("semi_implicit", STIFF)).all()
    monkeypatch.chdir(tmp_path)
    rk4, reset_at = models.damped_trajectory("RK4", STIFF)
    mine = ours("rk4", STIFF)[:reset_at]
    assert reset_at is not None and np.abs(mine - rk4[:reset_at]).max() <= 1e-13 * np.abs(mine).max()
    assert list(tmp_path.iterdir()) == [] and Path.cwd() == tmp_path
    assert not (REPO / "MUJOCO_LOG.TXT").exists() and not (REPO / "tests" / "MUJOCO_LOG.TXT").exists()
    model = mujoco.MjModel.from_xml_string(models.damped_xml("RK4", 0.01, damped(STIFF)))
    data = mujoco.MjData(model)
    data.qpos[0] = 1.0
    with models.in_scratch_folder() as scratch:  # ... and MuJoCo does write one where it runs, when it warns
        mujoco.mj_step(model, data, nstep=200)
        assert (scratch / "MUJOCO_LOG.TXT").exists()


# --- exercise 6 ---

def test_ex6_answer_is_the_stability_map_at_its_damping():
    """The measured verdicts equal what the one-step eigenvalues say at c = 2.5, w = 0.02. Explicit Euler needs
    damping (a lower bound), the implicit step no bound on it, though stiffness still bounds it."""
    assert stability_map.analytic_interval("euler", 0.5)[0] == 0.25
    assert stability_map.analytic_interval("implicit", 0.5) == (0.0, math.inf)
    assert stability_map.analytic_interval("implicit", 4.0) == (6.0, math.inf)
    measured = {name: bounded for name, (bounded, _, _) in ex6_stiff_damping.measure().items()}
    c, w = ex6_stiff_damping.DT * ex6_stiff_damping.DAMPING, ex6_stiff_damping.DT * 2.0
    analytic = {}
    for name in stability_map.NAMES:
        interval = stability_map.analytic_interval(name, w)
        analytic[name] = interval is not None and interval[0] <= c < interval[1]
    assert measured == analytic == {"euler": False, "semi_implicit": False, "rk4": True, "implicit": True}
    grid = ex6_stiff_damping.bounded_map()
    assert grid["implicit"][-1].all() and not grid["implicit"][0, :3].any()  # any damping; not any stiffness
