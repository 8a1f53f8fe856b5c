"""Chapter 3.3: the inside of mj_step, without contacts, in plain numpy.

A state (q, v, m), a force law and three integrators (explicit Euler, semi-implicit
Euler, RK4), run on three conservative systems. Energy is the referee: a perfect
integrator would hold it constant, so how far each one drifts, and in which shape,
is what we measure. A damped spring shows the next rung: its referee is its exact
solution, and a fourth step, implicit in the damping as MuJoCo's Euler is, joins in.

Run it from the repo root:

    python engine.py                       # Kepler orbit, all three integrators, with a recording
    python engine.py --system freefall     # a motion that never comes back
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
import math
import time
from pathlib import Path

import numpy as np

from curriculum.common.cli import OneLineParser, int_in, name_arg, positive_finite, progress_printer, recording_wanted
from curriculum.common.device import banner, wall_clock
from curriculum.common.outputs import content_id, folder_arg, folder_problem, one_line_failures, write_run
from curriculum.common.report import cell, metrics_text, rounded, sim_time
from curriculum.common.viewer import rerun_problem

# --- settings ---

DEFAULT_STEPS = 2000  # the chapter's run: 20 s of sim time at dt 0.01
SMOKE_STEPS = 600  # fixed, so two smoke runs can be diffed byte for byte
MAX_STEPS = 10_000_000  # energies of every step stay in memory: 80 MB per integrator at the cap
PROGRESS_FROM = 300_000  # integrator-steps in a run before progress goes to stderr
DAMPING = 0.5  # the damped spring's b, N s/m, unless --damping says otherwise (300 is the stiff case)
METRICS_FILE, RECORDING_FILE = "metrics.json", "engine.rrd"


# --- systems ---
# A system is the physics: where the body starts (q0, v0), its mass m, the force law
# force(q, v), and the true total energy(q, v), which a perfect integrator holds constant.

SYSTEMS = {}  # conservative systems, energy is the referee: name -> build(rng), filled by @system
DAMPED_SYSTEMS = {}  # dissipative systems, the closed-form solution is the referee: the same


def system(name: str, returns: bool = False, damped: bool = False):
    """Declare the system the decorated build(rng) returns, under `name`: its one entry. returns: the motion
    comes back (orbit, spring), so the energy error can average out and the drift ordering is judged on it.
    damped: energy drains by design (it declares dissipation and dforce_dv); its closed form referees it."""
    def declare(build):
        build.returns = returns
        (DAMPED_SYSTEMS if damped else SYSTEMS)[name] = build
        return build

    return declare


# Each system also knows its exact motion, exact(q0, v0, t): where a body starting at (q0, v0)
# is at times t, (K,) -> (K, *q0.shape); the recording measures the integrators against it.
# A system with no closed form says exact = None.
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


def dot3(a, b):
    """a . b over the last axis, summed in a fixed order: (3,) gives a number, (N, 3) gives (N,)."""
    x, y, z = (a * b).T  # the three products: numbers for one body, columns for a batch
    return x + y + z


@system("orbit", returns=True)
def orbit(rng):
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

    return {"q0": q0, "v0": v0, "m": m, "force": force, "energy": energy, "exact": exact, "mu": mu}


@system("spring", returns=True)
def spring(rng):
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

    return {"q0": q0, "v0": v0, "m": m, "force": force, "energy": energy, "exact": exact, "k": k}


@system("freefall")
def freefall(rng):
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

    return {"q0": q0, "v0": v0, "m": m, "force": force, "energy": energy, "exact": exact, "g": g}


@system("damped_spring", damped=True)
def damped_spring(rng, damping=DAMPING):
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
    return {"q0": q0, "v0": v0, "m": m, "force": force, "energy": energy, "exact": exact,
            "dissipation": dissipation, "dforce_dv": -b, "k": k, "b": b}


def build_system(name: str, rng: np.random.Generator, damping: float | None = None) -> dict:
    """The system `name` as a dict {name, returns, q0, v0, m, force, energy, exact, ...}; `damping`, if given,
    is the damped spring's b. The seed jitters one number of the start (orbit speed, spring stretch, launch
    speed), so --seed matters while the ordering of the drifts does not change."""
    build = SYSTEMS.get(name) or DAMPED_SYSTEMS.get(name)
    if build is None:
        raise ValueError(f"unknown system {name!r}; choose one of {', '.join([*SYSTEMS, *DAMPED_SYSTEMS])}")
    settings = {} if damping is None else {"damping": damping}
    return {"name": name, "returns": build.returns, **build(rng, **settings)}


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
        r1 = w0 * w0 / r2  # the slow root from r1 r2 = w0^2: -g + sqrt(...) would lose ~4 digits
        return ((r1 * math.exp(r2 * t) - r2 * math.exp(r1 * t)) / (r1 - r2),
                (math.exp(r1 * t) - math.exp(r2 * t)) / (r1 - r2))

    times = np.asarray(t, dtype=float)
    ab = np.array([basis(time) for time in times.ravel().tolist()]).reshape(times.shape + (2,))
    one_per_row = times.shape + (1,) * np.ndim(q0)  # broadcast each time over a body's (or a batch's) q0
    return ab[..., 0].reshape(one_per_row) * q0 + ab[..., 1].reshape(one_per_row) * v0


def kepler_period(q0, v0, mu: float = 1.0) -> float:
    """Kepler's third law, P = 2 pi sqrt(a^3 / mu), with a from vis-viva as in kepler_orbit."""
    a = 1.0 / (2.0 / np.sqrt(dot3(q0, q0)) - dot3(v0, v0) / mu)
    return float(2.0 * np.pi * np.sqrt(a * a * a / mu))


