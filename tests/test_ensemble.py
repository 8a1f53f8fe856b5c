"""Ensembles: every member is bit for bit its own single run, and --ensemble reports and writes what it says."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import engine
import engine_ensembles as ensembles
from conftest import REPO, ensemble_of, run_engine

SEEDS = [0, 1, 2, 7, 123, 40_000]
SIMD_OFF = {"NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR X86_V3"}  # as test_engine's determinism test

# Run in a child process so numpy starts with the SIMD level under test; prints one hash of the batches.
MEMBERS_VS_SINGLES = """
import functools, hashlib, numpy as np, engine, engine_ensembles as ensembles
seeds, digest = {seeds}, hashlib.sha256()
for system_name in engine.SYSTEMS:
    ensemble = ensembles.build_ensemble(functools.partial(engine.build_system, system_name), seeds)
    for name, step in engine.integrators_for(ensemble).items():
        batch = engine.simulate(step, ensemble, 0.01, 400)
        for i, seed in enumerate(seeds):
            alone = engine.build_system(system_name, np.random.default_rng(seed))
            single = engine.simulate(engine.integrators_for(alone)[name], alone, 0.01, 400)
            for mine, theirs in zip(batch, single):
                member = mine[:, i]
                assert member.tobytes() == theirs.tobytes(), (system_name, name, seed)
        for array in batch:
            digest.update(array.tobytes())
