"""The stability map of the damped spring: where each integrator stays bounded.

    python -m exercises.support.stability_map        # the table in docs/damping.md (7 to 13 s of CPU time)

Support for exercise 6 and docs/damping.md, not an exercise: its output answers exercise 6.

To an integrator a damped spring is two numbers per step: its stiffness w = dt sqrt(k/m) and
its damping c = dt b/m. For each stiffness w we find the range of dampings c where the run
stays bounded twice, independently:
- measured: the engine's own step functions run on a batch of damped springs, one per c, and
  the edges between bounded and unbounded are found by bisection;
- analytic: the one-step matrix (q, dt v) -> (q', dt v') of each integrator on this linear
  system is bounded while both of its eigenvalues lie inside the unit circle or on it (there, if
  the two are not equal, the motion neither grows nor decays: the intervals are closed). For the Eulers
  that condition has a closed form; for RK4 the eigenvalues are R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24
  at the oscillator's own z = dt * eigenvalue, and the edge is found by bisection on |R(z)| = 1.
"""

import math
import sys
from pathlib import Path

if __package__ in (None, ""):  # run as a file (python exercises/support/stability_map.py): make the repo importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

import engine

NAMES = ["euler", "semi_implicit", "rk4", "implicit"]
STIFFNESSES = [0.02, 0.5, 1.0, 1.5, 2.5, 3.0, 4.0]  # w = dt sqrt(k/m); 0.02 is the course's spring at dt 0.01
C_MAX = 1e4  # "any damping" means bounded all the way up to here
DT, M = 0.01, 1.0  # the measured runs use the course's dt and mass; k and b follow from w and c
RUN_STEPS = 4000  # bounded = the second half of the run never swings wider than the first half
PEAK_TOLERANCE = 1e-4
GRID_POINTS = 121
BISECTIONS = 24


# --- analytic: eigenvalues of the one-step matrix ---


def analytic_interval(name: str, w: float) -> tuple[float, float] | None:
    """The dampings (low, high), both ends included, where the one-step matrix stays bounded; None if none.

    With trace T and determinant D of the 2x2 one-step matrix, both eigenvalues lie inside the
    unit circle exactly when |D| < 1 and |T| < 1 + D (the Jury conditions). At the ends, where one
    becomes an equality, an eigenvalue has modulus 1 and the motion neither grows nor decays, so the
    ends are bounded too; except at w = 2, where the end puts both eigenvalues at -1 and the motion
    grows linearly: there the Eulers' intervals shrink to that one point and are None, and the
    implicit step's (0, inf) holds for every c > 0 but not c = 0. On (q, dt v):
    - euler:         [[1, 1], [-w^2, 1 - c]]:  D = 1 - c + w^2, T = 2 - c  ->  w^2 <= c <= 2 + w^2/2
    - semi_implicit: v first, then q with it:  D = 1 - c,       T = 2 - c - w^2  ->  0 <= c <= 2 - w^2/2
    - implicit:      damping at the new v, s = 1/(1 + c):  D = s, T = 1 + s - s w^2  ->  c >= w^2/2 - 2
    - rk4:           no closed form; bisection on the eigenvalues R(z) (see rk4_growth).
    """
    w2 = w * w
    if name == "euler":
        low, high = w2, 2.0 + w2 / 2.0
    elif name == "semi_implicit":
        low, high = 0.0, 2.0 - w2 / 2.0
    elif name == "implicit":
        low, high = max(0.0, w2 / 2.0 - 2.0), math.inf
    elif name == "rk4":
        return _bisect_intervals(lambda ws, c: rk4_growth(ws, c) <= 1.0, [w], bisections=50)[0]
    else:
        raise ValueError(name)
    return (low, high) if low < high else None


def rk4_growth(w, c) -> np.ndarray:
    """Spectral radius of RK4's one-step matrix: max |R(z)| over the oscillator's z = dt * eigenvalue."""
    w, c = np.asarray(w, dtype=float), np.asarray(c, dtype=float)
    root = np.sqrt((c * c - 4.0 * w * w).astype(complex))
    growth = np.zeros_like(c)
    for z in ((-c + root) / 2.0, (-c - root) / 2.0):
        growth = np.maximum(growth, np.abs(1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0))
    return growth


def one_step_matrix(name: str, w: float, c: float) -> np.ndarray:
    """The 2x2 matrix taking (q, dt v) to the next (q, dt v): the engine's step applied to (1, 0) and (0, 1)."""
    system = damped_springs(np.array([w]), np.array([c]))
    step = engine.integrators_for(system)[name]
    columns = []
    for q, dtv in ((1.0, 0.0), (0.0, 1.0)):
        q1, v1 = step(np.array([[q, 0.0, 0.0]]), np.array([[dtv / DT, 0.0, 0.0]]), M, system["force"], DT)
        columns.append([q1[0, 0], v1[0, 0] * DT])
    return np.array(columns).T


# --- measured: run the engine's steps ---


def damped_springs(w: np.ndarray, c: np.ndarray) -> dict:
    """A batch of damped springs, member i with stiffness w[i] and damping c[i] per step at dt = DT.

    The damped_spring's force law, -k q - b v, with k and b a column per member, so that
    one call steps them all.
    """
    k = (np.asarray(w, dtype=float) / DT) ** 2 * M
    b = np.asarray(c, dtype=float) / DT * M
    k, b = k[:, None], b[:, None]

    def force(q, v):
        return q * -k - v * b

    return {"force": force, "dforce_dv": -b, "n": len(k)}


