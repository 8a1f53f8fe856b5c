"""What an --ensemble run may hold, measured: the budget engine_ensembles.ensemble_bytes states covers the
whole process's peak at the largest ensemble it lets through, and what it refuses is refused at once."""

import ast
import subprocess
import sys

import pytest

import engine
import engine_ensembles as ensembles
from conftest import REPO


def peak_resident_bytes(*flags) -> tuple:
    """(the largest resident set of `python engine.py FLAGS` as the kernel counted it (ru_maxrss, in KiB), its
    stderr)."""
    code = ("import resource, subprocess, sys; run = subprocess.run([sys.executable, *sys.argv[1:]], "
            "stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True); "
            "print(run.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, repr(run.stderr))")
    result = subprocess.run([sys.executable, "-c", code, "engine.py", *map(str, flags)], cwd=REPO,
                            capture_output=True, text=True, timeout=900)
    returncode, kib, stderr = result.stdout.split(" ", 2)
    assert returncode == "0", stderr
    return int(kib) * 1024, ast.literal_eval(stderr)


@pytest.mark.slow
@pytest.mark.parametrize("steps", [1, 2000])
def test_the_largest_ensemble_the_guard_lets_through_peaks_within_the_budget(steps, tmp_path):
    """Before: --ensemble 1000000 --steps 1 passed an estimate of 0.21 GB and peaked at 1,553 MB. The run at one
    step draws the most members, so it also shows the draws' progress (from 100,000 members)."""
    members = ensembles.ensemble_most_members(steps)
    peak, stderr = peak_resident_bytes("--steps", steps, "--ensemble", members, "--out", tmp_path)
    assert peak <= ensembles.ENSEMBLE_MEMORY, f"{members:,} members x {steps} steps peaked at {peak / 1e6:,.0f} MB"
    assert steps > 1 or f"  seeds          100% of {members:,} members" in stderr.splitlines()


def test_the_guard_lets_through_what_fits_and_refuses_one_member_more_before_anything_is_built(tmp_path, capsys):
    """The issue's 10,000 orbits fit, 100,000 do not, fewer steps hold less. (--ensemble 40000000 is refused by the
    flag's own bound: test_cli.py's bad input.)"""
    most = ensembles.ensemble_most_members(2000)
    assert ensembles.ensemble_bytes(2000, most) <= ensembles.ENSEMBLE_MEMORY < ensembles.ensemble_bytes(2000, most + 1)
    assert ensembles.ensemble_bytes(2000, 10_000) < ensembles.ENSEMBLE_MEMORY < ensembles.ensemble_bytes(2000, 100_000)
    assert ensembles.ensemble_bytes(engine.SMOKE_STEPS, 100_000) < ensembles.ensemble_bytes(2000, 100_000)
    with pytest.raises(SystemExit) as stop:
        engine.main(["--ensemble", str(most + 1), "--out", str(tmp_path / "out")])
    assert stop.value.code == 2 and "GB" in capsys.readouterr().err and not (tmp_path / "out").exists()
