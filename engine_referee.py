"""The referee's maths, for engine.py: what every run is measured against.

- `relative_energy_error`: (E - E0) / |E0|, the one formula for how far the energy moved.
- `overflow_step`: the step at which a run blew up, the one definition the table, metrics.json, the recording
  and exercise 6 name.
- `distance`: |q - q_exact|, the one formula for how far a body is from its exact motion.
- The closed-form motions the exact referees come from: `kepler_orbit` (and `kepler_period`) for the
  orbit, `damped_oscillator` for the damped spring.
- `dot3`, the three-term sum the physics and the referee both use, the same on every CPU (engine.py's
  determinism note says why).

It imports numpy and nothing of the project's: engine.py and its extensions import it.
"""

import math

import numpy as np


def dot3(a, b):
    """a . b over the last axis, summed in a fixed order: (3,) gives a number, (N, 3) gives (N,)."""
    x, y, z = (a * b).T  # the three products: numbers for one body, columns for a batch
    return x + y + z


def relative_energy_error(energies: np.ndarray, e0=None) -> np.ndarray:
    """(E - E0) / |E0| at every step, sign kept: the referee's one formula (over 1 where E0 = 0).

    energies: (steps + 1,) for one run or (steps + 1, N) for a batch; E0 is row 0 unless given.
    """
    e0 = energies[0] if e0 is None else e0
    with np.errstate(all="ignore"):  # finite energies can still be so far apart that the error overflows
        return (energies - e0) / np.where(e0 != 0.0, np.abs(e0), 1.0)


def overflow_step(energies: np.ndarray) -> int | None:
    """The step at which a run blew up: the first whose energy error is no longer a finite number (the energy
    overflowed, |q| or |v| past about 1e154, or went NaN), or None. Its state overflows later (a float holds up to
    1.8e308) but its energy, the referee, can no longer say anything from here: "energy overflowed at step N"."""
    finite = np.isfinite(relative_energy_error(np.asarray(energies, dtype=float)))
    return None if finite.all() else int(np.argmin(finite))


def distance(positions: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """|q - q_exact| for each state, in metres: how far each body is from where the exact motion puts it."""
    gap = positions - exact
    with np.errstate(all="ignore"):  # a run that blew up is inf or NaN away
        return np.sqrt(dot3(gap, gap))


def times_for(t, q0):
    """Times (K,) shaped to broadcast against states of q0's shape: (K, 1) or (K, 1, 1)."""
    t = np.asarray(t, dtype=float)
    return t.reshape(t.shape + (1,) * np.ndim(q0))


def kepler_orbit(q0, v0, t, mu):
    """Exact positions at times t on the bound orbit that starts at (q0, v0), by Kepler's equation.

    With a the semi-major axis and n = sqrt(mu / a^3) the mean motion, the change dE of eccentric
    anomaly solves  n t = dE - (1 - r0/a) sin dE + (q0.v0) / sqrt(mu a) (1 - cos dE),  and then
    q(t) = f q0 + g v0 with Lagrange's f = 1 - a/r0 (1 - cos dE) and g = t - (dE - sin dE) / n.
    """
    r0 = np.sqrt(dot3(q0, q0))
    a = 1.0 / (2.0 / r0 - dot3(v0, v0) / mu)  # vis-viva: v^2 = mu (2/r - 1/a)
    n = np.sqrt(mu / (a * a * a))
    t = times_for(t, q0)[..., 0] % (2.0 * np.pi / n)  # the orbit repeats every period
    c, s = 1.0 - r0 / a, dot3(q0, v0) / np.sqrt(mu * a)
    de = n * t
    for _ in range(50):  # Newton's method: a handful of rounds reach round-off
        step = (de - c * np.sin(de) + s * (1.0 - np.cos(de)) - n * t) / (1.0 - c * np.cos(de) + s * np.sin(de))
        de = de - step
        if np.all(np.abs(step) < 1e-12):  # the next round would change de by ~1e-24
            break
    f = 1.0 - a / r0 * (1.0 - np.cos(de))
    g = t - (de - np.sin(de)) / n
    return f[..., None] * q0 + g[..., None] * v0


def kepler_period(q0, v0, mu: float = 1.0) -> float:
    """Kepler's third law, P = 2 pi sqrt(a^3 / mu), with a from vis-viva as in kepler_orbit."""
    a = 1.0 / (2.0 / np.sqrt(dot3(q0, q0)) - dot3(v0, v0) / mu)
    return float(2.0 * np.pi * np.sqrt(a * a * a / mu))


def damped_oscillator(q0, v0, k: float, m: float, b: float, t):
    """The exact positions of m q'' = -k q - b q' from (q0, v0) at the times t: shape t.shape + q0.shape.

    q(t) = A(t) q0 + B(t) v0, A and B the motions that start from (1, 0) and (0, 1). With
    g = b/2m and w0 = sqrt(k/m): under-damped (g < w0) they oscillate at wd = sqrt(w0^2 - g^2)
    inside e^(-gt); critically damped (g = w0) they are (1 + gt) e^(-gt) and t e^(-gt);
    over-damped (g > w0) they mix the two decays r1, r2 = -g +- sqrt(g^2 - w0^2).
    """
    g, w0 = b / (2.0 * m), math.sqrt(k / m)

    def basis(t):  # A(t), B(t) at one time, with math's exp/cos/sin: numpy picks SIMD versions
        fade = math.exp(-g * t)  # by CPU, whose last bits differ, and this truth goes into metrics.json
        if g < w0:
            wd = math.sqrt(w0 * w0 - g * g)
            return fade * (math.cos(wd * t) + g / wd * math.sin(wd * t)), fade * math.sin(wd * t) / wd
        if g == w0:
            return fade * (1.0 + g * t), t * fade
        r2 = -g - math.sqrt(g * g - w0 * w0)
        r1 = w0 * w0 / r2  # the slow root from r1 r2 = w0^2: -g + sqrt(...) would lose ~4 digits
        return ((r1 * math.exp(r2 * t) - r2 * math.exp(r1 * t)) / (r1 - r2),
                (math.exp(r1 * t) - math.exp(r2 * t)) / (r1 - r2))

    times = np.asarray(t, dtype=float)
    ab = np.array([basis(time) for time in times.ravel().tolist()]).reshape(times.shape + (2,))
    one_per_row = times.shape + (1,) * np.ndim(q0)  # broadcast each time over a body's (or a batch's) q0
    return ab[..., 0].reshape(one_per_row) * q0 + ab[..., 1].reshape(one_per_row) * v0


def did_not_move(positions: np.ndarray, velocities: np.ndarray) -> bool:
    """True if a run's last state is its first to within one rounding step of the state's size: a dt so small
    that the run measured nothing."""
    start = np.concatenate([positions[0].ravel(), velocities[0].ravel()])
    change = np.concatenate([(positions[-1] - positions[0]).ravel(), (velocities[-1] - velocities[0]).ravel()])
    return bool(np.all(np.abs(change) <= np.spacing(np.max(np.abs(start)))))
