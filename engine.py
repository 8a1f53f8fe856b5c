"""Chapter 3.3: the inside of mj_step, without contacts, in plain numpy.

A state (q, v, m), a force law and three integrators (explicit Euler, semi-implicit
Euler, RK4), run on three conservative systems. Energy is the referee: a perfect
integrator would hold it constant, so how far each one drifts, and in which shape,
is what we measure. Beyond the chapter, a damped spring: its referee is its exact
solution, and a fourth step, implicit in the damping as MuJoCo's Euler is, joins in.

Run it from the repo root:

    python engine.py                       # Kepler orbit, all three integrators, with a recording
    python engine.py --system freefall     # a motion that never comes back
    python engine.py --smoke --no-rerun    # fixed 600 steps: what CI diffs byte for byte
    python engine.py --ensemble 1000       # seeds 0..999 stepped together: does the ordering always hold?
    python engine.py --system damped_spring --damping 250   # exercise 6's stiff damper: predict it first

Open the recording with `rerun outputs/ch3.3-engine/engine.rrd`.
"""

import sys

from curriculum.common.interrupts import guard

guard("engine.py")  # from here on, Ctrl-C or SIGTERM ends in one line (exit 130 or 143), never a traceback

import argparse  # imports come below the guard on purpose: numpy takes a moment to load
import functools
import math
import time
from pathlib import Path

import numpy as np

import engine_damping  # beyond the chapter, a damper: registered below the chapter's integrators
import engine_ensembles as ensembles  # --ensemble N: many seeds as one batch
import engine_recording  # all of Rerun, which it loads only to record
import engine_registry as registry  # the declarations: the facts each system and integrator states
from curriculum.common.cli import OneLineParser, int_in, name_arg, positive_finite, progress_printer, recording_wanted
from curriculum.common.device import banner, wall_clock
from curriculum.common.outputs import folder_problem, one_line_failures
from curriculum.common.report import cell, rounded, sim_time, where_written, write_outputs
from curriculum.common.viewer import rerun_problem
from engine_referee import did_not_move, dot3, kepler_orbit, overflow_step, relative_energy_error, times_for
from engine_registry import INTEGRATORS, SYSTEMS, build_system, integrator, integrators_for, system

# --- settings ---

DEFAULT_STEPS = 2000  # the chapter's run: 20 s of sim time at dt 0.01
SMOKE_STEPS = 600  # fixed, so two smoke runs can be diffed byte for byte
METRICS_FILE, RECORDING_FILE = "metrics.json", "engine.rrd"


# --- systems ---
# A system is the physics: where the body starts (q0, v0), its mass m, the force law
# force(q, v), and the true total energy(q, v), which a perfect integrator holds constant.
# @system declares one with the facts the run and the tests read (engine_registry.py); the
# seed jitters one number of the start, so --seed matters and the drift ordering does not.
#
# The batch contract, which simulate() checks: q and v are one body's position and velocity,
# shape (3,), or N independent bodies stepped together, (N, 3). force(q, v) returns q's shape;
# energy(q, v) one number per body, q.shape[:-1]. Three components let a planar orbit draw as
# a curve in 3D, and chapter 3.4 adds a constraint force to this same force, nothing else.
#
# Determinism: `@`, np.dot and np.linalg.norm hand small vectors to BLAS, and `**` calls
# libm's pow; both round differently on different CPUs. So the physics squares, adds and
# cubes with plain arithmetic (dot3, r * r * r), which IEEE rounds the same everywhere.

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

    def exact(q0, v0, t):  # where a body starting at (q0, v0) is at times t: Kepler's equation
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


# --- integrators ---
# Each takes the state (q, v) and returns it one timestep dt later. They differ only in where
# they look at the velocity and the force, and that is the whole lesson. @integrator declares
# what the tests check of each: its order, and its force evaluations per step.

