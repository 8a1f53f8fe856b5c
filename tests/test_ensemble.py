"""Ensembles: --ensemble reports and writes what it says (a member is its single run: tests/test_engine.py)."""

import functools
import json
import re

import numpy as np
import pytest

import engine
import engine_ensembles as ensembles
from conftest import ensemble_of

SEEDS = [0, 1, 2, 7, 123, 40_000]


def test_ensemble_drift_is_energy_drift_member_by_member_and_the_members_differ():
    """At dt 0.01 and 1.5 s (every spring member diverges); the orbit's seed changes the physics, the spring's only
    scales it (linear: measured spread 1.9e-12 of the median over 1,000 seeds)."""
    for dt in (0.01, 1.5):
        _, _, energies = engine.simulate(engine.euler_step, ensemble_of("spring", SEEDS), dt, 500)
        drift = ensembles.ensemble_drift(energies)
        for i in range(len(SEEDS)):
            single = engine.energy_drift(energies[:, i])
            assert bool(drift["diverged"][i]) == single["diverged"]
            if not single["diverged"]:
                assert drift["rel_final"][i] == single["rel_final"] and drift["rel_max"][i] == single["rel_max"]
            else:
                assert np.isnan(drift["rel_final"][i]) and np.isnan(drift["rel_max"][i])
    orbit, spring = (ensembles.ensemble_drift(engine.simulate(engine.semi_implicit_step,
                                                               ensemble_of(name, SEEDS), 0.01, 2000)[2])
                     for name in ("orbit", "spring"))
    assert np.ptp(orbit["rel_max"]) > 0.1 * np.median(orbit["rel_max"])
    assert np.ptp(spring["rel_max"]) < 1e-10 * np.median(spring["rel_max"])


@pytest.mark.parametrize("system", list(engine.SYSTEMS))
def test_a_seed_moves_one_number_of_the_start_as_the_ensemble_report_says(system):
    """Over 1,000 seeds one number of the start moves, nothing else; the report's words for it (SEED_CHANGES: "the
    orbit's starting speed, 1 +- 0.05", jittered()'s for a system without words) name it and its range."""
    assert set(ensembles.SEED_CHANGES) <= set(engine.SYSTEMS)
    starts = [engine.build_system(system, np.random.default_rng(seed)) for seed in range(1000)]
    state = np.array([np.concatenate([s["q0"], s["v0"]]) for s in starts])  # (seeds, q0 then v0)
    (varies,) = np.flatnonzero(np.ptp(state, axis=0) > 0)  # one number per system: the seed moves nothing else
    named = ensembles.jittered(functools.partial(engine.build_system, system))
    assert named == f"the start's {('q0', 'v0')[varies // 3]}'s {'xyz'[varies % 3]}"
    if system in ensembles.SEED_CHANGES:
        said = ensembles.SEED_CHANGES[system]
        centre, spread = map(float, re.search(r"([\d.]+) \+- ([\d.]+)", said).groups())
        assert ("speed" in said) == (varies >= 3) and ("stretch" in said) == (varies < 3)
        drawn = state[:, varies]
        assert np.all(np.abs(drawn - centre) <= spread) and np.ptp(drawn) > 1.9 * spread, system


def test_ordering_count_names_the_seeds_where_it_fails():
    """Synthetic drifts with a planted failure: the count drops and the seed is named."""
    ok = {"rel_final": np.array([0.2, 0.2, 0.2]), "rel_max": np.array([0.2, 0.2, 0.2])}
    semi = {"rel_final": np.zeros(3), "rel_max": np.array([1e-4, 0.5, 1e-4]), "diverged": np.zeros(3, bool)}
    rk4 = {"rel_final": np.zeros(3), "rel_max": np.array([1e-11, 1e-11, np.nan]), "diverged": np.zeros(3, bool)}
    drifts = {"euler": {**ok, "diverged": np.zeros(3, bool)}, "semi_implicit": semi, "rk4": rk4}
    block = ensembles.ensemble_block(range(10, 13), drifts, engine.judge_ordering)
    assert block["ordering_holds"] == 1 and block["ordering_fails_for_seeds"] == [11, 12]
    assert block["ordering_not_judged"] == 0


