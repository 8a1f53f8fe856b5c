"""Chapter 3.3: the inside of mj_step, without contacts, in plain numpy.

A state (q, v, m), a force law and three integrators (explicit Euler, semi-implicit
Euler, RK4), run on three conservative systems. Energy is the referee: a perfect
integrator would hold it constant, so how far each one drifts is what we measure.

Run it from the repo root:

    python engine.py                       # Kepler orbit, all three integrators, with a recording
    python engine.py --system freefall     # the case where the symplectic advantage vanishes
    python engine.py --smoke --no-rerun    # fixed 600 steps: what CI diffs byte for byte

Open the recording with `rerun outputs/ch3.3-engine/engine.rrd`.
"""

import argparse
import importlib.util
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from curriculum.common import banner

# --- settings and flags ---

SMOKE_STEPS = 600  # fixed, so two smoke runs can be diffed byte for byte
MAX_STEPS = 10_000_000  # ~170 bytes of history per step for 3 integrators: about 1.7 GB at the cap
PROGRESS_FROM = 300_000  # integrator-steps in a run before progress goes to stderr
MAX_POINTS_PER_SERIES = 100_000  # past this the recording keeps every k-th step
APPLICATION_ID = "zero2robot-ch3_3-engine"  # rerun 0.41 ids: letters, digits, '_' and '-'


