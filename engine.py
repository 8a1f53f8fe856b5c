"""Chapter 3.3: the inside of mj_step, without contacts, in plain numpy.

A state (q, v, m), a force law and three integrators (explicit Euler, semi-implicit
Euler, RK4), run on three conservative systems. Energy is the referee: a perfect
integrator would hold it constant, so how far each one drifts, and in which shape,
is what we measure. A damped spring shows the next rung: its referee is its exact
solution, and a fourth step, implicit in the damping as MuJoCo's Euler is, joins in.

Run it from the repo root:

    python engine.py                       # Kepler orbit, all three integrators, with a recording
    python engine.py --system freefall     # the case where the symplectic advantage vanishes
    python engine.py --smoke --no-rerun    # fixed 600 steps: what CI diffs byte for byte
    python engine.py --ensemble 1000       # seeds 0..999 stepped together: does the ordering always hold?
    python engine.py --system damped_spring --damping 300   # stiff damping: the implicit rung

Open the recording with `rerun outputs/ch3.3-engine/engine.rrd`.
"""

from __future__ import annotations  # annotations stay text: np.random loads in main(), not at import

import sys

from curriculum.common.interrupts import guard

guard("engine.py")  # from here on, Ctrl-C or SIGTERM ends in one line (exit 130 or 143), never a traceback

import argparse  # imports come below the guard on purpose: numpy takes a moment to load
import functools
import json
import math
import time
from pathlib import Path

import numpy as np

from curriculum.common.cli import (
    OneLineParser,
    int_in,
    name_arg,
    positive_finite,
    progress_printer,
    recording_wanted,
)
from curriculum.common.device import banner, wall_clock
from curriculum.common.interrupts import memory_problem, signal_in
from curriculum.common.outputs import (
    content_id,
    folder_arg,
    folder_problem,
    one_line_failures,
    write_run,
)
from engine_ensembles import (
    ENSEMBLE_MEMORY,
    ROUNDOFF_DRIFT,
    ensemble_block,
    ensemble_bytes,
    ensemble_every,
    ensemble_most_members,
    print_ensemble_report,
    summarize_ensemble,
)

# --- settings ---

DEFAULT_STEPS = 2000  # the chapter's run: 20 s of sim time at dt 0.01
SMOKE_STEPS = 600  # fixed, so two smoke runs can be diffed byte for byte
MAX_STEPS = 10_000_000  # energies of every step stay in memory: 80 MB per integrator at the cap
MAX_SEED = 2**64 - 1  # any seed numpy takes would do; past 4,300 digits Python cannot even print one
MAX_DAMPING = 1e6  # N s/m: dt b/m = 10,000 at the chapter's dt, far past docs/damping.md's map (100); much
# further and the exact motion overflows: e^(b/2m t) at the recording's t = -1 us past 1.4e9, (b/2m)^2 past 2.7e154
MAX_POINTS_PER_SERIES = 100_000  # past this the kept states (and the recording) thin to every k-th step
CHUNK_VALUES = 100_000  # numbers per chunk of states whose energy simulate() evaluates in one call
PROGRESS_FROM = 300_000  # integrator-steps in a run before progress goes to stderr
BOUNDED_SLACK = 1e-3  # a steady oscillation's sampled peaks differ by less than this between halves
METRICS_FILE, RECORDING_FILE = "metrics.json", "engine.rrd"


# --- systems ---
# A system is the physics: where the body starts (q0, v0), its mass m, the force law
# force(q, v), and the true total energy(q, v), which a perfect integrator holds constant.
# Each also knows its exact motion, exact(q0, v0, t): where a body starting at (q0, v0) is
# at times t, (K,) -> (K, *q0.shape). The recording measures the integrators against it.
#
# The contract every system keeps, and simulate() checks: q and v are one body's
# position and velocity, shape (3,), or a batch of N independent bodies, shape (N, 3),
# stepped together. force(q, v) returns q's shape; energy(q, v) returns one number per
# body, shape q.shape[:-1]. Three components let a planar orbit draw as a curve in 3D,
# and chapter 3.4 adds a constraint force to this same force without changing the rest.
#
# Determinism: `@`, np.dot and np.linalg.norm hand small vectors to BLAS, and `**` calls
# libm's pow; both round differently on different CPUs. So the physics squares, adds and
# cubes with plain arithmetic (dot3, r * r * r), which IEEE rounds the same everywhere.

SYSTEMS = ("orbit", "spring", "freefall")  # conservative: energy is the referee
DAMPED_SYSTEMS = ("damped_spring",)  # dissipative: the closed-form solution is the referee
DAMPING = 0.5  # the damped spring's b, N s/m, unless --damping says otherwise (300 is the stiff case)


