"""What an --ensemble run may hold, measured: the budget engine_ensembles.ensemble_bytes states covers the
whole process's peak at the largest ensemble it lets through, and what it refuses is refused at once."""

import subprocess
import sys

import numpy as np
import pytest

import engine
import engine_ensembles as ensembles
from conftest import REPO, ensemble_of, run_engine


def peak_resident_bytes(*flags) -> int:
    """The largest resident set of `python engine.py FLAGS`, as the kernel counted it (ru_maxrss, in KiB)."""
    code = ("import resource, subprocess, sys; run = subprocess.run([sys.executable, *sys.argv[1:]], "
            "stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True); "
            "print(run.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, repr(run.stderr))")
    result = subprocess.run([sys.executable, "-c", code, "engine.py", *map(str, flags)], cwd=REPO,
                            capture_output=True, text=True, timeout=900)
    returncode, kib, stderr = result.stdout.split(" ", 2)
    assert returncode == "0", stderr
    return int(kib) * 1024


@pytest.mark.slow
@pytest.mark.parametrize("steps", [1, 2000])
def test_the_largest_ensemble_the_guard_lets_through_peaks_within_the_budget(steps, tmp_path):
    """Before: --ensemble 1000000 --steps 1 passed an estimate of 0.21 GB and peaked at 1,553 MB."""
    members = ensembles.ensemble_most_members(steps)
    assert ensembles.ensemble_bytes(steps, members) <= ensembles.ENSEMBLE_MEMORY
    peak = peak_resident_bytes("--steps", steps, "--ensemble", members, "--out", tmp_path)
    assert peak <= ensembles.ENSEMBLE_MEMORY, f"{members:,} members x {steps} steps peaked at {peak / 1e6:,.0f} MB"


def test_one_member_past_the_budget_is_refused_before_anything_is_built(tmp_path, capsys):
    """(--ensemble 40000000 is refused by the flag's own bound: test_cli.py's bad input.)"""
    with pytest.raises(SystemExit) as stop:
        engine.main(["--ensemble", str(ensembles.ensemble_most_members(2000) + 1), "--out", str(tmp_path / "out")])
    assert stop.value.code == 2 and "GB" in capsys.readouterr().err and not (tmp_path / "out").exists()


@pytest.mark.parametrize("system", list(engine.SYSTEMS))
def test_each_member_starts_exactly_where_the_single_run_with_its_seed_does(system):
    """build_ensemble draws only each seed's jitter: the rows must be build_system's, bit for bit."""
    seeds = range(7, 7 + 500)
    batch = ensemble_of(system, seeds)
    for row, seed in enumerate(seeds):
        single = engine.build_system(system, np.random.default_rng(seed))
        assert batch["q0"][row].tobytes() == single["q0"].tobytes()
        assert batch["v0"][row].tobytes() == single["v0"].tobytes()


def test_a_large_ensemble_shows_progress_while_its_members_are_drawn(tmp_path):
    result = run_engine("--ensemble", "100000", "--steps", "1", "--no-rerun", "--out", tmp_path, timeout=300)
    assert result.returncode == 0
    assert "  seeds          100% of 100,000 members" in result.stderr.splitlines()

