"""Many seeds at once, for `python engine.py --ensemble N`: what is kept of each integrator, and the report.

engine.build_ensemble() stacks N starting states into (N, 3) arrays and engine.simulate() steps them
together: the same arithmetic on every row, so each member is bit for bit its own single run, at a
fraction of the cost per member. This module keeps what the report needs: every member's energy at
every step, but positions only every few steps, and summarises them.

A leaf: it imports engine, and engine.main() loads it only when --ensemble asks.
"""

import math

import numpy as np

import engine

ENSEMBLE_MEMORY = 1_000_000_000  # bytes an --ensemble run may hold; larger requests are refused up front
ENSEMBLE_KEPT_VALUES = 8_000_000  # position values kept per integrator in an ensemble (energies: all of them)
SHOWN_MEMBERS = 20  # member paths an ensemble's recording draws: enough to see the spread, few enough to open


def ensemble_every(steps: int, members: int) -> int:
    """Keep every k-th state so an ensemble's positions stay under ENSEMBLE_KEPT_VALUES numbers."""
    return max(1, math.ceil((steps + 1) * members * 3 / ENSEMBLE_KEPT_VALUES))


def ensemble_bytes(steps: int, members: int) -> int:
    """Memory one integrator's ensemble holds at its peak: every energy (8 bytes) and whether it is
    finite (1 byte), the kept positions and velocities, and the recording's error spread over them."""
    return 9 * (steps + 1) * members + 3 * 8 * ENSEMBLE_KEPT_VALUES


def ensemble_problem(steps: int, members: int) -> str | None:
    """Why an ensemble of `members` x `steps` cannot run (it would not fit in ENSEMBLE_MEMORY), or None."""
    needed = ensemble_bytes(steps, members)
    if needed <= ENSEMBLE_MEMORY:
        return None
    return (f"{members:,} members x {steps:,} steps needs about {needed / 1e9:.1f} GB, over the"
            f" {ENSEMBLE_MEMORY / 1e9:g} GB this run may use: fewer members or fewer --steps")


def ensemble_drift(energies: np.ndarray) -> dict:
    """engine.energy_drift() for every member of an ensemble at once; energies is (steps + 1, N).

    Returns arrays of N: rel_final, rel_max (NaN where the member diverged) and diverged; each
    member's figures are the bits energy_drift() gives for that member alone."""
    # The worst excursion is above the highest energy or below the lowest: no (steps, N) temporaries, and
    # the same bits as max |E - E0| / |E0| because subtracting E0 and dividing by |E0| keep the order.
    start, highest, lowest, final = engine.relative_energy_error(
        np.stack([energies[0], np.max(energies, axis=0), np.min(energies, axis=0), energies[-1]]))
    worst = np.maximum(highest, -lowest)
    diverged = ~np.isfinite(worst)  # a non-finite energy, or finite ones whose error overflows
    return {"rel_final": np.where(diverged, np.nan, final), "rel_max": np.where(diverged, np.nan, worst),
            "diverged": diverged}