def dot3(a, b):
    """a . b over the last axis, summed in a fixed order: (3,) gives a number, (N, 3) gives (N,)."""
    x, y, z = (a * b).T  # the three products: numbers for one body, columns for a batch
    return x + y + z


def build_system(name: str, rng: np.random.Generator, damping: float = DAMPING) -> dict:
    """Return {name, q0, v0, m, force, energy, exact} for one of the systems.

    The seed jitters one initial condition per system (orbit speed, spring stretch,
    launch speed), so --seed matters while the ordering of the drifts does not change.
    The damped spring also declares dforce_dv and dissipation (see there).
    """
    if name == "orbit":
        # A unit mass around a fixed attractor at the origin, inverse-square pull, GM = mu = 1.
        # Speed 1 would be a circle; the jitter makes it an ellipse, which still closes exactly.
        mu, m = 1.0, 1.0
        q0 = np.array([1.0, 0.0, 0.0])
        v0 = np.array([0.0, 1.0 + rng.uniform(-0.05, 0.05), 0.0])

        def force(q, v):
            r = np.sqrt(dot3(q, q))  # distance to the attractor, one per body
            return -mu * m * q / (r * r * r)[..., None]  # magnitude mu m / r^2, pointing at the attractor

        def energy(q, v):
            return 0.5 * m * dot3(v, v) - mu * m / np.sqrt(dot3(q, q))  # kinetic + gravitational

        def exact(q0, v0, t):
            return kepler_orbit(q0, v0, t, mu)

    elif name == "spring":
        # A mass on an ideal Hooke spring: pulled straight back, in proportion to the stretch.
        # Undamped, so the amplitude and the energy should stay exactly where they started.
        k, m = 4.0, 1.0  # angular frequency sqrt(k/m) = 2 rad/s
        q0 = np.array([1.0 + rng.uniform(-0.1, 0.1), 0.0, 0.0])
        v0 = np.zeros(3)

        def force(q, v):
            return -k * q  # Hooke: restoring, in proportion to the stretch

        def energy(q, v):
            return 0.5 * m * dot3(v, v) + 0.5 * k * dot3(q, q)  # kinetic + spring

        def exact(q0, v0, t):
            w, t = np.sqrt(k / m), times_for(t, q0)
            return q0 * np.cos(w * t) + v0 / w * np.sin(w * t)

    elif name == "freefall":
        # A body thrown sideways under constant gravity. Energy is conserved here too, but the
        # motion never comes back, and that is what breaks the neat story of the other two.
        g, m = 9.81, 1.0
        q0 = np.array([0.0, 0.0, 10.0])
        v0 = np.array([3.0 + rng.uniform(-0.5, 0.5), 0.0, 0.0])
        gravity = np.array([0.0, 0.0, -g])
        weight = m * gravity

        def force(q, v):
            return np.full(q.shape, weight)  # the same weight on every body

        def energy(q, v):
            return 0.5 * m * dot3(v, v) + m * g * q[..., 2]  # kinetic + height

        def exact(q0, v0, t):
            t = times_for(t, q0)
            return q0 + v0 * t + 0.5 * gravity * t * t  # the parabola

    elif name == "damped_spring":
        # The spring again, with a damper pulling against the velocity: force -k q - b v.
        # Energy now drains away, so the referee is the closed-form solution instead, and the
        # energy lost must match the damper's work, the time integral of b |v|^2.
        k, m, b = 4.0, 1.0, float(damping)
        q0 = np.array([1.0 + rng.uniform(-0.1, 0.1), 0.0, 0.0])
        v0 = np.zeros(3)

        def force(q, v):
            return -k * q - b * v  # spring plus damper, added in MuJoCo's order

        def energy(q, v):
            return 0.5 * m * dot3(v, v) + 0.5 * k * dot3(q, q)  # kinetic + spring: what the damper drains

        def dissipation(q, v):
            return b * dot3(v, v)  # the power the damper takes out, one number per body

        def exact(q0, v0, t):  # the truth from any start, so a batch's rows each get their own
            return damped_oscillator(q0, v0, k, m, b, t)

        # What a velocity-dependent force declares for implicit_step: d force / d v, here -b
        # times the identity (MuJoCo's qDeriv). Conservative systems have none.
        return {"name": name, "q0": q0, "v0": v0, "m": m, "force": force, "energy": energy,
                "dforce_dv": -b, "dissipation": dissipation, "exact": exact, "k": k, "b": b}

    else:
        raise ValueError(f"unknown system {name!r}; choose one of {', '.join(SYSTEMS + DAMPED_SYSTEMS)}")
    return {"name": name, "q0": q0, "v0": v0, "m": m, "force": force, "energy": energy, "exact": exact}


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
        r1 = w0 * w0 / r2  # the slow root from r1 r2 = w0^2: -g + sqrt(...) would cancel away its digits
        return ((r1 * math.exp(r2 * t) - r2 * math.exp(r1 * t)) / (r1 - r2),
                (math.exp(r1 * t) - math.exp(r2 * t)) / (r1 - r2))

    times = np.asarray(t, dtype=float)
    ab = np.array([basis(time) for time in times.ravel().tolist()]).reshape(times.shape + (2,))
    one_per_row = times.shape + (1,) * np.ndim(q0)  # broadcast each time over a body's (or a batch's) q0
    return ab[..., 0].reshape(one_per_row) * q0 + ab[..., 1].reshape(one_per_row) * v0