@integrator("euler", order=1, force_evaluations=1)
def euler_step(q, v, m, force, dt):
    """Explicit (forward) Euler: everything from the old state.

    q += dt * v_old;  v += dt * a_old.
    Not symplectic; order 1; 1 force evaluation per step.
    What its energy does over a long run: exercise 1. How its error shrinks with dt: exercise 3.
    """
    a = force(q, v) / m
    return q + dt * v, v + dt * a  # the position moves with the OLD velocity


@integrator("semi_implicit", order=1, force_evaluations=1, symplectic=True)
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


# Beyond the chapter, in engine_damping.py: a damped spring, and a step implicit in the damping.
system("damped_spring", potential=False, velocity_free=False, damped=True)(engine_damping.damped_spring)
integrator("implicit", order=1, force_evaluations=1, chapter=False, needs=["dforce_dv"])(engine_damping.implicit_step)
CHAPTER_INTEGRATORS = tuple(name for name, step in INTEGRATORS.items() if step.chapter)  # euler, semi_implicit, rk4


# --- simulate and measure ---


def simulate(step_fn, system: dict, dt: float, steps: int):
    """Integrate `system` for `steps` steps of `dt`. Returns (positions, velocities, energies) of every state,
    row 0 the start: (steps + 1, 3) and (steps + 1,), or (steps + 1, N, 3) and (steps + 1, N) for a batch.
    A state that blows up is carried on as inf/NaN without warnings. energy_drift() says at which step the energy
    overflowed, which can come well before the state itself does: the energy squares it."""
    q = np.array(system["q0"], dtype=float)
    v = np.array(system["v0"], dtype=float)
    m, force, energy = system["m"], system["force"], system["energy"]
    registry.check_contract(system, q, v)
    positions = np.empty((steps + 1, *q.shape))
    velocities = np.empty_like(positions)
    positions[0], velocities[0] = q, v
    with np.errstate(all="ignore"):
        for i in range(steps):
            q, v = step_fn(q, v, m, force, dt)
            positions[i + 1], velocities[i + 1] = q, v
        # The referee, once over every state: a run's states are a batch like any other (see the contract).
        energies = energy(positions.reshape(-1, 3), velocities.reshape(-1, 3)).reshape(positions.shape[:-1])
    return positions, velocities, energies


def energy_drift(energies: np.ndarray) -> dict:
    """Energy error relative to the start: the numbers the chapter is about.

    rel_final: signed drift at the last step (explicit Euler: large and positive).
    rel_max: worst absolute excursion anywhere (how it behaves as the run grows: exercise 1).
    If the run blew up (its energy overflowed), the figures are None and energy_overflow_step says at which step.
    """
    relative = relative_energy_error(energies)  # (E - E0) / |E0|, engine_referee's one formula
    overflow, e0 = overflow_step(energies), float(energies[0])  # the one "blew up at step N", or None
    if overflow is not None:
        return {"e0": e0, "e_final": None, "rel_final": None, "rel_max": None,
                "diverged": True, "energy_overflow_step": overflow}
    return {"e0": e0, "e_final": float(energies[-1]), "rel_final": float(relative[-1]),
            "rel_max": float(np.max(np.abs(relative))), "diverged": False, "energy_overflow_step": None}


ORDERING = "energy drift ordering euler >> semi_implicit > rk4"  # |euler final| > semi max > rk4 max, per run
ROUNDOFF_DRIFT = 1e-12  # explicit Euler drifting less than this: every drift is round-off, nothing to judge


def judge_ordering(drifts: dict):
    """The chapter's claim, |euler rel_final| > semi_implicit rel_max > rk4 rel_max, judged run by run, for one
    run (numbers; None where one diverged) or an ensemble (arrays of N; NaN where a member diverged). For each
    run "holds", "fails", or why it cannot be judged: "diverged", "roundoff" (every drift is round-off: too few
    steps or too small a dt) or "left_band" (semi-implicit's error passed 100%: no band left to hold)."""
    euler = np.abs(np.asarray(drifts["euler"]["rel_final"], dtype=float))
    semi, rk4 = (np.asarray(drifts[name]["rel_max"], dtype=float) for name in ("semi_implicit", "rk4"))
    diverged = np.any([drifts[name]["diverged"] for name in ("euler", "semi_implicit", "rk4")], axis=0)
    with np.errstate(invalid="ignore"):
        holds = (euler > semi) & (semi > rk4)
        return np.select([diverged, euler < ROUNDOFF_DRIFT, semi > 1.0, holds],
                         ["diverged", "roundoff", "left_band", "holds"], "fails")


