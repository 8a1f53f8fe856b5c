"""The physics: the chapter's published figures, the metrics schema, determinism on any CPU."""

import inspect
import json
import os
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import engine
import engine_damping
import engine_referee
from conftest import REPO, ensemble_of, run, run_engine

GOLDEN = REPO / "tests" / "golden"
SIMD_OFF = {"NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR X86_V3"}  # numpy's AVX-512 and AVX2 loops off


def drift_of(system, integrator, seed=0):
    return engine.energy_drift(run(system, integrator, seed=seed)[2])


def percent(x, digits):  # the figure as the chapter prints it: a percentage to `digits` significant digits
    return float(f"{100 * x:.{digits}g}")


def test_orbit_and_freefall_reproduce_the_chapters_table_and_caveat():
    euler, semi, rk4 = (drift_of("orbit", name) for name in engine.CHAPTER_INTEGRATORS)
    assert (percent(euler["rel_final"], 3), percent(euler["rel_max"], 3)) == (22.1, 22.1)
    assert (percent(semi["rel_final"], 2), percent(semi["rel_max"], 2)) == (0.0098, 0.032)
    assert (percent(rk4["rel_final"], 2), percent(rk4["rel_max"], 2)) == (-4.5e-9, 5.1e-9)
    assert percent(drift_of("freefall", "euler")["rel_final"], 2) == 9.3
    assert percent(drift_of("freefall", "semi_implicit")["rel_final"], 2) == -9.3


@pytest.mark.parametrize("system", [name for name, build in engine.SYSTEMS.items() if build.facts["returns"]])
def test_drift_ordering_holds_for_every_seed(system):
    for seed in range(5):
        euler, semi, rk4 = (drift_of(system, name, seed=seed) for name in engine.CHAPTER_INTEGRATORS)
        for name, d in zip(engine.CHAPTER_INTEGRATORS, (euler, semi, rk4), strict=True):
            assert not d["diverged"], f"{system}, seed {seed}: {name} diverged at step {d['energy_overflow_step']:,}"
        assert abs(euler["rel_final"]) > semi["rel_max"] > rk4["rel_max"] > 0


def test_the_steps_and_the_energy_are_what_the_chapter_writes():
    """Semi-implicit Euler moves the position with the new velocity (from v0 = 0 explicit Euler does not move it);
    simulate() is the plain loop of steps, and its energy of a history is the energy of each state alone."""
    spring = engine.build_system("spring", np.random.default_rng(0))
    q, v = spring["q0"], spring["v0"]
    q1, v1 = engine.semi_implicit_step(q, v, spring["m"], spring["force"], 0.1)
    assert np.array_equal(v1, v + 0.1 * (-4.0 * q)) and np.array_equal(q1, q + 0.1 * v1)
    assert np.array_equal(engine.euler_step(q, v, spring["m"], spring["force"], 0.1)[0], q)
    for system in engine.SYSTEMS:
        sys_ = engine.build_system(system, np.random.default_rng(3))
        traj, _, energies = engine.simulate(engine.rk4_step, sys_, 0.05, 50)
        q, v = sys_["q0"].astype(float), sys_["v0"].astype(float)
        for _ in range(50):
            q, v = engine.rk4_step(q, v, sys_["m"], sys_["force"], 0.05)
        assert np.array_equal(q, traj[-1]) and sys_["energy"](q, v) == energies[-1]


