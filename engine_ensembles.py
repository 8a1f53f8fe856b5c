"""Many seeds at once, for `python engine.py --ensemble N`: build the batch, summarise it, report it.

build_ensemble() stacks N starting states into (N, 3) arrays and engine.simulate() steps them
together: the same arithmetic on every row, so each member is bit for bit its own single run, at a
fraction of the cost per member. summarize() keeps what the report and the recording need of each
integrator's run: every member's drift, the first members' paths and the spread of their errors.

Pure functions: engine.main() calls them in its --ensemble branch, and this module imports nothing
of engine's (it is handed engine.build_system and engine.judge_ordering where it needs them).
"""

import math

import numpy as np

from curriculum.common.cli import int_in, progress_printer
from engine_referee import relative_energy_error

ENSEMBLE_MEMORY = 1_000_000_000  # bytes an --ensemble run may hold; larger requests are refused up front
ENSEMBLE_KEPT_VALUES = 8_000_000  # position values kept per integrator in an ensemble (energies: all of them)
ENSEMBLE_BASE = 200_000_000  # bytes a run holds before its members: Python, numpy, Rerun (~150 MB measured)
ENSEMBLE_MEMBER = 700  # bytes per member whatever the steps (~500 measured at --steps 1; see ensemble_bytes)
SHOWN_MEMBERS = 20  # member paths an ensemble's recording draws: enough to see the spread, few enough to open


def ensemble_every(steps: int, members: int) -> int:
    """Keep every k-th state so an ensemble's positions stay under ENSEMBLE_KEPT_VALUES numbers."""
    return max(1, math.ceil((steps + 1) * members * 3 / ENSEMBLE_KEPT_VALUES))


def ensemble_bytes(steps: int, members: int) -> int:
    """The most memory an --ensemble run holds at once, the whole process counted (measured peaks in
    docs/ensembles.md stay under it): Python, numpy, Rerun and the recording (ENSEMBLE_BASE); for every
    member its energy at every step (8 bytes) and whether it is finite (1 byte); what one member costs
    whatever the steps (ENSEMBLE_MEMBER: its start, RK4's temporaries, its drifts, the seeds the ordering
    fails for); and the kept positions and velocities with the recording's error spread over them."""
    return ENSEMBLE_BASE + members * (ENSEMBLE_MEMBER + 9 * (steps + 1)) + 3 * 8 * ENSEMBLE_KEPT_VALUES