def build_ensemble(name: str, seeds, progress=None) -> dict:
    """One system, N bodies stepped as a batch: q0 and v0 become (N, 3), one row per seed.

    Row i starts exactly where build_system(name, default_rng(seeds[i])) does: each seed gets its own
    generator, as a single run does, but only its one jitter is drawn per seed. The rest, the force
    and energy laws included, is built once: with the jitter 0 (the start) and 1 (what it moves).
    progress(done), if given, is called as the members' draws are made.
    """
    zero, one = OneDraw(0.0), OneDraw(1.0)
    system, moved = build_system(name, zero), build_system(name, one)
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


# --- integrators ---
# Each takes the state (q, v) and returns it one timestep dt later. They differ only in
# where they look at the velocity and the force, and that is the whole lesson.


def euler_step(q, v, m, force, dt):
    """Explicit (forward) Euler: everything from the old state.

    q += dt * v_old;  v += dt * a_old.
    Not symplectic; order 1; 1 force evaluation per step.
    Fails on anything that oscillates: it adds energy every step, so orbits spiral out.
    """
    a = force(q, v) / m
    return q + dt * v, v + dt * a  # the position moves with the OLD velocity


def semi_implicit_step(q, v, m, force, dt):
    """Semi-implicit (symplectic) Euler, velocity first: MuJoCo's default, mjINT_EULER.

    v += dt * a_old;  q += dt * v_new.
    Symplectic; order 1; 1 force evaluation per step.
    Energy wobbles in a band that does not grow; it fails where motion never returns (freefall).
    """
    a = force(q, v) / m
    v_next = v + dt * a
    q_next = q + dt * v_next  # the NEW velocity moves the position: one line, the whole trick
    return q_next, v_next


def rk4_step(q, v, m, force, dt):
    """Classical Runge-Kutta 4 on (q, v)' = (v, force(q, v) / m).

    Four slopes (start, midpoint twice, end), blended 1-2-2-1.
    Not symplectic; order 4; 4 force evaluations per step.
    Tiny error per step, but it creeps one way and is never pulled back over long runs.
    """

    def deriv(q, v):  # the slope of the state: q changes at v, v at the acceleration
        return v, force(q, v) / m

    k1q, k1v = deriv(q, v)
    k2q, k2v = deriv(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v)
    k3q, k3v = deriv(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v)
    k4q, k4v = deriv(q + dt * k3q, v + dt * k3v)
    q_next = q + (dt / 6.0) * (k1q + 2.0 * k2q + 2.0 * k3q + k4q)
    v_next = v + (dt / 6.0) * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
    return q_next, v_next


INTEGRATORS = {"euler": euler_step, "semi_implicit": semi_implicit_step, "rk4": rk4_step}


# The next rung, for systems whose force depends on the velocity (a damper): it needs one
# more thing from the system, the force's derivative dforce_dv, so it is offered only there.


def implicit_step(q, v, m, force, dt, dforce_dv):
    """Semi-implicit Euler with the velocity-dependent force taken at the NEW velocity.

    Solves m (v_new - v) / dt = force(q, v) + dforce_dv (v_new - v) for v_new, then q += dt * v_new.
    With a linear damper that is the force at (q_old, v_new): implicit in the damping, explicit
    in the spring. It is MuJoCo's Euler on a joint with damping, and its implicitfast (M - h qDeriv).
    Order 1; 1 force evaluation per step; with dforce_dv = 0 it is semi_implicit_step exactly.
    What it buys under stiff damping is exercise 6 (predict first); docs/damping.md has the stability map.
    """
    # MuJoCo factorizes m - dt * qDeriv and multiplies by the inverse of its diagonal, so we do
    # too and match it to the bit (its mjINT_IMPLICIT divides instead: last-bit differences).
    inverse_mass = 1.0 / (m - dt * dforce_dv)
    a = force(q, v) * inverse_mass
    v_next = v + dt * a
    q_next = q + dt * v_next  # the new velocity moves the position, as in semi_implicit_step
    return q_next, v_next


def integrators_for(system: dict) -> dict:
    """The chapter's three, plus implicit_step where the system declares dforce_dv."""
    if "dforce_dv" not in system:
        return dict(INTEGRATORS)
    return {**INTEGRATORS, "implicit": functools.partial(implicit_step, dforce_dv=system["dforce_dv"])}