# --- integrators ---
# Each takes the state (q, v) and returns it one timestep dt later. They differ only in
# where they look at the velocity and the force, and that is the whole lesson. Each is
# declared once, with its passport: its order and its force evaluations per step.

INTEGRATORS = {}  # name -> step(q, v, m, force, dt), filled by @integrator


def integrator(name: str, order: int, force_evaluations: int, chapter: bool = True, needs: str | None = None,
               velocity_forces: bool = True):
    """Declare the decorated step under `name`. This is its one entry.

    chapter: one of the chapter's three, which the report's verdict and the exercises compare.
    needs: a fact the step reads from the system (implicit_step needs dforce_dv), so it is
    offered only on systems that declare it. velocity_forces=False: the step keeps its order only
    where the force ignores the velocity (velocity Verlet), so it is not offered where it does not.
    """
    def declare(step):
        vars(step).update(order=order, force_evaluations=force_evaluations, chapter=chapter, needs=needs,
                          velocity_forces=velocity_forces)
        INTEGRATORS[name] = step
        return step

    return declare


@integrator("euler", order=1, force_evaluations=1)
def euler_step(q, v, m, force, dt):
    """Explicit (forward) Euler: everything from the old state.

    q += dt * v_old;  v += dt * a_old.
    Not symplectic; order 1; 1 force evaluation per step.
    What its energy does over a long run: exercise 1. How its error shrinks with dt: exercise 3.
    """
    a = force(q, v) / m
    return q + dt * v, v + dt * a  # the position moves with the OLD velocity


@integrator("semi_implicit", order=1, force_evaluations=1)
def semi_implicit_step(q, v, m, force, dt):
    """Semi-implicit (symplectic) Euler, velocity first: MuJoCo's default, mjINT_EULER, on joints without damping.

    v += dt * a_old;  q += dt * v_new.
    Symplectic; order 1; 1 force evaluation per step.
    Write it yourself: exercise 2. Its energy over a long run: exercise 1; what symplectic means: exercise 5.
    """
    a = force(q, v) / m
    v_next = v + dt * a
    q_next = q + dt * v_next  # the NEW velocity moves the position: one line, the whole trick
    return q_next, v_next