def error_spread(energies: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """(len(kept), 3): min, median and max over the members of |E - E0| / |E0| at the kept steps."""
    relative = np.abs(engine.relative_energy_error(energies[kept]))
    relative[~np.isfinite(relative)] = np.inf  # a diverged member sorts last
    with np.errstate(all="ignore"):  # a median of two errors near the float limit overflows to inf (not drawn)
        return np.stack([relative.min(axis=1), np.median(relative, axis=1), relative.max(axis=1)], axis=1)


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


def summarize_ensemble(energies: np.ndarray, positions: np.ndarray, kept: np.ndarray, for_recording: bool) -> dict:
    """What an ensemble run keeps of one integrator: each member's drift and, for the recording,
    the first members' paths and the spread of all the members' error curves."""
    summary = ensemble_drift(energies)
    if for_recording:
        summary["paths"] = positions[:, :SHOWN_MEMBERS].copy()
        summary["error_spread"] = error_spread(energies, kept)
    return summary


def ensemble_block(system_name: str, seeds: range, ensemble: dict) -> dict:
    """The `ensemble` block of metrics.json (rounded there like drift): each drift's spread, the ordering count."""
    block = {"seeds": [seeds[0], seeds[-1]], "members": len(seeds), "drift": {
        name: {"rel_final": spread(s["rel_final"]), "rel_max": spread(s["rel_max"]),
               "diverged": int(np.count_nonzero(s["diverged"]))} for name, s in ensemble.items()}}
    if engine.ordering_is_judged(system_name, ensemble):
        verdicts = engine.judge_ordering(ensemble)  # one verdict per member, as a single run gets
        block["ordering_holds"] = int(np.count_nonzero(verdicts == "holds"))
        block["ordering_fails_for_seeds"] = [seeds[i] for i in np.flatnonzero(verdicts == "fails").tolist()]
        block["ordering_not_judged"] = int(np.count_nonzero(~np.isin(verdicts, ["holds", "fails"])))
        block["ordering_roundoff_only"] = int(np.count_nonzero(verdicts == "roundoff"))
        block["ordering_left_band"] = int(np.count_nonzero(verdicts == "left_band"))
    return block


def print_ensemble_report(system_name: str, seeds: range, block: dict) -> None:
    """The ensemble's table: per integrator, min/median/max over the members of both drifts."""
    print(f"\nensemble of seeds {seeds[0]}..{seeds[-1]}: {len(seeds):,} members stepped together")
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
        head = "energy drift ordering euler >> semi_implicit(bounded) > rk4:"
        if block["ordering_not_judged"] == len(seeds):
            print(f"{head} cannot judge any of the {len(seeds):,} seeds")
        else:
            print(f"{head} holds for {block['ordering_holds']:,} of {len(seeds):,} seeds")
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
            print(f"  it fails for seed {', '.join(map(str, fails[:10]))}{more}: rerun one with --seed to look")


def main(args, steps: int, started: float) -> int:
    """engine.main() for --ensemble: seeds --seed .. --seed+N-1 stepped together, reported, written.

    Member 0 is the single run with --seed, bit for bit: its drifts fill metrics.json's "drift" and
    the table above the ensemble's; the members' spread fills the "ensemble" block.
    """
    seeds = range(args.seed, args.seed + args.ensemble)  # PCG64 seeded per member is the only randomness
    system = engine.build_ensemble(args.system, seeds)
    integrators = engine.integrators_for(system)
    names = list(integrators) if args.integrator == "all" else [args.integrator]
    every = max(math.ceil((steps + 1) / engine.MAX_POINTS_PER_SERIES), ensemble_every(steps, len(seeds)))
    kept = engine.kept_steps(steps, every)
    # a member's step in a batch costs about a hundredth of a single run's, hence the 100
    show_progress = not args.smoke and steps * len(names) * len(seeds) >= engine.PROGRESS_FROM * 100
    runs, drifts, ensemble = {}, {}, {}
    for name in names:
        progress = engine.progress_printer(name, steps) if show_progress else None
        positions, velocities, energies = engine.simulate(integrators[name], system, args.dt, steps, every, progress)
        ensemble[name] = summarize_ensemble(energies, positions, kept, args.rerun)
        runs[name] = positions[:, 0].copy(), velocities[:, 0].copy(), energies[:, 0].copy()
        drifts[name] = engine.drift_with_final_position(runs[name])
    block = ensemble_block(args.system, seeds, ensemble)
    metrics = engine.build_metrics(args.system, args.dt, steps, args.seed, drifts, ensemble=block)
    engine.write_outputs(args, system, runs, kept, metrics, ensemble)
    engine.print_report(args.system, args.dt, steps, drifts)
    print_ensemble_report(args.system, seeds, block)
    engine.finish(args, runs, steps, started)
    return 0