# --- simulate and measure ---


def simulate(step_fn, system: dict, dt: float, steps: int, every: int = 1, progress=None):
    """Integrate `system` for `steps` steps of `dt`. Returns (positions, velocities, energies).

    positions, velocities: the states at kept_steps(steps, every), that is every `every`-th
    step and always the last; with every=1 that is all of them, (steps + 1, 3), or
    (steps + 1, N, 3) for a batch. energies: the total energy at every step, row 0 the start.
    A state that blows up is carried on as inf/NaN without warnings, and energy_drift()
    reports the step where that began. progress(done), if given, is called as chunks finish.
    """
    q = np.array(system["q0"], dtype=float)
    v = np.array(system["v0"], dtype=float)
    m, force, energy = system["m"], system["force"], system["energy"]
    check_contract(system, q, v)
    kept = kept_steps(steps, every)
    positions = np.empty((len(kept), *q.shape))
    velocities = np.empty_like(positions)
    energies = np.empty((steps + 1, *q.shape[:-1]))
    positions[0], velocities[0], energies[0] = q, v, energy(q, v)
    # The loop only steps and stores. The referee, energy, is evaluated a chunk of steps at a time:
    # a chunk of states is a batch like any other (see the contract), so one call does thousands.
    chunk = min(steps, max(1, CHUNK_VALUES // q.size))
    q_chunk, v_chunk = np.empty((chunk, *q.shape)), np.empty((chunk, *q.shape))
    with np.errstate(all="ignore"):
        for first in range(1, steps + 1, chunk):
            count = min(chunk, steps + 1 - first)
            for j in range(count):
                q, v = step_fn(q, v, m, force, dt)
                q_chunk[j], v_chunk[j] = q, v
            batch = energy(q_chunk[:count].reshape(-1, 3), v_chunk[:count].reshape(-1, 3))
            energies[first:first + count] = batch.reshape(count, *q.shape[:-1])
            rows = slice(*np.searchsorted(kept, [first, first + count]))  # kept steps inside this chunk
            positions[rows], velocities[rows] = q_chunk[kept[rows] - first], v_chunk[kept[rows] - first]
            if progress:
                progress(first + count - 1)
    return positions, velocities, energies


def kept_steps(steps: int, every: int = 1) -> np.ndarray:
    """The step numbers simulate() keeps states for: 0, every, 2 every, ... and the last."""
    kept = np.arange(0, steps + 1, every)
    return kept if kept[-1] == steps else np.append(kept, steps)


def check_contract(system: dict, q, v) -> None:
    """Fail at once, with a sentence, if a system breaks the contract above."""
    name = system.get("name", "this system")
    if q.ndim not in (1, 2) or q.shape[-1] != 3 or v.shape != q.shape:
        raise ValueError(f"{name}: q0 and v0 must both be (3,) for one body or (N, 3) for N bodies, "
                         f"got {q.shape} and {v.shape}")
    with np.errstate(all="ignore"):
        force, energy = np.shape(system["force"](q, v)), np.shape(system["energy"](q, v))
    if force != q.shape:
        raise ValueError(f"{name}: force(q, v) must return one force per body, shape {q.shape}, got {force}")
    if energy != q.shape[:-1]:
        raise ValueError(f"{name}: energy(q, v) must return one number per body, shape {q.shape[:-1]}, got {energy}"
                         " (sum the three components with dot3, not over the whole array)")


def run(system_name: str, integrator: str, dt: float = 0.01, steps: int = 2000, seed: int = 0, every: int = 1):
    """build_system + simulate, as the exercises and tests call it: (positions, velocities, energies)."""
    system = build_system(system_name, np.random.default_rng(seed))
    return simulate(integrators_for(system)[integrator], system, dt, steps, every)


def energy_drift(energies: np.ndarray) -> dict:
    """Energy error relative to the start: the numbers the chapter is about.

    rel_final: signed drift at the last step (explicit Euler: large and positive).
    rel_max: worst absolute excursion anywhere (bounded for semi-implicit, growing for Euler).
    If the energy overflowed or went NaN, the figures are None and diverged_at_step says when.
    """
    e0 = float(energies[0])
    scale = abs(e0) if e0 != 0.0 else 1.0
    with np.errstate(all="ignore"):  # finite energies can still be so far apart that the error overflows
        error = np.abs(energies - e0) / scale
    finite = np.isfinite(error)  # False where the energy is inf/NaN, or where its error is
    if not finite.all():
        return {"e0": e0, "e_final": None, "rel_final": None, "rel_max": None,
                "diverged": True, "diverged_at_step": int(np.argmin(finite))}
    return {
        "e0": e0,
        "e_final": float(energies[-1]),
        "rel_final": float((energies[-1] - e0) / scale),
        "rel_max": float(np.max(error)),
        "diverged": False,
        "diverged_at_step": None,
    }


def did_not_move(positions: np.ndarray, velocities: np.ndarray) -> bool:
    """True if the last state is the first to within one rounding step of the state's size (dt too small)."""
    start = np.concatenate([positions[0].ravel(), velocities[0].ravel()])
    change = np.concatenate([(positions[-1] - positions[0]).ravel(), (velocities[-1] - velocities[0]).ravel()])
    return bool(np.all(np.abs(change) <= np.spacing(np.max(np.abs(start)))))


def against_exact(system: dict, positions, velocities, energies, kept, dt: float) -> dict:
    """A damped run (one body) against its closed-form solution: what the report prints for it.

    err_max, err_final: the largest and the last distance |q - q_exact| over the kept states.
    bounded: finite, and the second half of the run swings no wider than the first (largest |q|,
    give or take BOUNDED_SLACK for where the samples fall on a steady oscillation).
    energy_lost against damper_work: E0 - E(t) against the integral of b |v|^2 up to the same t,
    by composite Simpson over the kept states (order 4, so it does not hide RK4's own order 4);
    work_mismatch = (energy_lost - damper_work) / E0 shrinks like dt^order when dt halves.
    """
    if not np.isfinite(energies).all():  # the energy squares q and v: finite energy, finite everything
        return {"err_max": None, "err_final": None, "bounded": False, "energy_lost": None,
                "damper_work": None, "work_mismatch": None}
    gap = positions - system["exact"](system["q0"], system["v0"], kept * dt)
    distance = np.sqrt(dot3(gap, gap))
    swing = np.sqrt(dot3(positions, positions))
    half = len(swing) // 2
    bounded = swing[half:].max() <= swing[:half + 1].max() * (1.0 + BOUNDED_SLACK)
    spacing = kept[1:] - kept[:-1]
    uniform = len(kept) - 1 if (spacing == spacing[0]).all() else len(kept) - 2  # thinned: drop the short tail
    work = simpson(system["dissipation"](positions[: uniform + 1], velocities[: uniform + 1]), spacing[0] * dt)
    lost = float(energies[0] - energies[kept[uniform]])
    return {"err_max": float(distance.max()), "err_final": float(distance[-1]), "bounded": bool(bounded),
            "energy_lost": lost, "damper_work": work, "work_mismatch": (lost - work) / float(energies[0])}


def simpson(values, h: float) -> float:
    """Composite Simpson's rule over equally spaced samples; an odd count of intervals ends with the 3/8 rule."""
    f = [float(value) for value in values]  # math.fsum: exactly rounded, the same on every CPU
    n = len(f) - 1
    if n < 3:  # too few for Simpson: the trapezoid
        return h * (0.5 * f[0] + math.fsum(f[1:n]) + 0.5 * f[n]) if n else 0.0
    head = n if n % 2 == 0 else n - 3  # even part by Simpson 1-4-2-4-...-1, the rest by 3/8
    total = h / 3.0 * (f[0] + 4.0 * math.fsum(f[1:head:2]) + 2.0 * math.fsum(f[2:head:2]) + f[head])
    if head < n:
        total += 3.0 * h / 8.0 * (f[n - 3] + 3.0 * f[n - 2] + 3.0 * f[n - 1] + f[n])
    return total


# --- report ---


def build_metrics(system_name: str, dt: float, steps: int, seed: int, drifts: dict,
                  damping: float | None = None, solution: dict | None = None, ensemble: dict | None = None) -> dict:
    """The metrics.json payload: no wall-clock, nothing machine-dependent.

    A damped system adds its damping and "solution": each integrator against the closed form;
    an --ensemble run adds its "ensemble" block.
    """
    metrics = {"system": system_name, "dt": dt, "steps": steps, "seed": seed, "drift": rounded(drifts)}
    if solution is not None:
        metrics.update(damping=damping, solution=rounded(solution))
    if ensemble is not None:
        metrics["ensemble"] = rounded(ensemble)
    return metrics


def rounded(value):
    """Every float in `value` (through dicts and lists) to 12 decimals, the chapter's format: RK4's drift
    at the chapter's dt, ~5e-11, keeps two digits. From dt 0.004 down it is below 1e-12 and rounds to 0.0
    in the file; the printed table keeps five significant digits of every drift."""
    if isinstance(value, dict):
        return {key: rounded(item) for key, item in value.items()}
    if isinstance(value, list):
        return [rounded(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None  # strict JSON has no NaN or inf: a figure that overflowed is null, as a diverged one is
    return round(value, 12) if isinstance(value, float) else value


def metrics_text(metrics: dict) -> str:
    """Strict JSON (no NaN or Infinity), keys sorted, so the same run gives the same bytes."""
    return json.dumps(metrics, indent=2, sort_keys=True, allow_nan=False) + "\n"


def cell(value: float, width: int, signed: bool = False) -> str:
    """A table cell: 4 decimals where they fit, scientific notation where they would not."""
    sign = "+" if signed else ""
    text = f"{value:{sign}.4f}"
    return f"{text:>{width}}" if len(text) < width - 1 else f"{value:>{sign}{width}.4e}"


def sim_time(seconds: float) -> str:
    """Simulated seconds as the reports print them: 20.00, or 1e-08 and 1e+12 where two decimals do not fit."""
    return f"{seconds:.2f}" if 0.01 <= seconds < 1e9 else f"{seconds:.3g}"


def print_report(system_name: str, dt: float, steps: int, drifts: dict) -> None:
    print(f"integrated {system_name} for {steps} steps of {dt} s -> {sim_time(steps * dt)} s of sim time")
    print(f"{'integrator':<14}{'E0':>12}{'E_final':>14}{'rel_final':>14}{'rel_max':>14}")
    for name, d in drifts.items():
        if d["diverged"]:
            step = d["diverged_at_step"]
            print(f"{name:<14}{cell(d['e0'], 12)}  diverged: energy error non-finite from step {step:,}")
        else:
            print(f"{name:<14}{cell(d['e0'], 12)}{cell(d['e_final'], 14)}"
                  f"{d['rel_final']:>+14.4e}{d['rel_max']:>14.4e}")
    if set(drifts) == set(INTEGRATORS) and system_name in ("orbit", "spring"):
        # The headline, stated as an ordering so it holds for any seed.
        diverged = [name for name, d in drifts.items() if d["diverged"]]
        euler, semi, rk4 = drifts["euler"], drifts["semi_implicit"], drifts["rk4"]
        if diverged:
            verdict = f"cannot judge, {' and '.join(diverged)} diverged (try a smaller --dt)"
        elif semi["rel_max"] > 1.0:  # an energy error past 100%: the bounded one has no band left to hold
            verdict = f"cannot judge, semi_implicit left its band (rel_max {semi['rel_max']:.3g}; try a smaller --dt)"
        elif abs(euler["rel_final"]) < ROUNDOFF_DRIFT:  # too few steps, or too small a dt, for any drift to show
            verdict = "cannot judge, every drift is round-off (more --steps or a larger --dt)"
        else:
            ok = abs(euler["rel_final"]) > semi["rel_max"] > rk4["rel_max"]
            verdict = "as expected" if ok else "UNEXPECTED: investigate"
        print(f"energy drift ordering euler >> semi_implicit(bounded) > rk4: {verdict}")


def print_damped_report(system: dict, dt: float, steps: int, drifts: dict, solution: dict) -> None:
    """The damped spring's table: distance from the closed form, boundedness, the energy audit."""
    k, m, b = system["k"], system["m"], system["b"]
    ratio = b / (2.0 * math.sqrt(k * m))
    regime = "under-damped" if ratio < 1.0 else "critically damped" if ratio == 1.0 else "over-damped"
    print(f"integrated {system['name']} (k {k:g}, m {m:g}, b {b:g}: {regime}) for {steps} steps of {dt} s"
          f" -> {sim_time(steps * dt)} s of sim time")
    print(f"per step: damping dt b/m = {dt * b / m:.4g}, stiffness dt sqrt(k/m) = {dt * math.sqrt(k / m):.4g}"
          " (docs/damping.md maps where each integrator stays bounded)")
    print(f"{'integrator':<14}{'max |q-exact|':>14}{'final':>12}{'bounded':>9}{'E lost':>10}"
          f"{'damper work':>13}{'mismatch/E0':>13}")
    for name, d in solution.items():
        if drifts[name]["diverged"]:
            print(f"{name:<14}  diverged: energy non-finite from step {drifts[name]['diverged_at_step']:,}")
        else:
            print(f"{name:<14}{d['err_max']:>14.4e}{d['err_final']:>12.4e}{'yes' if d['bounded'] else 'NO':>9}"
                  f"{cell(d['energy_lost'], 10)}{cell(d['damper_work'], 13)}{d['work_mismatch']:>+13.4e}")
    print("truth: the closed-form solution; damper work: the integral of b |v|^2, by composite Simpson")


# --- the run: flags and main ---


def parse_args(argv=None) -> argparse.Namespace:
    parser = OneLineParser(prog="engine.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seed", type=int_in(0, MAX_SEED, "--seed"), default=0,
                        help="seeds the one jittered initial condition per system (default 0)")
    parser.add_argument("--system", type=name_arg, choices=SYSTEMS + DAMPED_SYSTEMS, default="orbit",
                        help="which system to integrate; damped_spring is the one that is not conservative"
                             " (default orbit)")
    parser.add_argument("--integrator", type=name_arg, choices=["all", *INTEGRATORS, "implicit"], default="all",
                        help="'all' runs the three-way comparison, which is the point; on damped_spring it"
                             " adds implicit, the damping taken at the new velocity (default all)")
    parser.add_argument("--damping", type=positive_finite("--damping", MAX_DAMPING), default=None,
                        help=f"damped_spring's b in N s/m (default {DAMPING}); 300 at dt 0.01 is the stiff case")
    parser.add_argument("--dt", type=positive_finite("the timestep --dt"), default=0.01,
                        help="timestep in sim seconds, any positive number; raise it and every drift grows"
                             " (default 0.01)")
    parser.add_argument("--steps", type=int_in(1, MAX_STEPS, "--steps"), default=None,
                        help=f"steps per integrator, 1 to {MAX_STEPS:,} (default {DEFAULT_STEPS:,})")
    parser.add_argument("--smoke", action="store_true",
                        help=f"fixed {SMOKE_STEPS}-step run for CI; two runs write identical {METRICS_FILE}")
    parser.add_argument("--ensemble", type=int_in(1, ensemble_most_members(1), "--ensemble"), default=None,
                        metavar="N", help="also run seeds --seed .. --seed+N-1 together and report the spread, N up to"
                        f" what fits in {ENSEMBLE_MEMORY / 1e9:g} GB (about"
                        f" {ensemble_most_members(DEFAULT_STEPS) // 1000 * 1000:,} orbits of {DEFAULT_STEPS:,} steps;"
                        " default off)")
    parser.add_argument("--device", choices=["cpu"], default="cpu",
                        help="pure numpy runs on the CPU; the flag is there for the course's banner")
    parser.add_argument("--out", type=folder_arg, default=Path("outputs/ch3.3-engine"),
                        help=f"folder for {METRICS_FILE} and {RECORDING_FILE} (default outputs/ch3.3-engine)")
    parser.add_argument("--rerun", dest="rerun", action="store_true", default=True,
                        help=f"write the {RECORDING_FILE} recording (the default)")
    parser.add_argument("--no-rerun", dest="rerun", action="store_false",
                        help="skip the recording; rerun is then never imported")
    args = parser.parse_args(argv)
    args.rerun = recording_wanted("engine.py", args.rerun)  # not under RERUN=off, Rerun's own switch (a CI may set it)
    if args.system not in DAMPED_SYSTEMS and args.damping is not None:
        parser.error(f"argument --damping: only --system {' or '.join(DAMPED_SYSTEMS)} has a damper")
    if args.system in DAMPED_SYSTEMS and args.ensemble:
        parser.error("argument --ensemble: ensembles compare energy drift on the conservative systems"
                     f" ({', '.join(SYSTEMS)})")
    if args.system not in DAMPED_SYSTEMS and args.integrator == "implicit":
        parser.error(f"argument --integrator: implicit needs a velocity-dependent force, so --system"
                     f" {' or '.join(DAMPED_SYSTEMS)}")
    if args.smoke and args.steps is not None:
        parser.error(f"argument --steps: --smoke always runs {SMOKE_STEPS} steps (so two smoke runs can be diffed);"
                     " drop one of the two")
    problem = folder_problem(args.out, [METRICS_FILE, RECORDING_FILE] if args.rerun else [METRICS_FILE])
    if problem:
        parser.error(f"argument --out: {problem}")
    args.steps = args.steps or DEFAULT_STEPS
    steps = SMOKE_STEPS if args.smoke else args.steps
    if not math.isfinite(args.dt * (steps + 1)):  # the times every truth and the recording are evaluated at
        parser.error(f"argument --dt: {steps:,} steps of {args.dt:g} s is more time than a float can hold"
                     f" ({sys.float_info.max:.3g} s): a smaller --dt or fewer --steps")
    if args.ensemble and ensemble_bytes(steps, args.ensemble) > ENSEMBLE_MEMORY:
        parser.error(f"argument --ensemble: {args.ensemble:,} members x {steps:,} steps needs about"
                     f" {ensemble_bytes(steps, args.ensemble) / 1e9:.1f} GB, over the {ENSEMBLE_MEMORY / 1e9:g} GB"
                     " this run may use: fewer members or fewer --steps")
    problem = args.rerun and rerun_problem()
    if problem:
        parser.error(problem)
    return args


def rerun_problem() -> str | None:
    """Why the recording cannot be made (rerun-sdk missing or broken), or None. Imports it: needed anyway."""
    try:
        import rerun  # noqa: F401
    except BaseException as error:  # a broken install fails in many ways; a memory limit in a few more
        if isinstance(error, ImportError) and error.name == "rerun":
            return "the recording needs rerun-sdk: run `pip install -e .` first, or pass --no-rerun"
        if not isinstance(error, Exception) or signal_in(error):
            raise  # Ctrl-C or SIGTERM (also one that surfaced as an ImportError): not a problem of the install
        if memory_problem(error):  # a memory limit (ulimit -v): nothing is broken
            return f"not enough memory to load rerun-sdk ({memory_problem(error)}); raise the memory limit or" \
                   " pass --no-rerun"
        why = f"{type(error).__name__}: {error}".splitlines()[0]
        return f"rerun-sdk is installed but does not import ({why}); reinstall it (`pip install -e .`) or pass" \
               " --no-rerun"
    return None


@one_line_failures("engine.py", memory_hint="fewer --steps need less")  # Ctrl-C 130, SIGTERM 143, OS errors: one line
@np.errstate(all="ignore")  # past a blow-up, inf and NaN are carried on and the report names them: no warnings
def main(argv=None) -> int:
    started = time.perf_counter()  # the wall-clock line counts everything main() does, rerun's import included
    args = parse_args(argv)
    banner("ch3.3-engine", device=args.device)
    steps = SMOKE_STEPS if args.smoke else args.steps
    damping = DAMPING if args.damping is None else args.damping
    # PCG64 seeded per member is the only randomness; member 0 of an ensemble is the single run
    seeds = range(args.seed, args.seed + (args.ensemble or 1))
    if args.ensemble:  # one generator per seed takes ~15 us: past 100,000 members that is worth a progress line
        building = progress_printer("seeds", len(seeds), unit="members") if len(seeds) >= 100_000 else None
        system = build_ensemble(args.system, seeds, building)
    else:
        system = build_system(args.system, np.random.default_rng(args.seed), damping)
    integrators = integrators_for(system)
    names = list(integrators) if args.integrator == "all" else [args.integrator]
    every = math.ceil((steps + 1) / MAX_POINTS_PER_SERIES)  # states kept for the recording; energy: every step
    if args.ensemble:
        every = max(every, ensemble_every(steps, args.ensemble))
    # a member's step in a batch costs about a hundredth of a single run's, hence the 100
    show_progress = not args.smoke and steps * len(names) * len(seeds) >= PROGRESS_FROM * (100 if args.ensemble else 1)
    metrics_path, recording_path = args.out / METRICS_FILE, args.out / RECORDING_FILE
    runs, drifts, ensemble, solution = {}, {}, {}, {}
    for name in names:
        progress = progress_printer(name, steps) if show_progress else None
        positions, velocities, energies = simulate(integrators[name], system, args.dt, steps, every, progress)
        if args.ensemble:
            ensemble[name] = summarize_ensemble(energies, positions, kept_steps(steps, every), args.rerun)
            positions, velocities, energies = positions[:, 0].copy(), velocities[:, 0].copy(), energies[:, 0].copy()
        runs[name] = positions, velocities, energies
        drifts[name] = energy_drift(energies)
        drifts[name]["final_pos"] = [round(x, 6) if math.isfinite(x) else None for x in positions[-1].tolist()]
        if "dissipation" in system:  # a damped system: the closed-form solution is its referee
            solution[name] = against_exact(system, positions, velocities, energies, kept_steps(steps, every), args.dt)
    block = ensemble_block(args.system, seeds, ensemble) if args.ensemble else None
    metrics = build_metrics(args.system, args.dt, steps, args.seed, drifts, damping if solution else None,
                            solution or None, block)
    metrics["run_id"] = content_id(metrics_text(metrics))  # same flags, same id; engine.rrd carries it too
    files, note = {}, None
    if args.rerun:
        from engine_recording import record  # Rerun loads only when a recording is asked for

        files[RECORDING_FILE], note = record(system, runs, kept_steps(steps, every), args.dt, metrics["run_id"],
                                             ensemble)
    files[METRICS_FILE] = metrics_text(metrics)
    write_run(args.out, files)  # all on disk before any replaces its old file; metrics.json last
    if solution:
        print_damped_report(system, args.dt, steps, drifts, solution)
    else:
        print_report(args.system, args.dt, steps, drifts)
    if args.ensemble:
        print_ensemble_report(args.system, seeds, block)
    if all(did_not_move(positions, velocities) for positions, velocities, _ in runs.values()):
        print(f"engine.py: warning: --dt {args.dt} is too small to move the state: after {steps:,} steps no position "
              "or velocity changed by even one rounding step, so the drifts above measure nothing", file=sys.stderr)
    print(f"metrics: {metrics_path}")
    if args.rerun:
        print(f"recording: {recording_path} (open it with: rerun {recording_path})")
        if note:
            print(note)
    elif recording_path.exists():
        print(f"note: {recording_path} is from an earlier run (this one wrote no recording)")
    wall_clock(started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