def stays_bounded(name: str, w: np.ndarray, c: np.ndarray, steps: int = RUN_STEPS) -> np.ndarray:
    """Run each (w[i], c[i]) and say which stayed bounded.

    Start: q = 1 and dt v = 1, which excites both of the oscillator's modes. Bounded: finite, and
    the largest of |q| and |dt v| over the second half of the run is no larger than over the first
    half (to within PEAK_TOLERANCE, the sampling wobble of an oscillation that neither grows nor
    decays). A growing mode, however slow, swings wider later; a decaying one does not.
    """
    system = damped_springs(w, c)
    step = engine.integrators_for(system)[name]
    q = np.zeros((system["n"], 3))
    v = np.zeros_like(q)
    q[:, 0], v[:, 0] = 1.0, 1.0 / DT
    swing = np.empty((steps, system["n"]))
    with np.errstate(all="ignore"):
        for i in range(steps):
            q, v = step(q, v, M, system["force"], DT)
            swing[i] = np.maximum(np.abs(q[:, 0]), np.abs(v[:, 0]) * DT)
    swing[~np.isfinite(swing)] = np.inf  # NaN never wins a maximum: a blown-up state counts as infinite
    first, second = swing[: steps // 2].max(axis=0), swing[steps // 2:].max(axis=0)
    return np.isfinite(second) & (second <= first * (1.0 + PEAK_TOLERANCE))


def measured_intervals(name: str, ws, steps: int = RUN_STEPS, grid_points: int = GRID_POINTS,
                       bisections: int = BISECTIONS) -> list:
    """The bounded range of c at each stiffness in ws, from runs of the engine's step."""
    return _bisect_intervals(lambda w, c: stays_bounded(name, w, c, steps), ws, grid_points, bisections)


def _bisect_intervals(bounded, ws, grid_points: int = GRID_POINTS, bisections: int = BISECTIONS) -> list:
    """For each w in ws, the bounded range of c in [0, C_MAX]: scan a grid, then bisect every edge, all at once.

    `bounded(w_array, c_array) -> bool array`. Each entry is (low, high), high = inf if bounded up
    to C_MAX, or None if bounded nowhere. The map has one interval per stiffness (checked, not assumed).
    """
    grid = np.concatenate([[0.0], np.geomspace(1e-6, C_MAX, grid_points - 1)])
    verdicts = np.asarray(bounded(np.repeat(ws, len(grid)), np.tile(grid, len(ws)))).reshape(len(ws), len(grid))
    edges = []  # (row, which end, bounded c, unbounded c)
    for row, verdict in enumerate(verdicts):
        inside = np.flatnonzero(verdict)
        if inside.size == 0:
            continue
        first, last = inside[0], inside[-1]
        if not verdict[first:last + 1].all():
            raise AssertionError(f"w = {ws[row]}: more than one bounded interval, not what this table assumes")
        if first > 0:
            edges.append((row, 0, grid[first], grid[first - 1]))
        if last < len(grid) - 1:
            edges.append((row, 1, grid[last], grid[last + 1]))
    rows = np.array([e[0] for e in edges], dtype=int)
    good, bad = np.array([e[2] for e in edges]), np.array([e[3] for e in edges])
    for _ in range(bisections if edges else 0):
        middle = 0.5 * (good + bad)
        ok = np.asarray(bounded(np.asarray(ws, dtype=float)[rows], middle))
        good, bad = np.where(ok, middle, good), np.where(ok, bad, middle)
    intervals = [None if not verdict.any() else [0.0, math.inf] for verdict in verdicts]
    for (row, end, _, _), edge in zip(edges, 0.5 * (good + bad), strict=True):
        intervals[row][end] = float(edge)
    return [tuple(interval) if interval else None for interval in intervals]


def stability_table() -> list[tuple[float, dict, dict]]:
    """[(w, {name: measured interval}, {name: analytic interval})] for every stiffness in STIFFNESSES."""
    measured = {name: measured_intervals(name, STIFFNESSES) for name in NAMES}
    return [(w, {n: measured[n][i] for n in NAMES}, {n: analytic_interval(n, w) for n in NAMES})
            for i, w in enumerate(STIFFNESSES)]


def shown(interval, digits: int = 6) -> str:
    if interval is None:
        return "never"
    low, high = interval
    return f"{low:.{digits}g} to {'any' if math.isinf(high) else f'{high:.{digits}g}'}"


def largest_difference(table) -> float:
    """The largest relative gap between a measured edge and its analytic one (edges at 0 or inf must be equal)."""
    worst = 0.0
    for _, measured, analytic in table:
        for name in NAMES:
            if (measured[name] is None) != (analytic[name] is None):
                return math.inf
            for m, a in zip(measured[name] or (), analytic[name] or (), strict=True):
                worst = max(worst, 0.0 if m == a else abs(m - a) / abs(a) if a not in (0.0, math.inf) else math.inf)
    return worst


def main(argv=None) -> int:
    import argparse

    argparse.ArgumentParser(prog="exercises.support.stability_map", description=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter).parse_args(argv)
    table = stability_table()
    print(f"Bounded range of the damping c = dt b/m at each stiffness w = dt sqrt(k/m): measured by bisection on"
          f" runs of {RUN_STEPS} steps, (analytic) from the one-step matrix's eigenvalues.\n")
    print("| w | " + " | ".join(NAMES) + " |")
    print("|---" * (len(NAMES) + 1) + "|")
    for w, measured, analytic in table:
        print(f"| {w:g} | " + " | ".join(f"{shown(measured[n])} ({shown(analytic[n])})" for n in NAMES) + " |")
    print(f"\nlargest relative difference, measured against analytic: {largest_difference(table):.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