def test_import_is_free(tmp_path):
    code = "import sys, engine; print(sorted(m for m in sys.modules if m.split('.')[0] == 'rerun'))"
    result = subprocess.run([sys.executable, "-c", code, "--steps", "oops"], cwd=tmp_path, capture_output=True,
                            text=True, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert (result.returncode, result.stdout, result.stderr) == (0, "[]\n", "")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("system", list(engine.SYSTEMS))
def test_smoke_metrics_match_the_golden_file_byte_for_byte(system, tmp_path, capsys):
    golden = GOLDEN / f"smoke_{system}.json"
    assert engine.main(["--smoke", "--no-rerun", "--system", system, "--out", str(tmp_path)]) == 0
    assert golden.exists() and (tmp_path / "metrics.json").read_bytes() == golden.read_bytes(), (
        f"{system}'s smoke run does not write {golden.relative_to(REPO)}: if a system or an integrator is new or"
        " changed on purpose, write the golden files with `python tools/figures.py golden` and read"
        " `git diff tests/golden` line by line (a new file's figures by hand)")


def test_metrics_schema_and_rounding(tmp_path, capsys):
    engine.main(["--no-rerun", "--out", str(tmp_path)])
    text = (tmp_path / "metrics.json").read_text()
    metrics = json.loads(text)
    assert text.endswith("}\n") and text == json.dumps(metrics, indent=2, sort_keys=True) + "\n"
    assert {k: metrics[k] for k in ("system", "dt", "steps", "seed")} == {"system": "orbit", "dt": 0.01,
                                                                          "steps": 2000, "seed": 0}
    assert set(metrics["drift"]) == set(engine.integrators_for(engine.build_system("orbit", np.random.default_rng(0))))
    for d in metrics["drift"].values():
        assert set(d) == {"e0", "e_final", "rel_final", "rel_max", "final_pos", "diverged", "energy_overflow_step"}
        assert all(d[key] == round(d[key], 12) for key in ("e0", "e_final", "rel_final", "rel_max"))
        assert len(d["final_pos"]) == 3 and all(x == round(x, 6) for x in d["final_pos"])
    # 12 decimals keep RK4's ~1e-11 drift: rounding to fewer would print 0.0
    assert metrics["drift"]["rk4"]["rel_max"] != 0.0
    assert "wall-clock" not in text and "wall-clock" in capsys.readouterr().out.splitlines()[-1]


BLAS_AND_POW = (" @ ", "np.dot", "linalg", "**", "np.sum", ".sum(")  # a CPU-dependent BLAS kernel or pow
NUMPYS_TRANSCENDENTALS = ("np.exp", "np.sin", "np.cos")  # a CPU-specific SIMD kernel: the damped truth uses math's


@pytest.mark.parametrize("fn, traps", [
    *((fn, BLAS_AND_POW) for fn in (engine.dot3, *engine.SYSTEMS.values(), engine.simulate,
                                    engine.relative_energy_error, engine.energy_drift, *engine.INTEGRATORS.values())),
    *((fn, BLAS_AND_POW + NUMPYS_TRANSCENDENTALS) for fn in (engine_damping.implicit_step, engine_damping.simpson,
                                                             engine_referee.damped_oscillator,
                                                             engine_damping.against_exact)),
    *((built[law], BLAS_AND_POW + NUMPYS_TRANSCENDENTALS)  # what metrics.json is made of: math's sin, never numpy's
      for built in map(lambda name: engine.build_system(name, np.random.default_rng(0)), engine.SYSTEMS)
      for law in ("force", "energy"))],
    ids=lambda fn: getattr(fn, "__qualname__", ""))
def test_physics_avoids_blas_libm_pow_and_cpu_specific_kernels(fn, traps):
    code = "\n".join(line.split("#")[0] for line in inspect.getsource(fn).splitlines())
    code = re.sub(r'""".*?"""', "", code, flags=re.S)
    for trap in traps:
        assert trap not in code, f"{fn.__name__} uses {trap.strip()}"


SEEDS = [0, 1, 2, 7, 123, 40_000]
EVERY_RUN = f"""import hashlib, numpy as np, engine
from conftest import ensemble_of
digest = hashlib.sha256()
for name in engine.SYSTEMS:  # each seed alone and all as a batch, under every integrator offered
    alone = [engine.build_system(name, np.random.default_rng(seed)) for seed in {SEEDS}]
    for system in (*alone, ensemble_of(name, {SEEDS})):
        for step in engine.integrators_for(system).values():
            for array in engine.simulate(step, system, 0.01, 400):
                digest.update(array.tobytes())
print(digest.hexdigest())"""


def test_every_run_and_the_damped_metrics_do_not_depend_on_the_simd_level(tmp_path):
    """With numpy's AVX-512 and AVX2 loops off, every bit of every position, velocity and energy of every system
    alone and as a batch stays the same (so a member is its single run at every SIMD level: the batch test below
    holds at the default one), and so do the damped spring's metrics.json, whose closed form uses math's
    exp/cos/sin: numpy's own pick a CPU-specific kernel whose last bits differ."""
    def hashed(extra_env):
        result = subprocess.run([sys.executable, "-c", EVERY_RUN], capture_output=True, text=True, timeout=300,
                                env={**os.environ, "PYTHONPATH": f"{REPO}:{REPO / 'tests'}", **extra_env})
        assert result.returncode == 0, result.stderr[-2000:]
        return result.stdout

    assert hashed({}) == hashed(SIMD_OFF)
    for out, env in ((tmp_path / "a", None), (tmp_path / "b", {**os.environ, **SIMD_OFF})):
        assert run_engine("--system", "damped_spring", "--smoke", "--no-rerun", "--out", out, env=env).returncode == 0
    assert (tmp_path / "a" / "metrics.json").read_bytes() == (tmp_path / "b" / "metrics.json").read_bytes()


@pytest.mark.parametrize("system", list(engine.SYSTEMS))
@pytest.mark.parametrize("dt", ["0.5", "2", "1e30", "1e300"])
def test_absurd_timesteps_run_quietly_and_write_strict_json_naming_the_step(system, dt, tmp_path, capsys):
    """Huge dt: escapes, overflows, NaN, recording included. No warning escapes, the JSON stays strict, and a run
    that diverged has no drift, only the step its energy overflowed at, which the table names."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any RuntimeWarning (overflow, invalid, float32 cast) fails the test
        assert engine.main(["--system", system, "--dt", dt, "--steps", "300", "--out", str(tmp_path)]) == 0
    metrics = json.loads((tmp_path / "metrics.json").read_text(), parse_constant=lambda t: pytest.fail(t))
    out = capsys.readouterr()
    for name, d in metrics["drift"].items():
        assert (d["rel_max"] is None) == (d["rel_final"] is None) == d["diverged"], name
        if d["diverged"]:
            assert isinstance(d["energy_overflow_step"], int) and 0 < d["energy_overflow_step"] <= 300
            assert re.search(rf"{name} .*diverged: energy overflowed at step {d['energy_overflow_step']:,}\n", out.out)
    judged = engine.SYSTEMS[system].facts["returns"] and any(d["diverged"] for d in metrics["drift"].values())
    assert out.err == "" and ("cannot judge" in out.out or not judged)


PER_BODY = (r"^spring: energy\(q, v\) must return one number per body, shape \([23],\) for [23] bodies, got"
            r" (a ValueError|\(3, 3\)|\(\)) \(sum the three components with dot3")


@pytest.mark.parametrize("broken, sentence", [
    ({"energy": lambda q, v: 0.5 * (v @ v) + 2.0 * (q @ q)}, PER_BODY),
    ({"energy": lambda q, v: 0.5 * (v * v).sum()}, PER_BODY),
    ({"force": lambda q, v: -4.0}, r"force\(q, v\) must return one force per body, shape \((\d, )?3,?\)"),
    ({"q0": np.zeros(2)}, r"q0 and v0 must both be \(3,\)")])
@pytest.mark.parametrize("bodies", [None, 1, 2, 3, 4])
def test_a_system_that_breaks_the_contract_gets_a_sentence_whatever_the_batch(broken, sentence, bodies):
    """The chapter's `v @ v` energy sums over the whole batch, or fails on it with numpy's own error: either way,
    one sentence, for one body (simulate() hands the energy every state at once) and for a batch of any size."""
    system = engine.build_system("spring", np.random.default_rng(0))
    if bodies:
        system = {**system, "q0": np.stack([system["q0"]] * bodies), "v0": np.stack([system["v0"]] * bodies)}
    with pytest.raises(ValueError, match=sentence):
        engine.simulate(engine.euler_step, {**system, **broken}, 0.01, 2)


@pytest.mark.parametrize("system", engine.SYSTEMS)
def test_a_batch_steps_each_body_as_if_alone(system):
    """The same code steps one body (3,) or a batch (N, 3): each row is its own single run, bit for bit, under
    every integrator the batch is offered (the implicit step too), and its exact motion is the member's own."""
    seeds, times = SEEDS, np.linspace(0.0, 300.0, 13)
    ensemble = ensemble_of(system, seeds)
    for integrator, step in engine.integrators_for(ensemble).items():
        positions, velocities, energies = engine.simulate(step, ensemble, 0.01, 400)
        assert positions.shape == (401, len(seeds), 3) and energies.shape == (401, len(seeds))
        for i, seed in enumerate(seeds):
            alone = run(system, integrator, 0.01, 400, seed)
            assert np.array_equal(positions[:, i], alone[0]) and np.array_equal(velocities[:, i], alone[1])
            assert np.array_equal(energies[:, i], alone[2])
    if ensemble.get("exact") is not None:  # (at seed 40,000 the batched Kepler solve differs by an ulp: not yet)
        batched = ensemble["exact"](ensemble["q0"], ensemble["v0"], times)
        for i, seed in enumerate(seeds[:3]):
            member = engine.build_system(system, np.random.default_rng(seed))
            assert np.array_equal(batched[:, i], member["exact"](member["q0"], member["v0"], times))


def test_simulate_long_keeps_every_kth_state_and_the_last_and_every_energy_in_pieces(monkeypatch):
    """Pieces of 7 steps keep every 5th state and every energy: the same bits as one simulate() call."""
    assert engine.kept_steps(10, 4).tolist() == [0, 4, 8, 10] and engine.kept_steps(8, 4).tolist() == [0, 4, 8]
    monkeypatch.setattr(engine, "PIECE_VALUES", 21)  # 7 steps of one body
    system = engine.build_system("orbit", np.random.default_rng(0))
    whole = engine.simulate(engine.rk4_step, system, 0.01, 100)
    pieces = engine.simulate_long(engine.rk4_step, system, 0.01, 100, every=5)
    kept = engine.kept_steps(100, 5)
    for got, want in zip(pieces, (whole[0][kept], whole[1][kept], whole[2]), strict=True):
        assert np.array_equal(got, want)


def test_the_table_keeps_its_columns_for_large_values(capsys):
    engine.print_report("spring", 0.05, 2000, {"euler": engine.energy_drift(np.array([2.111192736, 2.1443e8]))})
    row = capsys.readouterr().out.splitlines()[-1].split()
    assert row == ["euler", "2.1112", "2.1443e+08", "+1.0157e+08", "1.0157e+08"]