print(digest.hexdigest())
"""


def members_vs_singles(extra_env):
    code = MEMBERS_VS_SINGLES.format(seeds=SEEDS)
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO,
                            env={**os.environ, "PYTHONPATH": str(REPO), **extra_env}, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout


@pytest.mark.slow
def test_every_member_is_its_single_run_bit_for_bit_at_every_simd_level():
    """All three systems x three integrators: positions, velocities and energies of each member equal the
    member's own single run byte for byte, with numpy's AVX2/AVX-512 loops on and off (the batch takes
    the vector loops, the single run mostly the scalar ones), and the batches themselves do not change."""
    assert members_vs_singles({}) == members_vs_singles(SIMD_OFF)


def test_ensemble_starts_are_the_single_runs_starts():
    for system_name in engine.SYSTEMS:
        ensemble = ensemble_of(system_name, SEEDS)
        for i, seed in enumerate(SEEDS):
            single = engine.build_system(system_name, np.random.default_rng(seed))
            assert np.array_equal(ensemble["q0"][i], single["q0"]) and np.array_equal(ensemble["v0"][i], single["v0"])


@pytest.mark.parametrize("dt", [0.01, 1.5])  # 1.5 s: every spring member diverges
def test_ensemble_drift_is_energy_drift_member_by_member(dt):
    ensemble = ensemble_of("spring", SEEDS)
    _, _, energies = engine.simulate(engine.euler_step, ensemble, dt, 500)
    drift = ensembles.ensemble_drift(energies)
    for i in range(len(SEEDS)):
        single = engine.energy_drift(energies[:, i])
        assert bool(drift["diverged"][i]) == single["diverged"]
        if not single["diverged"]:
            assert drift["rel_final"][i] == single["rel_final"] and drift["rel_max"][i] == single["rel_max"]
        else:
            assert np.isnan(drift["rel_final"][i]) and np.isnan(drift["rel_max"][i])


def test_orbit_members_really_differ_and_the_spring_only_scales():
    orbit, spring = (ensembles.ensemble_drift(engine.simulate(engine.semi_implicit_step,
                                                               ensemble_of(name, SEEDS), 0.01, 2000)[2])
                     for name in ("orbit", "spring"))
    assert np.ptp(orbit["rel_max"]) > 0.1 * np.median(orbit["rel_max"])  # the seed changes the physics
    # linear: the seed scales the amplitude only (measured spread 1.9e-12 of the median over 1,000 seeds)
    assert np.ptp(spring["rel_max"]) < 1e-10 * np.median(spring["rel_max"])


def test_ordering_count_names_the_seeds_where_it_fails():
    """Synthetic drifts with a planted failure: the count drops and the seed is named."""
    ok = {"rel_final": np.array([0.2, 0.2, 0.2]), "rel_max": np.array([0.2, 0.2, 0.2])}
    semi = {"rel_final": np.zeros(3), "rel_max": np.array([1e-4, 0.5, 1e-4]), "diverged": np.zeros(3, bool)}
    rk4 = {"rel_final": np.zeros(3), "rel_max": np.array([1e-11, 1e-11, np.nan]), "diverged": np.zeros(3, bool)}
    drifts = {"euler": {**ok, "diverged": np.zeros(3, bool)}, "semi_implicit": semi, "rk4": rk4}
    block = ensembles.ensemble_block(range(10, 13), drifts, engine.judge_ordering)
    assert block["ordering_holds"] == 1 and block["ordering_fails_for_seeds"] == [11, 12]
    assert block["ordering_not_judged"] == 0


def test_cli_ensemble_report_and_metrics_block(tmp_path):
    first, second = tmp_path / "a", tmp_path / "b"
    result = run_engine("--ensemble", "50", "--seed", "3", "--no-rerun", "--out", first)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    assert "ensemble of seeds 3..52: 50 members" in result.stdout
    assert "holds for 50 of 50 seeds" in result.stdout
    assert run_engine("--ensemble", "50", "--seed", "3", "--no-rerun", "--out", second).returncode == 0
    text = (first / "metrics.json").read_bytes()
    assert text == (second / "metrics.json").read_bytes()  # deterministic bytes
    metrics = json.loads(text, parse_constant=lambda token: pytest.fail(f"non-strict JSON token {token}"))
    block = metrics["ensemble"]
    assert block["seeds"] == [3, 52] and block["members"] == 50 and block["ordering_holds"] == 50
    assert block["ordering_fails_for_seeds"] == [] and block["ordering_not_judged"] == 0
    for d in block["drift"].values():
        assert d["rel_final"]["min"] <= d["rel_final"]["median"] <= d["rel_final"]["max"] and d["diverged"] == 0

    # the drift block is member 0's, which is exactly the single run of --seed 3
    single = tmp_path / "single"
    assert run_engine("--seed", "3", "--no-rerun", "--out", single).returncode == 0
    alone = json.loads((single / "metrics.json").read_text())
    assert "ensemble" not in alone and alone["drift"] == metrics["drift"]


def test_spring_report_states_linearity_not_as_a_finding(tmp_path, capsys):
    assert engine.main(["--system", "spring", "--ensemble", "20", "--no-rerun", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "the spring is linear" in out and "not a finding" in out


def test_ensemble_counts_diverged_members(tmp_path, capsys):
    assert engine.main(["--system", "spring", "--dt", "1.5", "--ensemble", "5", "--no-rerun",
                        "--out", str(tmp_path)]) == 0
    block = json.loads((tmp_path / "metrics.json").read_text())["ensemble"]
    assert all(d["diverged"] == 5 and d["rel_max"] is None for d in block["drift"].values())
    assert block["ordering_holds"] == 0 and block["ordering_not_judged"] == 5
    assert block["ordering_fails_for_seeds"] == []  # diverged is "cannot judge", not a failure
    out = capsys.readouterr().out
    assert "cannot judge any of the 5 seeds" in out and "5 diverged under some integrator and cannot be judged" in out


def test_ensemble_does_not_judge_members_whose_drifts_are_round_off(tmp_path, capsys):
    assert engine.main(["--dt", "1e-9", "--steps", "10", "--ensemble", "5", "--no-rerun", "--out", str(tmp_path)]) == 0
    block = json.loads((tmp_path / "metrics.json").read_text())["ensemble"]
    assert block["ordering_holds"] == 0 and block["ordering_fails_for_seeds"] == []
    assert block["ordering_not_judged"] == block["ordering_roundoff_only"] == 5
    out = capsys.readouterr().out
    assert "cannot judge any of the 5 seeds" in out and "holds for" not in out
    assert "5 drifted by round-off only and cannot be judged" in out and "diverged under" not in out


def test_ensemble_does_not_judge_members_that_left_the_band_as_the_single_run_does(tmp_path, capsys):
    assert engine.main(["--dt", "1.0", "--ensemble", "3", "--no-rerun", "--out", str(tmp_path)]) == 0
    block = json.loads((tmp_path / "metrics.json").read_text())["ensemble"]
    assert block["ordering_not_judged"] == block["ordering_left_band"] == 3 and block["ordering_fails_for_seeds"] == []
    out = capsys.readouterr().out
    assert "cannot judge, semi_implicit left its band" in out and "cannot judge any of the 3 seeds" in out
    assert "3 left semi_implicit's band" in out


@pytest.mark.parametrize("members, why", [("0", "--ensemble must be from 1 to"), ("-3", "must be from 1 to"),
                                          ("many", "is not a whole number"), ("100000", "GB"),
                                          ("40000000", "must be from 1 to"), ("1e4300", "got 1e4300")])
def test_bad_ensemble_gets_one_line_and_touches_nothing(members, why, tmp_path):
    out = tmp_path / "out"
    result = run_engine("--ensemble", members, "--out", out)
    assert result.returncode == 2 and result.stdout == ""
    assert len(result.stderr.splitlines()) == 1 and why in result.stderr, result.stderr
    assert not out.exists()


def test_memory_estimate_refuses_what_would_not_fit():
    assert ensembles.ensemble_bytes(2000, 10_000) < ensembles.ENSEMBLE_MEMORY  # the 10,000 orbits fit
    assert ensembles.ensemble_bytes(2000, 100_000) > ensembles.ENSEMBLE_MEMORY
    assert ensembles.ensemble_bytes(SMOKE := engine.SMOKE_STEPS, 100_000) < ensembles.ensemble_bytes(2000, 100_000)
    assert SMOKE == 600


def test_recording_holds_member_paths_and_error_spread(tmp_path):
    rerun_chunk = pytest.importorskip("rerun.chunk")
    assert run_engine("--ensemble", "30", "--out", tmp_path).returncode == 0
    reader = rerun_chunk.RrdReader(tmp_path / "engine.rrd")
    (recording,) = reader.recordings()
    rows = {}
    for chunk in reader.stream(store=recording).to_chunks():
        rows.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())
    for name in engine.integrators_for(engine.build_system("orbit", np.random.default_rng(0))):
        (paths,) = [b for b in rows[f"/ensemble_paths/{name}"] if "LineStrips3D:strips" in b.schema.names]
        assert len(paths.column("LineStrips3D:strips").to_pylist()[0]) == 20  # SHOWN_MEMBERS strips
        for which in ("min", "median", "max"):
            steps = [s for b in rows[f"/ensemble_error/{name}/{which}"] if "step" in b.schema.names
                     for s in b.column("step").to_pylist()]
            assert 1900 < len(steps) <= 2001
