"""Many seeds at once, for `python engine.py --ensemble N`: what is kept of each integrator, and the report.

engine.build_ensemble() stacks N starting states into (N, 3) arrays and engine.simulate() steps them
together: the same arithmetic on every row, so each member is bit for bit its own single run, at a
fraction of the cost per member. This module keeps what the report needs: every member's energy at
every step, but positions only every few steps, and summarises them.
"""

import math

import numpy as np

CHAPTER_INTEGRATORS = ("euler", "semi_implicit", "rk4")  # the ordering the verdict checks is theirs
ENSEMBLE_MEMORY = 1_000_000_000  # bytes an --ensemble run may hold; larger requests are refused up front
ENSEMBLE_KEPT_VALUES = 8_000_000  # position values kept per integrator in an ensemble (energies: all of them)
ROUNDOFF_DRIFT = 1e-12  # explicit Euler drifting less than this: every drift is round-off, no ordering to judge
SHOWN_MEMBERS = 20  # member paths an ensemble's recording draws: enough to see the spread, few enough to open


def ensemble_every(steps: int, members: int) -> int:
    """Keep every k-th state so an ensemble's positions stay under ENSEMBLE_KEPT_VALUES numbers."""
    return max(1, math.ceil((steps + 1) * members * 3 / ENSEMBLE_KEPT_VALUES))


def ensemble_bytes(steps: int, members: int) -> int:
    """Memory one integrator's ensemble holds at its peak: every energy (8 bytes) and whether it is
    finite (1 byte), the kept positions and velocities, and the recording's error spread over them."""
    return 9 * (steps + 1) * members + 3 * 8 * ENSEMBLE_KEPT_VALUES


def ensemble_drift(energies: np.ndarray) -> dict:
    """energy_drift() for every member of an ensemble at once; energies is (steps + 1, N).

    Returns arrays of N: rel_final, rel_max (NaN where the member diverged) and diverged; each
    member's figures are the bits energy_drift() gives for that member alone."""
    e0 = energies[0]
    scale = np.where(e0 != 0.0, np.abs(e0), 1.0)
    with np.errstate(all="ignore"):
        # the worst excursion is above the highest energy or below the lowest: no (steps, N) temporaries,
        # and the same bits as max |E - E0| because subtracting E0 keeps the order
        worst = np.maximum(np.max(energies, axis=0) - e0, e0 - np.min(energies, axis=0))
        diverged = ~np.isfinite(worst / scale)  # a non-finite energy, or finite ones whose error overflows
        rel_final = np.where(diverged, np.nan, (energies[-1] - e0) / scale)
        rel_max = np.where(diverged, np.nan, worst / scale)
    return {"rel_final": rel_final, "rel_max": rel_max, "diverged": diverged}


def error_spread(energies: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """(len(kept), 3): at each kept step k, each member's worst |E - E0| / |E0| over steps 0..k (every
    step counts, kept or not), and of those the best member's, the median and the worst member's.

    The worst-so-far only rises, so the recording's curves carry no noise from errors crossing zero."""
    e0 = energies[0]
    # highest and lowest energy between one kept step and the next, then carried on: (len(kept), N) each,
    # worked on in place so the recording's spread costs what the plain |E - E0| at the kept steps did
    starts = np.concatenate([[0], kept[:-1] + 1])
    with np.errstate(all="ignore"):
        worst = np.maximum.reduceat(energies, starts, axis=0)
        np.maximum.accumulate(worst, axis=0, out=worst)
        lowest = np.minimum.reduceat(energies, starts, axis=0)
        np.minimum.accumulate(lowest, axis=0, out=lowest)
        worst -= e0
        np.subtract(e0, lowest, out=lowest)
        np.maximum(worst, lowest, out=worst)
        del lowest
        worst /= np.where(e0 != 0.0, np.abs(e0), 1.0)
        worst[~np.isfinite(worst)] = np.inf  # a diverged member sorts last
        # (a median of two errors near the float limit overflows to inf, which the plot leaves out)
        return np.stack([worst.min(axis=1), np.median(worst, axis=1), worst.max(axis=1)], axis=1)


def ordering_holds(drifts: dict) -> np.ndarray:
    """Per member: |euler rel_final| > semi_implicit rel_max > rk4 rel_max (False where any diverged)."""
    euler, semi, rk4 = drifts["euler"], drifts["semi_implicit"], drifts["rk4"]
    with np.errstate(invalid="ignore"):
        return (np.abs(euler["rel_final"]) > semi["rel_max"]) & (semi["rel_max"] > rk4["rel_max"])


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
    if set(ensemble) == set(CHAPTER_INTEGRATORS) and system_name in ("orbit", "spring"):
        holds = ordering_holds(ensemble)
        diverged = np.any([s["diverged"] for s in ensemble.values()], axis=0)  # such a member cannot be judged
        with np.errstate(invalid="ignore"):  # nor one whose drifts are all round-off (a diverged one's are NaN),
            roundoff = ~diverged & (np.abs(ensemble["euler"]["rel_final"]) < ROUNDOFF_DRIFT)
            unbanded = ~diverged & (ensemble["semi_implicit"]["rel_max"] > 1.0)  # nor one past 100%: no band left
        judged = ~diverged & ~roundoff & ~unbanded
        block["ordering_holds"] = int(np.count_nonzero(holds & judged))
        block["ordering_fails_for_seeds"] = [seeds[i] for i in np.flatnonzero(~holds & judged).tolist()]
        block["ordering_not_judged"] = int(np.count_nonzero(~judged))
        block["ordering_roundoff_only"] = int(np.count_nonzero(roundoff))
        block["ordering_left_band"] = int(np.count_nonzero(unbanded & ~roundoff))
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