def ordering_is_judged(system_name: str, integrators) -> bool:
    """The ordering is a claim about the chapter's three on a motion that returns under a potential (orbit, spring)."""
    facts = SYSTEMS[system_name].facts if system_name in SYSTEMS else {}
    return bool(facts.get("returns") and facts.get("potential")) and set(CHAPTER_INTEGRATORS) <= set(integrators)


# --- report ---


def print_report(system_name: str, dt: float, steps: int, drifts: dict) -> None:
    print(f"integrated {system_name} for {steps} steps of {dt} s -> {sim_time(steps * dt)} s of sim time")
    w = max(14, *(len(name) + 2 for name in drifts))  # the names' column: 14, or wider for a longer name
    print(f"{'integrator':<{w}}{'E0':>12}{'E_final':>14}{'rel_final':>14}{'rel_max':>14}")
    for name, d in drifts.items():
        if d["diverged"]:
            print(f"{name:<{w}}{cell(d['e0'], 12)}  diverged: energy overflowed at step {d['energy_overflow_step']:,}")
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


def build_metrics(system_name, dt, steps, seed, drifts, damping=None, solution=None, ensemble=None) -> dict:
    """The metrics.json payload: no wall-clock, nothing machine-dependent. A damped system adds its damping and
    "solution" (each integrator against the closed form); an --ensemble run adds its "ensemble" block."""
    metrics = {"system": system_name, "dt": dt, "steps": steps, "seed": seed, "drift": rounded(drifts)}
    if solution is not None:
        metrics.update(damping=damping, solution=rounded(solution))
    if ensemble is not None:
        metrics["ensemble"] = rounded(ensemble)
    return metrics


# --- the run: long runs in pieces, and what main() keeps of them ---

MAX_POINTS_PER_SERIES = 100_000  # past this the kept states (and the recording) thin to every k-th step
PIECE_VALUES = 2_000_000  # numbers per piece of states simulate_long() holds at once: 16 MB an array