def ensemble_most_members(steps: int) -> int:
    """The largest --ensemble that fits in ENSEMBLE_MEMORY at `steps` steps (0 if none does)."""
    return max(0, (ENSEMBLE_MEMORY - ensemble_bytes(steps, 0)) // (ENSEMBLE_MEMBER + 9 * (steps + 1)))


def ensemble_size(text: str) -> int:
    """--ensemble's type: a whole number of members, from 1 to as many as fit at one step."""
    return int_in(1, ensemble_most_members(1), "--ensemble")(text)


def build_ensemble(build, seeds) -> dict:
    """One system, N bodies stepped as a batch: q0 and v0 become (N, 3), one row per seed.

    build(rng) builds the system (engine.build_system with its name). Row i starts exactly where
    build(default_rng(seeds[i])) does: each seed gets its own generator, as a single run does, but only
    its one jitter is drawn per seed. The rest, the force and energy laws included, is built once: with
    the jitter 0 (the start) and 1 (what it moves). From 100,000 members the draws show progress.
    """
    zero, one = OneDraw(0.0), OneDraw(1.0)
    system, moved = build(zero), build(one)
    # one generator per seed takes ~15 us: past 100,000 members that is worth a progress line
    progress = progress_printer("seeds", len(seeds), unit="members") if len(seeds) >= 100_000 else None
    jitter = np.empty(len(seeds))
    for first in range(0, len(seeds), 100_000):
        chunk = seeds[first:first + 100_000]
        jitter[first:first + len(chunk)] = [np.random.default_rng(seed).uniform(*zero.bounds) for seed in chunk]
        if progress:
            progress(first + len(chunk))
    starts = {}
    for key in ("q0", "v0"):
        starts[key] = np.tile(system[key], (len(seeds), 1))
        jittered = np.flatnonzero(moved[key] != system[key])  # the component the jitter moves, if it is here
        starts[key][:, jittered] = starts[key][:, jittered] + jitter[:, None]  # start + draw, as build_system adds it
    return {**system, **starts}


class OneDraw:
    """Stands in for a generator in build_system, which draws each system's jitter with one
    rng.uniform(low, high): returns `value` and notes (low, high)."""

    def __init__(self, value: float):
        self.value, self.bounds = value, None

    def uniform(self, low: float, high: float) -> float:
        self.bounds = (low, high)
        return self.value


def ensemble_problem(steps: int, members: int) -> str | None:
    """Why an ensemble of `members` x `steps` cannot run (it would not fit in ENSEMBLE_MEMORY), or None."""
    most = ensemble_most_members(steps)
    if members <= most:
        return None
    fits = f"at most {most:,} fit at {steps:,} steps" if most else f"not even one fits at {steps:,} steps"
    if members > 10 * most + 1000:  # far past the limit (1e4300 members, say): no need to print the sum
        return f"{members:.3g} members is far more than {ENSEMBLE_MEMORY / 1e9:g} GB holds ({fits})"
    return (f"{members:,} members x {steps:,} steps needs about {memory_over_limit(ensemble_bytes(steps, members))}"
            f" this run may use ({fits}): fewer members or fewer --steps")


def ensemble_drift(energies: np.ndarray) -> dict:
    """engine.energy_drift() for every member of an ensemble at once; energies is (steps + 1, N).

    Returns arrays of N: rel_final, rel_max (NaN where the member diverged) and diverged; each
    member's figures are the bits energy_drift() gives for that member alone."""
    # The worst excursion is above the highest energy or below the lowest: no (steps, N) temporaries, and
    # the same bits as max |E - E0| / |E0| because subtracting E0 and dividing by |E0| keep the order.
    start, highest, lowest, final = relative_energy_error(
        np.stack([energies[0], np.max(energies, axis=0), np.min(energies, axis=0), energies[-1]]))
    worst = np.maximum(highest, -lowest)
    diverged = ~np.isfinite(worst)  # a non-finite energy, or finite ones whose error overflows
    return {"rel_final": np.where(diverged, np.nan, final), "rel_max": np.where(diverged, np.nan, worst),
            "diverged": diverged}


def error_spread(energies: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """(len(kept), 3): at each kept step k, each member's worst |E - E0| / |E0| over steps 0..k (every
    step counts, kept or not), and of those the best member's, the median and the worst member's.

    The worst-so-far only rises, so the recording's curves carry no noise from errors crossing zero."""
    # highest and lowest energy between one kept step and the next, carried on: (len(kept), N) each
    starts = np.concatenate([[0], kept[:-1] + 1])
    highest = np.maximum.accumulate(np.maximum.reduceat(energies, starts, axis=0), axis=0)
    worst = relative_energy_error(highest, e0=energies[0])
    del highest  # (len(kept), N) arrays: at most three at a time
    lowest = np.minimum.accumulate(np.minimum.reduceat(energies, starts, axis=0), axis=0)
    np.maximum(worst, -relative_energy_error(lowest, e0=energies[0]), out=worst)
    worst[~np.isfinite(worst)] = np.inf  # a diverged member sorts last
    with np.errstate(all="ignore"):  # a median of two errors near the float limit overflows to inf (not drawn)
        return np.stack([worst.min(axis=1), np.median(worst, axis=1), worst.max(axis=1)], axis=1)


def spread(values: np.ndarray) -> dict | None:
    """min, median and max over the members that did not diverge (None if all did)."""
    finite = np.sort(values[np.isfinite(values)])
    if len(finite) == 0:
        return None
    middle = finite[(len(finite) - 1) // 2: len(finite) // 2 + 1]
    with np.errstate(over="ignore"):
        median = np.median(middle)
    if not np.isfinite(median):  # two middle values near the float limit: their sum overflows, their halves do not
        median = middle[0] / 2 + middle[-1] / 2
    return {"min": float(finite[0]), "median": float(median), "max": float(finite[-1])}


def summarize(run: tuple, kept: np.ndarray, for_recording: bool) -> tuple[dict, tuple]:
    """What an ensemble run keeps of one integrator's run (positions, velocities, energies of every member):
    each member's drift and, for the recording, the first members' paths and the spread of all the members'
    error curves; and member 0's own run, which is the single run with --seed, bit for bit."""
    positions, velocities, energies = run
    summary = ensemble_drift(energies)
    if for_recording:
        summary["paths"] = positions[:, :SHOWN_MEMBERS].copy()
        summary["error_spread"] = error_spread(energies, kept)
    return summary, (positions[:, 0].copy(), velocities[:, 0].copy(), energies[:, 0].copy())


def ensemble_block(seeds: range, ensemble: dict, judge=None) -> dict:
    """The `ensemble` block of metrics.json (rounded there like drift): each drift's spread and, where the ordering
    is judged (judge is engine.judge_ordering, one verdict per member as a single run gets), its counts."""
    block = {"seeds": [seeds[0], seeds[-1]], "members": len(seeds), "drift": {
        name: {"rel_final": spread(s["rel_final"]), "rel_max": spread(s["rel_max"]),
               "diverged": int(np.count_nonzero(s["diverged"]))} for name, s in ensemble.items()}}
    if judge:
        verdicts = judge(ensemble)
        block["ordering_holds"] = int(np.count_nonzero(verdicts == "holds"))
        block["ordering_fails_for_seeds"] = [seeds[i] for i in np.flatnonzero(verdicts == "fails").tolist()]
        block["ordering_not_judged"] = int(np.count_nonzero(~np.isin(verdicts, ["holds", "fails"])))
        block["ordering_roundoff_only"] = int(np.count_nonzero(verdicts == "roundoff"))
        block["ordering_left_band"] = int(np.count_nonzero(verdicts == "left_band"))
    return block


# What one seed changes in each system (engine.build_system draws it; tests/test_docs.py holds the two together).
SEED_CHANGES = {"orbit": "the orbit's starting speed, 1 +- 0.05 (5%), and with it the ellipse",
                "spring": "the spring's starting stretch, 1 +- 0.1 m (10%)",
                "freefall": "the body's launch speed, 3 +- 0.5 m/s"}


def jittered(build) -> str:
    """What a seed changes in a system SEED_CHANGES has no words for: the one number that differs between seeds.
    build(rng) builds the system, as in build_ensemble."""
    a, b = (build(np.random.default_rng(seed)) for seed in (0, 1))
    changed = [f"{key}'s {axis}" for key in ("q0", "v0") for axis, x, y in zip("xyz", a[key], b[key], strict=True)
               if x != y]
    return f"the start's {' and '.join(changed) or 'nothing'}"


def counted(count: int, noun: str) -> str:
    """'1 member', '1,000 members'."""
    return f"{count:,} {noun}" if count == 1 else f"{count:,} {noun}s"


def memory_over_limit(needed: float) -> str:
    """'2.0 GB, over the 1 GB': as many decimals as it takes for the need to read as more than the limit."""
    for decimals in range(1, 10):
        shown = f"{needed / 1e9:.{decimals}f}"
        if float(shown) > ENSEMBLE_MEMORY / 1e9:
            break
    return f"{shown} GB, over the {ENSEMBLE_MEMORY / 1e9:g} GB"


def print_ensemble_report(system_name: str, seeds: range, block: dict, ordering: str, build) -> None:
    """The ensemble's table: per integrator, min/median/max over the members of both drifts; then the
    ordering's line (engine.ORDERING) with how many members it holds for. build(rng) builds the system."""
    print(f"\nensemble of seeds {seeds[0]}..{seeds[-1]}: {counted(len(seeds), 'member')} stepped together")
    print(f"(a seed changes {SEED_CHANGES.get(system_name) or jittered(build)})")
    if system_name == "spring":
        print("(the spring is linear: a seed only scales the amplitude, so every member's relative drift\n"
              " is the same up to round-off; the spread below is not a finding)")
    print(f"{'':<14}{'rel_final':^36}  {'rel_max':^36}".rstrip())
    print(f"{'integrator':<14}" + f"{'min':>12}{'median':>12}{'max':>12}  " * 2 + f"{'diverged':>8}")
    for name, d in block["drift"].items():
        cells = [("".join(f"{x[key]:>12.3e}" for key in ("min", "median", "max")) if x else f"{'-':>36}")
                 for x in (d["rel_final"], d["rel_max"])]  # '-': every member diverged
        print(f"{name:<14}{cells[0]}  {cells[1]}  {d['diverged']:>8,}")
    if "ordering_holds" in block:
        head = f"{ordering}:"
        if block["ordering_not_judged"] == len(seeds):
            print(f"{head} cannot judge {'the one seed' if len(seeds) == 1 else f'any of the {len(seeds):,} seeds'}")
        else:
            print(f"{head} holds for {block['ordering_holds']:,} of {counted(len(seeds), 'seed')}")
        roundoff, left_band = block["ordering_roundoff_only"], block["ordering_left_band"]
        if block["ordering_not_judged"] - roundoff - left_band:
            print(f"  {block['ordering_not_judged'] - roundoff - left_band:,} diverged under some integrator and"
                  " cannot be judged (try a smaller --dt)")
        if left_band:
            print(f"  {left_band:,} left semi_implicit's band (energy error past 100%) and cannot be judged"
                  " (try a smaller --dt)")
        if roundoff:
            print(f"  {roundoff:,} drifted by round-off only and cannot be judged (more --steps or a larger --dt)")
        fails = block["ordering_fails_for_seeds"]
        if fails:
            more = f" and {len(fails) - 10:,} more" if len(fails) > 10 else ""
            print(f"  it fails for {'seed' if len(fails) == 1 else 'seeds'} {', '.join(map(str, fails[:10]))}{more}:"
                  " rerun one with --seed to look")