class _OneLineParser(argparse.ArgumentParser):
    """Bad input gets one line naming the problem, not a usage block."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def _timestep(text: str) -> float:
    try:
        dt = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(dt) and dt > 0.0):
        raise argparse.ArgumentTypeError(f"the timestep must be a positive, finite number of seconds, got {text}")
    return dt


def _int_in(low: int, high: int | None, what: str):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if value < low or (high is not None and value > high):
            bound = f"from {low:,} to {high:,}" if high is not None else f"{low} or more"
            raise argparse.ArgumentTypeError(f"{what} must be {bound}, got {value:,}")
        return value

    return parse


def _unwritable_reason(out: Path) -> str | None:
    """Why --out cannot hold our files, or None if it can. Creates nothing."""
    if out.exists():
        return None if out.is_dir() and os.access(out, os.W_OK | os.X_OK) else f"{out} is not a writable directory"
    parent = out.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        return f"{out} cannot be created: {parent} is not a writable directory"
    return None


def parse_args(argv=None) -> argparse.Namespace:
    parser = _OneLineParser(prog="engine.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seed", type=_int_in(0, None, "--seed"), default=0,
                        help="seeds the one jittered initial condition per system (default 0)")
    parser.add_argument("--system", choices=["orbit", "spring", "freefall"], default="orbit",
                        help="which conservative system to integrate (default orbit)")
    parser.add_argument("--integrator", choices=["all", "euler", "semi_implicit", "rk4"], default="all",
                        help="'all' runs the three-way comparison, which is the point (default all)")
    parser.add_argument("--dt", type=_timestep, default=0.01,
                        help="timestep in sim seconds; raise it and every drift grows (default 0.01)")
    parser.add_argument("--steps", type=_int_in(1, MAX_STEPS, "--steps"), default=2000,
                        help=f"steps per integrator, 1 to {MAX_STEPS:,} (history is kept in memory; default 2000)")
    parser.add_argument("--smoke", action="store_true",
                        help=f"fixed {SMOKE_STEPS}-step run for CI; two runs write identical metrics.json")
    parser.add_argument("--device", choices=["cpu"], default="cpu",
                        help="pure numpy runs on the CPU; the flag is there for the course's banner")
    parser.add_argument("--out", type=Path, default=Path("outputs/ch3.3-engine"),
                        help="folder for metrics.json and engine.rrd (default outputs/ch3.3-engine)")
    parser.add_argument("--rerun", dest="rerun", action="store_true", default=True,
                        help="write the .rrd recording (the default)")
    parser.add_argument("--no-rerun", dest="rerun", action="store_false",
                        help="skip the recording; rerun is then never imported")
    args = parser.parse_args(argv)
    reason = _unwritable_reason(args.out)
    if reason:
        parser.error(f"argument --out: {reason}")
    if args.rerun and importlib.util.find_spec("rerun") is None:  # looks, does not import
        parser.error("the recording needs rerun-sdk: run `pip install -e .` first, or pass --no-rerun")
    return args


# --- systems ---
# A system is the physics: an initial state (q0, v0, m), a force law force(q, v)
# and the true total energy(q, v), which a perfect integrator holds constant.
# States are 3-vectors, so a planar orbit draws as a curve in 3D and chapter 3.4
# can add a constraint force to this same force without changing anything else.
#
# Determinism: `@`, np.dot and np.linalg.norm on small vectors go through BLAS,
# whose kernel (and so the last bit) depends on the CPU. We square and add the
# three components ourselves instead: plain IEEE arithmetic, the same on every CPU.


def dot3(a, b):
    """a . b over the last axis of length 3, in a fixed order. Works on (3,) and (N, 3)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def build_system(name: str, rng: np.random.Generator) -> dict:
    """Return {q0, v0, m, force, energy} for one of the three conservative systems.

    The seed jitters one initial condition per system (orbit speed, spring stretch,
    launch speed), so --seed matters while the ordering of the drifts does not change.
    force(q, v) takes one state; energy(q, v) takes one state or (N, 3) histories.
    """
    if name == "orbit":
        # A unit mass around a fixed attractor at the origin, inverse-square pull, GM = mu = 1.
        # Speed 1 would be a circle; the jitter makes it an ellipse, which still closes exactly.
        mu, m = 1.0, 1.0
        q0 = np.array([1.0, 0.0, 0.0])
        v0 = np.array([0.0, 1.0 + rng.uniform(-0.05, 0.05), 0.0])

        def force(q, v):
            x, y, z = q.tolist()  # plain floats: for three numbers, faster than numpy's calls
            r = math.sqrt(x * x + y * y + z * z)
            r3 = r * r * r  # not r**3: pow() comes from libm, whose last bit varies by CPU
            # Magnitude mu*m/r^2, pointing at the attractor. At r = 0 the pull is undefined:
            # NaN, so that simulate() reports the step instead of raising mid-run.
            pull = -mu * m / r3 if r3 > 0.0 else math.nan
            return np.array((x * pull, y * pull, z * pull))

        def energy(q, v):
            return 0.5 * m * dot3(v, v) - mu * m / np.sqrt(dot3(q, q))  # kinetic + gravitational

    elif name == "spring":
        # A mass on an ideal Hooke spring: pulled straight back, in proportion to the stretch.
        # Undamped, so the amplitude and the energy should stay exactly where they started.
        k, m = 4.0, 1.0  # angular frequency sqrt(k/m) = 2 rad/s
        q0 = np.array([1.0 + rng.uniform(-0.1, 0.1), 0.0, 0.0])
        v0 = np.zeros(3)

        def force(q, v):
            return q * -k  # Hooke: restoring, in proportion to the stretch

        def energy(q, v):
            return 0.5 * m * dot3(v, v) + 0.5 * k * dot3(q, q)  # kinetic + spring

    elif name == "freefall":
        # A body thrown sideways under constant gravity. Energy is conserved here too, but the
        # motion never comes back, and that is what breaks the neat story of the other two.
        g, m = 9.81, 1.0
        q0 = np.array([0.0, 0.0, 10.0])
        v0 = np.array([3.0 + rng.uniform(-0.5, 0.5), 0.0, 0.0])
        weight = np.array([0.0, 0.0, -m * g])

        def force(q, v):
            return weight.copy()

        def energy(q, v):
            return 0.5 * m * dot3(v, v) + m * g * q[..., 2]  # kinetic + height

    else:
        raise ValueError(f"unknown system {name!r}; choose orbit, spring or freefall")
    return {"q0": q0, "v0": v0, "m": m, "force": force, "energy": energy}


# --- integrators ---
# Each takes (q, v) and returns the state one timestep dt later. They differ only in
# where they look at the velocity and the force, and that is the whole lesson.
# Products are written array * scalar (`v * dt`): the same number as `dt * v`, but numpy
# answers it directly instead of after Python's float has declined, a third faster.