@integrator("rk4", order=4, force_evaluations=4)
def rk4_step(q, v, m, force, dt):
    """Classical Runge-Kutta 4 on (q, v)' = (v, force(q, v) / m).

    Four slopes (start, midpoint twice, end), blended 1-2-2-1.
    Not symplectic; order 4; 4 force evaluations per step.
    Write it yourself: exercise 2. Its energy over a long run: exercises 1 and 4; its order: exercise 3.
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


# The next rung, for systems whose force depends on the velocity (a damper): it needs one
# more thing from the system, the force's derivative dforce_dv, so it is offered only there.


@integrator("implicit", order=1, force_evaluations=1, chapter=False, needs="dforce_dv")
def implicit_step(q, v, m, force, dt, dforce_dv):
    """Semi-implicit Euler with the velocity-dependent force taken at the NEW velocity.

    Solves m (v_new - v) / dt = force(q, v) + dforce_dv (v_new - v) for v_new, then q += dt * v_new.
    With a linear damper that is the force at (q_old, v_new): implicit in the damping, explicit
    in the spring. It is MuJoCo's Euler on a joint with damping, and its implicitfast (M - h qDeriv).
    Symplectic only where dforce_dv = 0; order 1; 1 force evaluation per step (and dforce_dv).
    With dforce_dv = 0 it is semi_implicit_step, bit for bit where 1/m is exact (m = 1, 2, 0.5, ...);
    for other masses the last bit can differ, as it multiplies by 1/m where that one divides by m.
    What it buys under stiff damping: exercise 6 (predict first); docs/damping.md has the stability map.
    """
    # MuJoCo factorizes m - dt * qDeriv and multiplies by the inverse of its diagonal, so we do
    # too and match it to the bit (its mjINT_IMPLICIT divides instead: last-bit differences).
    inverse_mass = 1.0 / (m - dt * dforce_dv)
    a = force(q, v) * inverse_mass
    v_next = v + dt * a
    q_next = q + dt * v_next  # the new velocity moves the position, as in semi_implicit_step
    return q_next, v_next


CHAPTER_INTEGRATORS = tuple(name for name, step in INTEGRATORS.items() if step.chapter)  # euler, semi_implicit, rk4


def integrators_for(system: dict) -> dict:
    """{name: step(q, v, m, force, dt)} for every integrator that can run `system`."""
    steps = {}
    for name, step in INTEGRATORS.items():
        if "dforce_dv" in system and not step.velocity_forces:
            continue  # a velocity-dependent force, which this step's order does not cover
        if step.needs is None:
            steps[name] = step
        elif step.needs in system:
            steps[name] = functools.partial(step, **{step.needs: system[step.needs]})
    return steps


# --- simulate and measure ---

MAX_POINTS_PER_SERIES = 100_000  # past this the kept states (and the recording) thin to every k-th step
CHUNK_VALUES = 100_000  # numbers per chunk of states whose energy simulate() evaluates in one call


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


def relative_energy_error(energies: np.ndarray, e0=None) -> np.ndarray:
    """(E - E0) / |E0| at every step, sign kept: the referee's one formula (over 1 where E0 = 0).

    energies: (steps + 1,) for one run or (steps + 1, N) for a batch; E0 is row 0 unless given.
    """
    e0 = energies[0] if e0 is None else e0
    with np.errstate(all="ignore"):  # finite energies can still be so far apart that the error overflows
        return (energies - e0) / np.where(e0 != 0.0, np.abs(e0), 1.0)


def energy_drift(energies: np.ndarray) -> dict:
    """Energy error relative to the start: the numbers the chapter is about.

    rel_final: signed drift at the last step (explicit Euler: large and positive).
    rel_max: worst absolute excursion anywhere (how it behaves as the run grows: exercise 1).
    If the energy overflowed or went NaN, the figures are None and diverged_at_step says when.
    """
    relative = relative_energy_error(energies)
    error = np.abs(relative)
    finite = np.isfinite(error)  # False where the energy is inf/NaN, or where its error is
    e0 = float(energies[0])
    if not finite.all():
        return {"e0": e0, "e_final": None, "rel_final": None, "rel_max": None,
                "diverged": True, "diverged_at_step": int(np.argmin(finite))}
    return {
        "e0": e0,
        "e_final": float(energies[-1]),
        "rel_final": float(relative[-1]),
        "rel_max": float(np.max(error)),
        "diverged": False,
        "diverged_at_step": None,
    }


ORDERING = "energy drift ordering euler >> semi_implicit > rk4"  # |euler final| > semi max > rk4 max, per run
ROUNDOFF_DRIFT = 1e-12  # explicit Euler drifting less than this: every drift is round-off, nothing to judge


def judge_ordering(drifts: dict):
    """The chapter's claim, |euler rel_final| > semi_implicit rel_max > rk4 rel_max, judged run by run.

    drifts: {integrator: its drift} for one run (numbers; None where it diverged) or for an
    ensemble (arrays of N; NaN where a member diverged). Returns, for each run, "holds", "fails",
    or why it cannot be judged: "diverged", "roundoff" (every drift is round-off: too few steps or
    too small a dt) or "left_band" (semi-implicit's error passed 100%: no band left to hold).
    """
    euler = np.abs(np.asarray(drifts["euler"]["rel_final"], dtype=float))
    semi, rk4 = (np.asarray(drifts[name]["rel_max"], dtype=float) for name in ("semi_implicit", "rk4"))
    diverged = np.any([drifts[name]["diverged"] for name in ("euler", "semi_implicit", "rk4")], axis=0)
    with np.errstate(invalid="ignore"):
        holds = (euler > semi) & (semi > rk4)
        return np.select([diverged, euler < ROUNDOFF_DRIFT, semi > 1.0, holds],
                         ["diverged", "roundoff", "left_band", "holds"], "fails")


def ordering_is_judged(system_name: str, integrators) -> bool:
    """The ordering is a claim about the chapter's three on a motion that comes back (orbit, spring)."""
    build = SYSTEMS.get(system_name)
    return build is not None and build.returns and set(CHAPTER_INTEGRATORS) <= set(integrators)


def did_not_move(positions: np.ndarray, velocities: np.ndarray) -> bool:
    """True if the last state is the first to within one rounding step of the state's size (dt too small)."""
    start = np.concatenate([positions[0].ravel(), velocities[0].ravel()])
    change = np.concatenate([(positions[-1] - positions[0]).ravel(), (velocities[-1] - velocities[0]).ravel()])
    return bool(np.all(np.abs(change) <= np.spacing(np.max(np.abs(start)))))


# --- report ---


def build_metrics(system_name: str, dt: float, steps: int, seed: int, drifts: dict,
                  damping: float | None = None, solution: dict | None = None, ensemble: dict | None = None) -> dict:
    """The metrics.json payload: no wall-clock, nothing machine-dependent. A damped system adds its damping and
    "solution" (each integrator against the closed form); an --ensemble run adds its "ensemble" block."""
    metrics = {"system": system_name, "dt": dt, "steps": steps, "seed": seed, "drift": rounded(drifts)}
    if solution is not None:
        metrics.update(damping=damping, solution=rounded(solution))
    if ensemble is not None:
        metrics["ensemble"] = rounded(ensemble)
    return metrics


def print_report(system_name: str, dt: float, steps: int, drifts: dict) -> None:
    print(f"integrated {system_name} for {steps} steps of {dt} s -> {sim_time(steps * dt)} s of sim time")
    w = max(14, *(len(name) + 2 for name in drifts))  # the names' column: 14, or wider for a longer name
    print(f"{'integrator':<{w}}{'E0':>12}{'E_final':>14}{'rel_final':>14}{'rel_max':>14}")
    for name, d in drifts.items():
        if d["diverged"]:
            print(f"{name:<{w}}{cell(d['e0'], 12)}  diverged: energy error non-finite from step"
                  f" {d['diverged_at_step']:,}")
        else:
            print(f"{name:<{w}}{cell(d['e0'], 12)}{cell(d['e_final'], 14)}"
                  f"{d['rel_final']:>+14.4e}{d['rel_max']:>14.4e}")
    if ordering_is_judged(system_name, drifts):  # the headline, stated as an ordering so it holds for any seed
        print(f"{ORDERING}: {verdict_line(drifts)}")


def verdict_line(drifts: dict) -> str:
    """What the report says of judge_ordering()'s verdict on one run."""
    verdict = str(judge_ordering(drifts))
    if verdict == "diverged":
        diverged = [name for name in CHAPTER_INTEGRATORS if drifts[name]["diverged"]]
        return f"cannot judge, {' and '.join(diverged)} diverged (try a smaller --dt)"
    if verdict == "roundoff":
        return "cannot judge, every drift is round-off (more --steps or a larger --dt)"
    if verdict == "left_band":
        return (f"cannot judge, semi_implicit left its band (rel_max {drifts['semi_implicit']['rel_max']:.3g};"
                " try a smaller --dt)")
    return "as expected" if verdict == "holds" else "UNEXPECTED: investigate"


# --- the run: flags and main ---

MAX_SEED = 2**64 - 1  # any seed numpy takes would do; past 4,300 digits Python cannot even print one
MAX_DAMPING = 1e6  # N s/m: dt b/m = 10,000, the map's last column; from ~7e8 the recording's exact velocity overflows


def parse_args(argv=None) -> argparse.Namespace:
    parser = OneLineParser(prog="engine.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seed", type=int_in(0, MAX_SEED, "--seed"), default=0,
                        help="seeds the one jittered initial condition per system (default 0)")
    parser.add_argument("--system", type=name_arg, choices=[*SYSTEMS, *DAMPED_SYSTEMS], default="orbit",
                        help="which system to integrate; damped_spring is the one that is not conservative"
                             " (default orbit)")
    parser.add_argument("--integrator", type=name_arg, choices=["all", *INTEGRATORS], default="all",
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
    parser.add_argument("--ensemble", type=ensemble_size, default=None, metavar="N",
                        help="also run seeds --seed .. --seed+N-1 together and report the spread, N as large as"
                             " fits in 1 GB (a larger one is refused and told how many fit; default off)")
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
    needs = getattr(INTEGRATORS.get(args.integrator), "needs", None)  # implicit needs the force's dforce_dv
    if needs and needs not in build_system(args.system, np.random.default_rng(0)):
        parser.error(f"argument --integrator: {args.integrator} needs a velocity-dependent force ({needs}), which"
                     f" --system {args.system} does not have: try --system {' or '.join(DAMPED_SYSTEMS)}")
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
    if args.ensemble:
        from engine_ensembles import ensemble_problem  # the extension loads only when its flag asks

        problem = ensemble_problem(steps, args.ensemble)
        if problem:
            parser.error(f"argument --ensemble: {problem}")
    problem = args.rerun and rerun_problem()
    if problem:
        parser.error(problem)
    return args


def ensemble_size(text: str) -> int:
    """--ensemble's type, called only when the flag is given: the extension that knows its limit loads then."""
    from engine_ensembles import ensemble_most_members

    return int_in(1, ensemble_most_members(1), "--ensemble")(text)


@one_line_failures("engine.py", memory_hint="fewer --steps need less")  # Ctrl-C 130, SIGTERM 143, OS errors: one line
@np.errstate(all="ignore")  # past a blow-up, inf and NaN are carried on and the report names them: no warnings
def main(argv=None) -> int:
    started = time.perf_counter()  # the wall-clock line counts everything main() does, rerun's import included
    args = parse_args(argv)
    banner("ch3.3-engine", device=args.device)
    steps = SMOKE_STEPS if args.smoke else args.steps
    if args.ensemble:  # seeds --seed .. --seed+N-1 stepped together: the extension keeps and reports them
        import engine_ensembles

        return engine_ensembles.main(args, steps, started)
    system = build_system(args.system, np.random.default_rng(args.seed), args.damping)
    integrators = integrators_for(system)
    names = list(integrators) if args.integrator == "all" else [args.integrator]
    every = math.ceil((steps + 1) / MAX_POINTS_PER_SERIES)  # states kept for the recording; energy: every step
    show_progress = not args.smoke and steps * len(names) >= PROGRESS_FROM
    runs, drifts = {}, {}
    for name in names:
        progress = progress_printer(name, steps) if show_progress else None
        runs[name] = simulate(integrators[name], system, args.dt, steps, every, progress)
        drifts[name] = drift_with_final_position(runs[name])
    solution = None
    if args.system in DAMPED_SYSTEMS:  # a damped system: the closed-form solution is its referee
        from engine_damping import against_exact, print_damped_report

        solution = {name: against_exact(system, *runs[name], kept_steps(steps, every), args.dt) for name in names}
    metrics = build_metrics(args.system, args.dt, steps, args.seed, drifts, system.get("b"), solution)
    write_outputs(args, system, runs, kept_steps(steps, every), metrics)
    if solution:
        print_damped_report(system, args.dt, steps, drifts, solution)
    else:
        print_report(args.system, args.dt, steps, drifts)
    finish(args, runs, steps, started)
    return 0


def drift_with_final_position(run: tuple) -> dict:
    """energy_drift() of one run, plus where its body ended (None for a coordinate that blew up)."""
    positions, _, energies = run
    drift = energy_drift(energies)
    drift["final_pos"] = [round(x, 6) if math.isfinite(x) else None for x in positions[-1].tolist()]
    return drift


def write_outputs(args, system: dict, runs: dict, kept, metrics: dict, ensemble: dict | None = None) -> None:
    """metrics.json and, unless --no-rerun, engine.rrd, written together (metrics.json last)."""
    metrics["run_id"] = content_id(metrics_text(metrics))  # same flags, same id; engine.rrd carries it too
    files, args.recording_note = {}, None
    if args.rerun:
        from engine_recording import record  # Rerun loads only when a recording is asked for

        files[RECORDING_FILE], args.recording_note = record(system, runs, kept, args.dt, metrics["run_id"], ensemble)
    files[METRICS_FILE] = metrics_text(metrics)
    write_run(args.out, files)  # all on disk before any replaces its old file; metrics.json last


def finish(args, runs: dict, steps: int, started: float) -> None:
    """The lines after the report: a dt too small to move anything, where the files are, the wall clock."""
    if all(did_not_move(positions, velocities) for positions, velocities, _ in runs.values()):
        print(f"engine.py: warning: --dt {args.dt} is too small to move the state: after {steps:,} steps no position "
              "or velocity changed by even one rounding step, so the drifts above measure nothing", file=sys.stderr)
    metrics_path, recording_path = args.out / METRICS_FILE, args.out / RECORDING_FILE
    print(f"metrics: {metrics_path}")
    if args.rerun:
        print(f"recording: {recording_path} (open it with: rerun {recording_path})")
        if args.recording_note:
            print(args.recording_note)
    elif recording_path.exists():
        print(f"note: {recording_path} is from an earlier run (this one wrote no recording)")
    wall_clock(started)


if __name__ == "__main__":
    sys.modules.setdefault("engine", sys.modules["__main__"])  # the extensions' `import engine` is this run
    sys.exit(main())