def ensemble_run(tmp_path, capsys, *args):  # (metrics.json's bytes, stdout) of `python engine.py --no-rerun ARGS`
    assert engine.main([*args, "--no-rerun", "--out", str(tmp_path)]) == 0
    return (tmp_path / "metrics.json").read_bytes(), capsys.readouterr().out


def test_ensemble_report_and_metrics_block(tmp_path, capsys):
    text, out = ensemble_run(tmp_path / "a", capsys, "--ensemble", "50", "--seed", "3")
    assert "ensemble of seeds 3..52: 50 members" in out and "holds for 50 of 50 seeds" in out
    assert text == ensemble_run(tmp_path / "b", capsys, "--ensemble", "50", "--seed", "3")[0]  # deterministic bytes
    metrics = json.loads(text, parse_constant=lambda token: pytest.fail(f"non-strict JSON token {token}"))
    block = metrics["ensemble"]
    assert block["seeds"] == [3, 52] and block["members"] == 50 and block["ordering_holds"] == 50
    assert block["ordering_fails_for_seeds"] == [] and block["ordering_not_judged"] == 0
    for d in block["drift"].values():
        assert d["rel_final"]["min"] <= d["rel_final"]["median"] <= d["rel_final"]["max"] and d["diverged"] == 0
    # the drift block is member 0's, which is exactly the single run of --seed 3
    alone = json.loads(ensemble_run(tmp_path / "single", capsys, "--seed", "3")[0])
    assert "ensemble" not in alone and alone["drift"] == metrics["drift"]


@pytest.mark.parametrize("args, block, said, unsaid", [
    (["--system", "spring", "--ensemble", "20"], {}, ["the spring is linear", "not a finding"], []),
    (["--system", "spring", "--dt", "1.5", "--ensemble", "5"],  # diverged is "cannot judge", not a failure
     {"ordering_holds": 0, "ordering_not_judged": 5},
     ["cannot judge any of the 5 seeds", "5 diverged under some integrator and cannot be judged"], []),
    (["--dt", "1e-9", "--steps", "10", "--ensemble", "5"],
     {"ordering_holds": 0, "ordering_not_judged": 5, "ordering_roundoff_only": 5},
     ["cannot judge any of the 5 seeds", "5 drifted by round-off only and cannot be judged"],
     ["holds for", "diverged under"]),
    (["--dt", "1.0", "--ensemble", "3"], {"ordering_not_judged": 3, "ordering_left_band": 3},
     ["cannot judge, semi_implicit left its band", "cannot judge any of the 3 seeds", "3 left semi_implicit's band"],
     []),
])
def test_the_ensemble_says_which_members_it_cannot_judge_and_why(args, block, said, unsaid, tmp_path, capsys):
    text, out = ensemble_run(tmp_path, capsys, *args)
    ensemble = json.loads(text)["ensemble"]
    assert {key: ensemble[key] for key in block} == block and ensemble["ordering_fails_for_seeds"] == []
    if "1.5" in args:
        assert all(d["diverged"] == 5 and d["rel_max"] is None for d in ensemble["drift"].values())
    assert all(phrase in out for phrase in said) and not any(phrase in out for phrase in unsaid), out


def test_the_ensemble_lines_read_true_for_one_member_and_just_over_the_limit(capsys, tmp_path):
    needed = ensembles.ensemble_bytes(2000, ensembles.ensemble_most_members(2000) + 1)  # the first over, at 2,000 steps
    shown = ensembles.memory_over_limit(needed)  # was "1.0 GB, over the 1 GB": a need that read as the limit itself
    assert shown.endswith(" GB, over the 1 GB") and float(shown.split()[0]) > 1.0
    assert ensembles.memory_over_limit(2.04e9) == "2.0 GB, over the 1 GB"
    assert engine.main(["--ensemble", "1", "--no-rerun", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "1 member stepped together" in out and "holds for 1 of 1 seed\n" in out