def euler_step(q, v, m, force, dt):
    """Explicit (forward) Euler: everything from the old state.

    q += dt * v_old;  v += dt * a_old.
    Not symplectic; order 1; 1 force evaluation per step.
    Fails on anything that oscillates: it adds energy every step, so orbits spiral out.
    """
    a = force(q, v) / m
    return q + v * dt, v + a * dt  # position moves with the OLD velocity


def semi_implicit_step(q, v, m, force, dt):
    """Semi-implicit (symplectic) Euler, velocity first: MuJoCo's default, mjINT_EULER.

    v += dt * a_old;  q += dt * v_new.
    Symplectic; order 1; 1 force evaluation per step.
    Energy wobbles in a band that does not grow; it fails where motion never returns (freefall).
    """
    a = force(q, v) / m
    v_next = v + a * dt
    q_next = q + v_next * dt  # the NEW velocity moves the position: one line, the whole trick
    return q_next, v_next


def rk4_step(q, v, m, force, dt):
    """Classical Runge-Kutta 4 on (q, v)' = (v, force(q, v) / m).

    Four slopes (start, midpoint twice, end), blended 1-2-2-1.
    Not symplectic; order 4; 4 force evaluations per step.
    Tiny error per step, but it creeps one way and is never pulled back over long runs.
    """
    # kNq is the slope of q at stage N, which is just the velocity there; kNv is the acceleration.
    k1q, k1v = v, force(q, v) / m
    k2q = v + k1v * (0.5 * dt)
    k2v = force(q + k1q * (0.5 * dt), k2q) / m
    k3q = v + k2v * (0.5 * dt)
    k3v = force(q + k2q * (0.5 * dt), k3q) / m
    k4q = v + k3v * dt
    k4v = force(q + k3q * dt, k4q) / m
    q_next = q + (k1q + (k2q + k3q) * 2.0 + k4q) * (dt / 6.0)  # weights 1-2-2-1, over 6
    v_next = v + (k1v + (k2v + k3v) * 2.0 + k4v) * (dt / 6.0)
    return q_next, v_next


INTEGRATORS = {"euler": euler_step, "semi_implicit": semi_implicit_step, "rk4": rk4_step}
COLORS = {"euler": [217, 76, 64], "semi_implicit": [76, 175, 80], "rk4": [64, 115, 217]}


# --- simulate and measure ---


