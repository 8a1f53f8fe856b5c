"""Helpers shared by the tests: run engine.py the way a student does."""

import functools
import hashlib
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import engine
import engine_ensembles

# A runner may start the suite with Ctrl-C or SIGTERM ignored (as a non-interactive shell starts a background job);
# the programs keep an ignored signal ignored, on purpose, and the signal tests need them delivered, here and in
# the children (a handled signal is default again after exec).
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
if signal.getsignal(signal.SIGTERM) is signal.SIG_IGN:
    signal.signal(signal.SIGTERM, signal.SIG_DFL)

REPO = Path(__file__).resolve().parents[1]
ENGINE = REPO / "engine.py"

# The suite's runs are not a student's: nothing goes into the checkout's journal, here or in any process started,
# and a test of the journal points COURSE_JOURNAL at a scratch file of its own.
os.environ["COURSE_JOURNAL"] = "off"
CHECKOUT_JOURNAL = REPO / "exercises" / "journal.jsonl"


@pytest.fixture(autouse=True, scope="session")
def _the_checkouts_journal_is_left_alone():  # under pytest-xdist each worker checks the tests it ran
    def state():
        return hashlib.sha256(CHECKOUT_JOURNAL.read_bytes()).hexdigest() if CHECKOUT_JOURNAL.exists() else None

    before = state()
    yield
    assert state() == before, ("a test wrote into exercises/journal.jsonl: give the programs it starts the"
                               " environment's COURSE_JOURNAL")


def pytest_collection_modifyitems(items):
    """The slow tests first: under `pytest -n 2` the longest start early and the short ones even out the two cores
    (in collection order a 30 s test could start last and run alone)."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


def run_engine(*args, cwd=None, env=None, timeout=120):
    """`python engine.py ARGS` in a fresh interpreter; returns the CompletedProcess."""
    return subprocess.run([sys.executable, str(ENGINE), *map(str, args)], cwd=cwd or REPO, env=env,
                          capture_output=True, text=True, timeout=timeout)


def run_exercise(module, *args, cwd=REPO, timeout=300):
    """`python -m exercises.<module> ARGS` (the course's journal off, as everywhere here); a CompletedProcess."""
    return subprocess.run([sys.executable, "-m", f"exercises.{module}", *map(str, args)], cwd=cwd, timeout=timeout,
                          env={**os.environ, "PYTHONPATH": str(REPO)}, capture_output=True, text=True)


def run(system_name: str, integrator: str, dt: float = 0.01, steps: int = 2000, seed: int = 0, every: int = 1):
    """One run as main() makes it (simulate_long, every k-th state kept): (positions, velocities, energies)."""
    system = engine.build_system(system_name, np.random.default_rng(seed))
    return engine.simulate_long(engine.integrators_for(system)[integrator], system, dt, steps, every)


def ensemble_of(system_name: str, seeds) -> dict:
    """engine_ensembles.build_ensemble for the system called `system_name`."""
    return engine_ensembles.build_ensemble(functools.partial(engine.build_system, system_name), seeds)