def simulate_long(step_fn, system: dict, dt: float, steps: int, every: int = 1, progress=None):
    """simulate() in pieces of at most PIECE_VALUES numbers, each starting where the last one ended, so a long run
    or a large batch holds little: the same states, bit for bit, but only those at kept_steps(steps, every), and
    the energy of every step. progress(done), if given, is called after each piece, a twentieth of the run at most."""
    kept, q0 = kept_steps(steps, every), np.asarray(system["q0"])
    positions, velocities = np.empty((len(kept), *q0.shape)), np.empty((len(kept), *q0.shape))
    energies = np.empty((steps + 1, *q0.shape[:-1]))
    piece, start = max(1, min(PIECE_VALUES // q0.size, math.ceil(steps / 20) if progress else steps)), system
    for first in range(0, steps, piece):
        count = min(piece, steps - first)
        states, speeds, energies[first:first + count + 1] = simulate(step_fn, start, dt, count)
        here = (kept >= first) & (kept <= first + count)  # the kept steps inside this piece
        positions[here], velocities[here] = states[kept[here] - first], speeds[kept[here] - first]
        start = {**system, "q0": states[-1], "v0": speeds[-1]}
        if progress:
            progress(first + count)
    return positions, velocities, energies


def kept_steps(steps: int, every: int = 1) -> np.ndarray:
    """The step numbers simulate_long() keeps states for: 0, every, 2 every, ... and the last."""
    kept = np.arange(0, steps + 1, every)
    return kept if kept[-1] == steps else np.append(kept, steps)


def drift_with_final_position(run: tuple) -> dict:
    """energy_drift() of one run, plus where its body ended (None for a coordinate that blew up)."""
    final = [round(x, 6) if math.isfinite(x) else None for x in run[0][-1].tolist()]
    return {**energy_drift(run[2]), "final_pos": final}


# --- flags and main ---

MAX_STEPS = 10_000_000  # energies of every step stay in memory: 80 MB per integrator at the cap
MAX_SEED = 2**64 - 1  # any seed numpy takes would do; past 4,300 digits Python cannot even print one
PROGRESS_FROM = 300_000  # integrator-steps in a run before progress goes to stderr


def parse_args(argv=None) -> argparse.Namespace:
    parser = OneLineParser(prog="engine.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seed", type=int_in(0, MAX_SEED, "--seed"), default=0,
                        help="seeds the one jittered initial condition per system (default 0)")
    parser.add_argument("--system", type=name_arg, choices=list(SYSTEMS), default="orbit",
                        help="which system to integrate; damped_spring is the one that is not conservative"
                             " (default orbit)")
    parser.add_argument("--integrator", type=name_arg, choices=["all", *INTEGRATORS], default="all",
                        help="'all' runs the three-way comparison, which is the point; on damped_spring it"
                             " adds implicit, the damping taken at the new velocity (default all)")
    parser.add_argument("--damping", type=positive_finite("--damping", engine_damping.MAX_DAMPING), default=None,
                        help=f"damped_spring's b in N s/m (default {engine_damping.DAMPING}); exercise 6 asks what"
                             " 250 does at dt 0.01")
    parser.add_argument("--dt", type=positive_finite("the timestep --dt"), default=0.01,
                        help="timestep in sim seconds, positive, short enough that --steps of it fit in a float"
                             " (default 0.01); raise it and every drift grows except round-off (RK4's on the freefall)")
    parser.add_argument("--steps", type=int_in(1, MAX_STEPS, "--steps"), default=None,
                        help=f"steps per integrator, 1 to {MAX_STEPS:,} (default {DEFAULT_STEPS:,})")
    parser.add_argument("--smoke", action="store_true",
                        help=f"fixed {SMOKE_STEPS}-step run for CI; two runs write identical {METRICS_FILE}")
    parser.add_argument("--ensemble", type=ensembles.ensemble_size, default=None, metavar="N",
                        help="also run seeds --seed .. --seed+N-1 together and report the spread, N as large as"
                             " fits in 1 GB (a larger one is refused and told how many fit; default off)")
    parser.add_argument("--device", choices=["cpu"], default="cpu",
                        help="pure numpy runs on the CPU; the flag is there for the course's banner")
    parser.add_argument("--out", type=Path, default=Path("outputs/ch3.3-engine"),
                        help=f"folder for {METRICS_FILE} and {RECORDING_FILE} (default outputs/ch3.3-engine)")
    parser.add_argument("--rerun", dest="rerun", action="store_true", default=True,
                        help=f"write the {RECORDING_FILE} recording (the default)")
    parser.add_argument("--no-rerun", dest="rerun", action="store_false",
                        help="skip the recording; rerun is then never imported")
    args = parser.parse_args(argv)
    args.rerun = recording_wanted("engine.py", args.rerun)  # not under RERUN=off, Rerun's own switch (a CI may set it)
    problem = registry.flag_problem(args.system, args.integrator, args.damping, args.ensemble)
    if problem:
        parser.error(problem)
    if args.smoke and args.steps is not None:
        parser.error(f"argument --steps: --smoke always runs {SMOKE_STEPS} steps (so two smoke runs can be diffed);"
                     " drop one of the two")
    problem = folder_problem(args.out, [METRICS_FILE, RECORDING_FILE] if args.rerun else [METRICS_FILE])
    if problem:
        parser.error(f"argument --out: {problem}")
    args.steps = SMOKE_STEPS if args.smoke else args.steps or DEFAULT_STEPS
    if not math.isfinite(args.dt * (args.steps + 1)):  # the times every truth and the recording are evaluated at
        parser.error(f"argument --dt: {args.steps:,} steps of {args.dt:g} s is more time than a float can hold"
                     f" ({sys.float_info.max:.3g} s): a smaller --dt or fewer --steps")
    problem = args.ensemble and ensembles.ensemble_problem(args.steps, args.ensemble)
    if problem:
        parser.error(f"argument --ensemble: {problem}")
    problem = args.rerun and rerun_problem()
    if problem:
        parser.error(problem)
    return args


@one_line_failures("engine.py", memory_hint="fewer --steps need less")  # Ctrl-C 130, SIGTERM 143, OS errors: one line
@np.errstate(all="ignore")  # past a blow-up, inf and NaN are carried on and the report names them: no warnings
def main(argv=None) -> int:
    started = time.perf_counter()  # the wall-clock line counts everything main() does, rerun's import included
    args = parse_args(argv)
    banner("ch3.3-engine", device=args.device)
    steps, seeds, build = args.steps, range(args.seed, args.seed + (args.ensemble or 1)), None
    if args.ensemble:  # seeds --seed .. --seed+N-1 stepped together as one batch; member 0 is the single run
        build = functools.partial(build_system, args.system)
        system, ensemble = ensembles.build_ensemble(build, seeds), {}
    else:
        system, ensemble = build_system(args.system, np.random.default_rng(args.seed), args.damping), None
    integrators = integrators_for(system)
    names = list(integrators) if args.integrator == "all" else [args.integrator]
    every = max(math.ceil((steps + 1) / MAX_POINTS_PER_SERIES), ensembles.ensemble_every(steps, len(seeds)))
    kept = kept_steps(steps, every)  # the states kept for the recording; energies are kept at every step
    # a member's step in a batch costs a hundredth of a single run's or less, hence the 100
    show_progress = not args.smoke and steps * len(names) * (len(seeds) / 100 if args.ensemble else 1) >= PROGRESS_FROM
    runs, drifts = {}, {}
    for name in names:
        progress = progress_printer(name, steps) if show_progress else None
        runs[name] = simulate_long(integrators[name], system, args.dt, steps, every, progress)
        if args.ensemble:  # what is kept of every member; then member 0, the single run, goes on as the run
            ensemble[name], runs[name] = ensembles.summarize(runs[name], kept, args.rerun)
        drifts[name] = drift_with_final_position(runs[name])
    solution = None
    if system["damped"]:  # a damped system: the closed-form solution is its referee
        solution = {name: engine_damping.against_exact(system, *runs[name], kept, args.dt) for name in names}
    block = None
    if args.ensemble:  # the spread of the members' drifts, and for how many of them the ordering holds
        block = ensembles.ensemble_block(seeds, ensemble, ordering_is_judged(args.system, ensemble) and judge_ordering)
    metrics = build_metrics(args.system, args.dt, steps, args.seed, drifts, system.get("b"), solution, block)
    record = functools.partial(engine_recording.record, system, runs, kept, args.dt, ensemble=ensemble)
    note = write_outputs(args.out, metrics, METRICS_FILE, (RECORDING_FILE, record) if args.rerun else None)
    if solution:
        engine_damping.print_damped_report(system, args.dt, steps, drifts, solution)
    else:
        print_report(args.system, args.dt, steps, drifts)
    if args.ensemble:
        ensembles.print_ensemble_report(args.system, seeds, block, ORDERING, build)
    if all(did_not_move(positions, velocities) for positions, velocities, _ in runs.values()):
        print(f"engine.py: warning: --dt {args.dt} is too small to move the state: after {steps:,} steps no position "
              "or velocity changed by even one rounding step, so the drifts above measure nothing", file=sys.stderr)
    where_written(args.out, METRICS_FILE, RECORDING_FILE, args.rerun, note)
    wall_clock(started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