def simulate(step_fn, system: dict, dt: float, steps: int, progress=None):
    """Integrate `system` for `steps` steps. Returns (trajectory, energies).

    trajectory: (steps + 1, 3) positions; energies: (steps + 1,) total energy, row 0 the start.
    The loop only steps and stores; energy is computed once afterwards, over the whole
    history at once. A state that blows up is carried on as inf/NaN without warnings;
    energy_drift() reports the step where that began. progress(done), if given, is called ~20 times.
    """
    q = system["q0"].astype(float)
    v = system["v0"].astype(float)
    m, force = system["m"], system["force"]
    positions = np.empty((steps + 1, 3))
    velocities = np.empty((steps + 1, 3))
    positions[0], velocities[0] = q, v
    block = max(steps // 20, 1) if progress else steps  # report ~20 times, between blocks
    with np.errstate(all="ignore"):
        for start in range(1, steps + 1, block):
            for i in range(start, min(start + block, steps + 1)):
                q, v = step_fn(q, v, m, force, dt)
                positions[i], velocities[i] = q, v
            if progress:
                progress(i)
        energies = system["energy"](positions, velocities)
    return positions, energies


def energy_drift(energies: np.ndarray) -> dict:
    """Energy error relative to the start: the numbers the chapter is about.

    rel_final: signed drift at the last step (explicit Euler: large and positive).
    rel_max: worst absolute excursion anywhere (bounded for semi-implicit, growing for Euler).
    If the energy overflowed or went NaN, the figures are None and diverged_at_step says when.
    """
    e0 = float(energies[0])
    finite = np.isfinite(energies)
    if not finite.all():
        return {"e0": e0, "e_final": None, "rel_final": None, "rel_max": None,
                "diverged": True, "diverged_at_step": int(np.argmin(finite))}
    scale = abs(e0) if e0 != 0.0 else 1.0
    return {
        "e0": e0,
        "e_final": float(energies[-1]),
        "rel_final": float((energies[-1] - e0) / scale),
        "rel_max": float(np.max(np.abs(energies - e0)) / scale),
        "diverged": False,
        "diverged_at_step": None,
    }


# --- record ---
# All of Rerun lives here, imported only when a recording is asked for, so the physics
# and the tests run without it. The file opens on three things: the paths in 3D, and
# beside them one plot where the integrators' energy errors overlay (raw energy in a tab).


def record(path: Path, system_name: str, runs: dict) -> str | None:
    """Write runs {name: (trajectory, energies)} to `path`. Returns a note if decimated."""
    import rerun as rr
    import rerun.blueprint as rrb

    steps = len(next(iter(runs.values()))[1]) - 1
    stride = math.ceil((steps + 1) / MAX_POINTS_PER_SERIES)
    kept = np.arange(0, steps + 1, stride)
    if kept[-1] != steps:
        kept = np.append(kept, steps)  # always keep the final state

    blueprint = rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="world", name="paths"),
            rrb.Tabs(
                rrb.TimeSeriesView(origin="rel_error", name="log10 |E - E0| / |E0|"),
                rrb.TimeSeriesView(origin="energy", name="total energy E"),
                active_tab=0,
            ),
        ),
    )
    partial = path.with_name(path.name + ".partial")
    recording = rr.RecordingStream(APPLICATION_ID)
    try:
        recording.save(partial, default_blueprint=blueprint)
        if system_name == "orbit":  # the fixed attractor the orbit's ellipse has at one focus
            recording.log("world/attractor", rr.Points3D([[0.0, 0.0, 0.0]], radii=[0.03]), static=True)
        for name, (trajectory, energies) in runs.items():
            log_path(rr, recording, name, trajectory[kept])
            log_energy(rr, recording, name, kept, energies[kept])
            log_relative_error(rr, recording, name, kept, energies[kept], energies[0])
        recording.flush()
        recording.disconnect()
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
    if stride == 1:
        return None
    return f"recording keeps 1 state in {stride} of {steps + 1:,} per integrator, to stay viewable (metrics use all)"


def log_path(rr, recording, name, trajectory):
    """The 3D view: the whole path as one line strip, in the integrator's colour."""
    # Rerun stores float32: a diverged path's inf/NaN, or anything past 3.4e38, cannot be drawn.
    drawable = (np.abs(trajectory) < np.finfo(np.float32).max).all(axis=1)
    line = rr.LineStrips3D([trajectory[drawable]], colors=[COLORS[name]], labels=[name])
    recording.log(f"world/{name}", line, static=True)


def log_energy(rr, recording, name, steps, energies):
    """Total energy on the `step` timeline. Euler's 22% climb flattens the others here."""
    recording.log(f"energy/{name}", rr.SeriesLines(colors=[COLORS[name]], names=[name]), static=True)
    finite = np.isfinite(energies)
    recording.send_columns(f"energy/{name}", indexes=[rr.TimeColumn("step", sequence=steps[finite])],
                           columns=rr.Scalars.columns(scalars=energies[finite]))


def log_relative_error(rr, recording, name, steps, energies, e0):
    """log10 |E - E0| / |E0|: Rerun has no log axis, so we log the exponent.

    Read it as "digits lost": Euler climbs towards 0 (100%), semi-implicit sits in a flat
    band, RK4 starts near round-off. Steps where the error is exactly zero have no log.
    """
    recording.log(f"rel_error/{name}", rr.SeriesLines(colors=[COLORS[name]], names=[name]), static=True)
    with np.errstate(all="ignore"):
        relative = np.abs(energies - e0) / (abs(e0) if e0 != 0.0 else 1.0)
        shown = np.isfinite(relative) & (relative > 0.0)
        recording.send_columns(f"rel_error/{name}", indexes=[rr.TimeColumn("step", sequence=steps[shown])],
                               columns=rr.Scalars.columns(scalars=np.log10(relative[shown])))


# --- report ---


def build_metrics(args, num_steps: int, drifts: dict) -> dict:
    """The metrics.json payload: no wall-clock, nothing machine-dependent."""
    # 12 decimals, not fewer: RK4's drift is ~1e-11 and rounding it to zero would erase it.
    rounded = {name: {key: round(value, 12) if isinstance(value, float) else value for key, value in d.items()}
               for name, d in drifts.items()}
    return {"system": args.system, "dt": args.dt, "steps": num_steps, "seed": args.seed, "drift": rounded}


def write_json_atomic(path: Path, payload: dict) -> None:
    """Write strict JSON (no NaN/Infinity) via a temp file and a rename: never half a file."""
    text = json.dumps(payload, indent=2, sort_keys=True, allow_nan=False) + "\n"
    partial = path.with_name(path.name + ".partial")
    try:
        partial.write_text(text)
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)


def print_report(args, num_steps: int, drifts: dict) -> None:
    sim_seconds = num_steps * args.dt
    shown = f"{sim_seconds:.2f}" if sim_seconds < 1e9 else f"{sim_seconds:.3g}"
    print(f"integrated {args.system} for {num_steps} steps of {args.dt} s -> {shown} s of sim time")
    print(f"{'integrator':<14}{'E0':>12}{'E_final':>14}{'rel_final':>14}{'rel_max':>14}")
    for name, d in drifts.items():
        if d["diverged"]:
            print(f"{name:<14}{d['e0']:>12.4f}  diverged: energy non-finite from step {d['diverged_at_step']:,}")
        else:
            print(f"{name:<14}{d['e0']:>12.4f}{d['e_final']:>14.4f}{d['rel_final']:>+14.4e}{d['rel_max']:>14.4e}")
    if args.integrator == "all" and args.system in ("orbit", "spring"):
        # The headline, stated as an ordering so it holds for any seed.
        diverged = [name for name, d in drifts.items() if d["diverged"]]
        if diverged:
            verdict = f"cannot judge, {' and '.join(diverged)} diverged (try a smaller --dt)"
        else:
            euler, semi, rk4 = drifts["euler"], drifts["semi_implicit"], drifts["rk4"]
            ok = abs(euler["rel_final"]) > semi["rel_max"] > rk4["rel_max"]
            verdict = "as expected" if ok else "UNEXPECTED: investigate"
        print(f"energy drift ordering euler >> semi_implicit(bounded) > rk4: {verdict}")


def _progress_printer(name: str, steps: int):
    def show(done: int) -> None:
        end = "\n" if done == steps else ""
        print(f"\r  {name:<14}{done / steps:>5.0%} of {steps:,} steps", end=end, file=sys.stderr, flush=True)

    return show


def main(argv=None) -> int:
    args = parse_args(argv)
    started = time.perf_counter()
    banner("ch3.3-engine", device=args.device)
    num_steps = SMOKE_STEPS if args.smoke else args.steps
    names = list(INTEGRATORS) if args.integrator == "all" else [args.integrator]
    system = build_system(args.system, np.random.default_rng(args.seed))  # PCG64: the only randomness
    show_progress = not args.smoke and num_steps * len(names) >= PROGRESS_FROM
    try:
        runs = {}
        for name in names:
            progress = _progress_printer(name, num_steps) if show_progress else None
            runs[name] = simulate(INTEGRATORS[name], system, args.dt, num_steps, progress)
        drifts = {name: energy_drift(energies) for name, (_, energies) in runs.items()}
        for name, (trajectory, _) in runs.items():
            drifts[name]["final_pos"] = [round(x, 6) if math.isfinite(x) else None for x in trajectory[-1].tolist()]
        args.out.mkdir(parents=True, exist_ok=True)
        note = record(args.out / "engine.rrd", args.system, runs) if args.rerun else None
        write_json_atomic(args.out / "metrics.json", build_metrics(args, num_steps, drifts))
    except KeyboardInterrupt:
        print("\ninterrupted: metrics.json and engine.rrd were left as they were", file=sys.stderr)
        return 130
    print_report(args, num_steps, drifts)
    print(f"metrics: {args.out / 'metrics.json'}")
    if args.rerun:
        print(f"recording: {args.out / 'engine.rrd'} (open it with: rerun {args.out / 'engine.rrd'})")
        if note:
            print(note)
    print(f"wall-clock: {time.perf_counter() - started:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
