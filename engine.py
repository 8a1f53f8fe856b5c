"""Chapter 3.3: the inside of mj_step, without contacts, in plain numpy.

A state (q, v, m), a force law and three integrators (explicit Euler, semi-implicit
Euler, RK4), run on three conservative systems. Energy is the referee: a perfect
integrator would hold it constant, so how far each one drifts, and in which shape,
is what we measure.

Run it from the repo root:

    python engine.py                       # Kepler orbit, all three integrators, with a recording
    python engine.py --system freefall     # the case where the symplectic advantage vanishes
    python engine.py --smoke --no-rerun    # fixed 600 steps: what CI diffs byte for byte

Open the recording with `rerun outputs/ch3.3-engine/engine.rrd`.
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from curriculum.common import (
    OneLineParser,
    banner,
    int_in,
    output_folder_problem,
    positive_finite,
    progress_printer,
    wall_clock,
    write_atomic,
)

# --- settings ---

SMOKE_STEPS = 600  # fixed, so two smoke runs can be diffed byte for byte
MAX_STEPS = 10_000_000  # energies of every step stay in memory: 80 MB per integrator at the cap
MAX_POINTS_PER_SERIES = 100_000  # past this the kept states (and the recording) thin to every k-th step
PROGRESS_FROM = 300_000  # integrator-steps in a run before progress goes to stderr
METRICS_FILE, RECORDING_FILE = "metrics.json", "engine.rrd"
APPLICATION_ID = "zero2robot-ch3_3-engine"  # rerun 0.41 ids: letters, digits, '_' and '-'


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

SYSTEMS = ("orbit", "spring", "freefall")


def dot3(a, b):
    """a . b over the last axis, summed in a fixed order: (3,) gives a number, (N, 3) gives (N,)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def build_system(name: str, rng: np.random.Generator) -> dict:
    """Return {name, q0, v0, m, force, energy, exact} for one of the three conservative systems.

    The seed jitters one initial condition per system (orbit speed, spring stretch,
    launch speed), so --seed matters while the ordering of the drifts does not change.
    """
    if name == "orbit":
        # A unit mass around a fixed attractor at the origin, inverse-square pull, GM = mu = 1.
        # Speed 1 would be a circle; the jitter makes it an ellipse, which still closes exactly.
        mu, m = 1.0, 1.0
        q0 = np.array([1.0, 0.0, 0.0])
        v0 = np.array([0.0, 1.0 + rng.uniform(-0.05, 0.05), 0.0])

        def force(q, v):
            r = np.sqrt(dot3(q, q))[..., None]  # distance to the attractor, one per body
            return -mu * m * q / (r * r * r)  # magnitude mu m / r^2, pointing at the attractor

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

        def force(q, v):
            return np.broadcast_to(m * gravity, q.shape)  # the same weight on every body

        def energy(q, v):
            return 0.5 * m * dot3(v, v) + m * g * q[..., 2]  # kinetic + height

        def exact(q0, v0, t):
            t = times_for(t, q0)
            return q0 + v0 * t + 0.5 * gravity * t * t  # the parabola

    else:
        raise ValueError(f"unknown system {name!r}; choose one of {', '.join(SYSTEMS)}")
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


def build_ensemble(name: str, seeds) -> dict:
    """One system, N bodies stepped as a batch: q0 and v0 become (N, 3), one row per seed.

    Row i starts exactly where build_system(name, default_rng(seeds[i])) does; the force
    and energy laws are the same for every member, so they are shared.
    """
    members = [build_system(name, np.random.default_rng(seed)) for seed in seeds]
    return {**members[0], "q0": np.stack([s["q0"] for s in members]), "v0": np.stack([s["v0"] for s in members])}


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
COLORS = {"euler": [217, 76, 64], "semi_implicit": [76, 175, 80], "rk4": [64, 115, 217]}


# --- simulate and measure ---


def simulate(step_fn, system: dict, dt: float, steps: int, every: int = 1, progress=None):
    """Integrate `system` for `steps` steps of `dt`. Returns (positions, velocities, energies).

    positions, velocities: the states at kept_steps(steps, every), that is every `every`-th
    step and always the last; with every=1 that is all of them, (steps + 1, 3), or
    (steps + 1, N, 3) for a batch. energies: the total energy at every step, row 0 the start.
    A state that blows up is carried on as inf/NaN without warnings, and energy_drift()
    reports the step where that began. progress(done), if given, is called ~20 times.
    """
    q = np.array(system["q0"], dtype=float)
    v = np.array(system["v0"], dtype=float)
    m, force, energy = system["m"], system["force"], system["energy"]
    check_contract(system, q, v)
    positions = np.empty((len(kept_steps(steps, every)), *q.shape))
    velocities = np.empty_like(positions)
    energies = np.empty((steps + 1, *q.shape[:-1]))
    positions[0], velocities[0], energies[0] = q, v, energy(q, v)
    row, report_every = 1, max(steps // 20, 1)
    with np.errstate(all="ignore"):
        for i in range(1, steps + 1):
            q, v = step_fn(q, v, m, force, dt)
            energies[i] = energy(q, v)
            if i % every == 0 or i == steps:
                positions[row], velocities[row] = q, v
                row += 1
            if progress and (i % report_every == 0 or i == steps):
                progress(i)
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
    return simulate(INTEGRATORS[integrator], system, dt, steps, every)


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
# All of Rerun lives here, imported only when a recording is asked for, so the physics and the tests run
# without it. Each system opens on its own lesson: RECORDED_VIEWS lists, per system, the views it needs,
# and each log_<view>() logs its data along the `step` timeline and returns that view's layout. A new
# system or view plugs in with one function and one line in the table.

LABELS = {"euler": "explicit Euler", "semi_implicit": "semi-implicit Euler", "rk4": "RK4"}
PLAYBACK_SECONDS = 20.0  # pressing play runs the whole recording in about this long, whatever its length
FLOAT32_MAX = float(np.finfo(np.float32).max)  # Rerun stores float32: inf, NaN and beyond cannot be drawn


def record(path: Path, system: dict, runs: dict, kept: np.ndarray, dt: float) -> str | None:
    """Write runs {integrator: (positions, velocities, energies)} to `path`. Returns a note if thinned.

    `kept` are the step numbers of the kept states; energies are logged at those steps too.
    """
    import rerun as rr
    import rerun.blueprint as rrb

    # The stream: created, saved to a partial file, renamed into place once complete.
    recording = rr.RecordingStream(APPLICATION_ID)
    partial = path.with_name(path.name + ".partial")
    try:
        recording.save(partial)
        views = [log_view(rr, rrb, recording, system, runs, kept, dt) for log_view in RECORDED_VIEWS[system["name"]]]
        recording.send_blueprint(layout(rrb, views, kept))
        recording.flush()
        recording.disconnect()
        partial.replace(path)
    finally:
        partial.unlink(missing_ok=True)
    steps = int(kept[-1])
    if len(kept) == steps + 1:
        return None
    every = int(kept[1] - kept[0])
    return f"recording keeps 1 state in {every} of {steps + 1:,} per integrator, to stay viewable (metrics use all)"


def layout(rrb, views, kept):
    """The first view large on the left, the others stacked on the right; the side panels folded away.

    The file opens with the time cursor on the last step (play state "following"): every body where its
    run ended, every plot whole. Pause, then play, and the viewer starts again from step 0.
    """
    first, *others = views
    story = rrb.Horizontal(first, rrb.Vertical(*others), column_shares=[3, 2]) if others else first
    return rrb.Blueprint(
        story,
        rrb.BlueprintPanel(state="hidden"),
        rrb.SelectionPanel(state="hidden"),
        rrb.TimePanel(state="collapsed", timeline="step", play_state="following",
                      fps=max(int(kept[-1]) / PLAYBACK_SECONDS, 1.0)),
    )


def drawable(points):
    """Rows whose every coordinate Rerun can draw (a diverged run's inf and NaN are left out)."""
    return (np.abs(points) < FLOAT32_MAX).all(axis=-1)


def on_steps(rr, steps):
    return [rr.TimeColumn("step", sequence=steps)]


def log_bodies(rr, recording, entity, name, points, kept, label_lift):
    """One integrator in a spatial view: its whole path as a trail, and a body that travels along it.

    Sizes are in screen points, so a body stays a visible dot and a trail a thin line at any zoom.
    """
    shown = drawable(points)
    colour = [COLORS[name]]
    trail = rr.LineStrips3D([points[shown]], colors=colour, radii=rr.components.Radius.ui_points(1.0))
    recording.log(f"{entity}/trail", trail, static=True)
    body = rr.Points3D.from_fields(colors=colour, radii=rr.components.Radius.ui_points(7.0))
    recording.log(f"{entity}/body", body, static=True)
    recording.send_columns(f"{entity}/body", indexes=on_steps(rr, kept[shown]),
                           columns=rr.Points3D.columns(positions=points[shown]))
    # The label rides with its body, lifted up or down the screen (+y) by label_lifts() below.
    lifted = points[shown] + label_lift[shown, None] * [0.0, 1.0, 0.0]
    recording.log(f"{entity}/label", rr.Points3D.from_fields(colors=colour, radii=[0.0], labels=[LABELS[name]],
                                                             show_labels=True), static=True)
    recording.send_columns(f"{entity}/label", indexes=on_steps(rr, kept[shown]),
                           columns=rr.Points3D.columns(positions=lifted))


def label_lifts(paths, gap=0.045):
    """Per step, how far to lift each integrator's label: by its body's rank in height among the bodies.

    Bodies in one place (they all start together; RK4 and semi-implicit stay close) would stack their
    labels into one unreadable blot. Ranked this way the labels keep their bodies' order and stay apart.
    """
    low, high = extent(paths.values())
    gap *= float(max(high[0] - low[0], high[1] - low[1]) or 1.0)  # a fraction of what the camera frames
    heights = np.stack([points[:, 1] for points in paths.values()], axis=1)
    rank = np.argsort(np.argsort(heights, axis=1, kind="stable"), axis=1)  # 0 = lowest body at that step
    lifts = (rank - (len(paths) - 1) / 2.0) * gap
    return {name: lifts[:, i] for i, name in enumerate(paths)}


def extent(paths):
    """The corners (low, high) of the box around every drawable point; a unit box if there are none."""
    points = np.concatenate([p[drawable(p)] for p in paths])
    if len(points) == 0:
        return np.full(3, -1.0), np.full(3, 1.0)
    return points.min(axis=0), points.max(axis=0)


def camera_above(rrb, paths, tilt):
    """A camera above the plane z = 0 that frames every drawable point of every path.

    tilt 0 looks straight down with +y up the screen (a flat plot); a small tilt shows that it is 3D.
    """
    low, high = extent(paths)
    centre = (low + high) / 2.0
    distance = 1.1 * float(max(high[0] - low[0], high[1] - low[1]) or 1.0)
    up = [0.0, 0.0, 1.0] if tilt else [0.0, 1.0, 0.0]
    return rrb.EyeControls3D(kind="Orbital", look_target=centre.tolist(), eye_up=up,
                             position=(centre + [0.0, -tilt * distance, distance]).tolist())


def log_orbit(rr, rrb, recording, system, runs, kept, dt):
    """3D, seen from above: each body circles the attractor, Euler's spiralling out, the other two together."""
    attractor = rr.Points3D([[0.0, 0.0, 0.0]], radii=rr.components.Radius.ui_points(6.0), colors=[[230, 230, 230]],
                            labels=["attractor"])
    recording.log("orbit/attractor", attractor, static=True)
    paths = {name: positions for name, (positions, _, _) in runs.items()}
    lifts = label_lifts(paths)
    for name, positions in paths.items():
        log_bodies(rr, recording, f"orbit/{name}", name, positions, kept, label_lift=lifts[name])
    return rrb.Spatial3DView(origin="orbit", name="orbit: the paths, from above",
                             eye_controls=camera_above(rrb, paths.values(), tilt=0.35),
                             line_grid=rrb.LineGrid3D(visible=True, spacing=0.5))


def log_phase_plane(rr, rrb, recording, system, runs, kept, dt):
    """x across, v_x up: a closed curve is an oscillation that keeps its energy; Euler's spirals out."""
    planes = {name: np.stack([positions[:, 0], velocities[:, 0], np.zeros(len(kept))], axis=1)
              for name, (positions, velocities, _) in runs.items()}
    lifts = label_lifts(planes)
    for name, plane in planes.items():
        log_bodies(rr, recording, f"phase/{name}", name, plane, kept, label_lift=lifts[name])
    low, high = extent(planes.values())
    log_axes(rr, recording, "phase/axes", np.maximum(-low, high)[:2] * 1.1, ("x (m)", "v_x (m/s)"))
    return rrb.Spatial3DView(origin="phase", name=f"{system['name']}: phase plane, x against v_x",
                             eye_controls=camera_above(rrb, planes.values(), tilt=0.0),
                             line_grid=rrb.LineGrid3D(visible=True, spacing=0.5))


def log_axes(rr, recording, entity, reach, names):
    """Axes through the origin out to +-reach, named at their tips, with ticks at round numbers.

    A 3D view looking straight down stands in for a 2D plot because Rerun's 2D views point y downwards.
    """
    grey = [[150, 150, 150]]
    x, y = float(reach[0]), float(reach[1])
    lines = rr.LineStrips3D([[[-x, 0, 0], [x, 0, 0]], [[0, -y, 0], [0, y, 0]]], colors=grey,
                            radii=rr.components.Radius.ui_points(1.0))
    recording.log(entity, lines, static=True)
    tips = rr.Points3D([[x, 0, 0], [0, y, 0]], radii=[0.0], colors=[[200, 200, 200]], labels=names, show_labels=True)
    recording.log(f"{entity}/names", tips, static=True)
    ticks = []
    for axis, length in enumerate((x, y)):
        unit = 10.0 ** math.floor(math.log10(length)) if length > 0.0 else 1.0  # 1 to 9 ticks each way
        for k in range(-int(length / unit), int(length / unit) + 1):
            if k:
                ticks.append([k * unit if axis == 0 else 0.0, k * unit if axis == 1 else 0.0, 0.0])
    marks = rr.Points3D(ticks, radii=rr.components.Radius.ui_points(3.0), colors=grey,
                        labels=[f"{t[0] + t[1]:g}" for t in ticks], show_labels=True)
    recording.log(f"{entity}/ticks", marks, static=True)


def log_curves(rr, recording, origin, curves, kept, widths=None):
    """One line per integrator on the `step` timeline, in its colour. Returns the finite values logged."""
    logged = []
    for name, values in curves.items():
        style = rr.SeriesLines(colors=[COLORS[name]], names=[LABELS[name]], widths=widths and [widths[name]])
        recording.log(f"{origin}/{name}", style, static=True)
        shown = np.isfinite(values)
        recording.send_columns(f"{origin}/{name}", indexes=on_steps(rr, kept[shown]),
                               columns=rr.Scalars.columns(scalars=values[shown]))
        logged.append(values[shown])
    return np.concatenate(logged)


def log_level(rr, recording, entity, label, value, kept):
    """A grey line at `value` across the whole run, to read the curves against."""
    recording.log(entity, rr.SeriesLines(colors=[[150, 150, 150]], names=[label]), static=True)
    recording.send_columns(entity, indexes=on_steps(rr, [0, int(kept[-1])]),
                           columns=rr.Scalars.columns(scalars=[value, value]))


def plot(rr, rrb, origin, name, kept, y_range, legend):
    """A time-series view that opens on the whole run, from step 0 to the last, on a fixed y range."""
    whole_run = rr.TimeRange(start=rrb.TimeRangeBoundary.absolute(seq=0),
                             end=rrb.TimeRangeBoundary.absolute(seq=int(kept[-1])))
    return rrb.TimeSeriesView(origin=origin, name=name, axis_x=rrb.TimeAxis(view_range=whole_run),
                              axis_y=rrb.ScalarAxis(range=y_range), plot_legend=rrb.PlotLegend(corner=legend),
                              interaction=rrb.PlotInteraction(tooltip_mode="All"))


def padded(values, margin=0.05):
    """(low, high) of the values with a margin, or None (the viewer's own fit) when there are none."""
    if values.size == 0:
        return None
    low, high = float(values.min()), float(values.max())
    pad = margin * ((high - low) or 1.0)
    return (low - pad, high + pad)


def log10_of(x):
    """log10 where x > 0, NaN elsewhere (exact zeros, which have no logarithm, are not drawn)."""
    with np.errstate(all="ignore"):
        return np.where(x > 0.0, np.log10(np.where(x > 0.0, x, 1.0)), np.nan)


def log_position_error(rr, rrb, recording, system, runs, kept, dt):
    """log10 |q - q_exact| in metres: RK4 sits orders of magnitude below semi-implicit Euler."""
    exact = system["exact"](system["q0"], system["v0"], kept * dt)
    curves = {}
    for name, (positions, _, _) in runs.items():
        miss = positions - exact
        with np.errstate(all="ignore"):
            curves[name] = log10_of(np.sqrt(dot3(miss, miss)))
    logged = log_curves(rr, recording, "position_error", curves, kept)
    # log10 = 0 is an error as big as the orbit itself. (Legends sort by entity name: "zero" comes last.)
    log_level(rr, recording, "position_error/zero", "1 m, the orbit's radius", 0.0, kept)
    return plot(rr, rrb, "position_error", "position error against the exact orbit: log10 |q - q_exact| (m)", kept,
                padded(np.append(logged, 0.0)), "RightBottom")


def log_energy_error(rr, rrb, recording, system, runs, kept, dt):
    """log10 |E - E0| / |E0|, digits of energy lost: Euler climbs to 0 (100%), semi-implicit stays in a band."""
    curves = {}
    for name, (_, _, energies) in runs.items():
        e0 = energies[0]
        with np.errstate(all="ignore"):
            curves[name] = log10_of(np.abs(energies[kept] - e0) / (abs(e0) or 1.0))
    logged = log_curves(rr, recording, "energy_error", curves, kept)
    log_level(rr, recording, "energy_error/zero", "100% of E0", 0.0, kept)  # log10 = 0: all of it
    return plot(rr, rrb, "energy_error", "energy error: log10 |E - E0| / |E0|", kept, padded(np.append(logged, 0.0)),
                "RightBottom")


def log_energy_change(rr, rrb, recording, system, runs, kept, dt):
    """(E - E0) / |E0| in percent, sign kept: on freefall the two Eulers miss by the same amount, opposite ways."""
    curves = {}
    for name, (_, _, energies) in runs.items():
        e0 = energies[0]
        with np.errstate(all="ignore"):
            curves[name] = (energies[kept] - e0) / (abs(e0) or 1.0) * 100.0
    logged = log_curves(rr, recording, "energy_change", curves, kept)
    reach = 1.15 * float(np.abs(logged).max(initial=0.0)) or 1.0
    return plot(rr, rrb, "energy_change", "energy change (E - E0) / |E0|, %", kept, (-reach, reach), "LeftTop")


def log_height(rr, rrb, recording, system, runs, kept, dt):
    """Height z against the step: the body falls and never comes back, so no error is ever paid back."""
    curves = {name: positions[:, 2] for name, (positions, _, _) in runs.items()}
    # The default run's heights end 2 m apart after a 2 km fall: one line to the eye. Drawn widest
    # first (the viewer draws in name order: euler, rk4, semi_implicit), all three show.
    widths = {"euler": 7.0, "rk4": 4.0, "semi_implicit": 1.5}
    logged = log_curves(rr, recording, "height", curves, kept, widths)
    ends = [heights[-1] for heights in curves.values() if np.isfinite(heights[-1])]
    apart = f": the curves end {max(ends) - min(ends):.2g} m apart" if len(ends) > 1 else ""
    return plot(rr, rrb, "height", f"height z (m){apart}", kept, padded(logged), "LeftBottom")


RECORDED_VIEWS = {  # per system, the views its lesson needs; the first one opens large on the left
    "orbit": (log_orbit, log_position_error, log_energy_error),
    "spring": (log_phase_plane, log_energy_error),
    "freefall": (log_energy_change, log_height),
}


# --- report ---


def build_metrics(system_name: str, dt: float, steps: int, seed: int, drifts: dict) -> dict:
    """The metrics.json payload: no wall-clock, nothing machine-dependent."""
    # 12 decimals, not fewer: RK4's drift is ~1e-11 and rounding it to zero would erase it.
    rounded = {name: {key: round(value, 12) if isinstance(value, float) else value for key, value in d.items()}
               for name, d in drifts.items()}
    return {"system": system_name, "dt": dt, "steps": steps, "seed": seed, "drift": rounded}


def metrics_text(metrics: dict) -> str:
    """Strict JSON (no NaN or Infinity), keys sorted, so the same run gives the same bytes."""
    return json.dumps(metrics, indent=2, sort_keys=True, allow_nan=False) + "\n"


def cell(value: float, width: int, signed: bool = False) -> str:
    """A table cell: 4 decimals where they fit, scientific notation where they would not."""
    sign = "+" if signed else ""
    text = f"{value:{sign}.4f}"
    return f"{text:>{width}}" if len(text) < width - 1 else f"{value:>{sign}{width}.4e}"


def print_report(system_name: str, dt: float, steps: int, drifts: dict) -> None:
    sim_seconds = steps * dt
    shown = f"{sim_seconds:.2f}" if sim_seconds < 1e9 else f"{sim_seconds:.3g}"
    print(f"integrated {system_name} for {steps} steps of {dt} s -> {shown} s of sim time")
    print(f"{'integrator':<14}{'E0':>12}{'E_final':>14}{'rel_final':>14}{'rel_max':>14}")
    for name, d in drifts.items():
        if d["diverged"]:
            print(f"{name:<14}{cell(d['e0'], 12)}  diverged: energy non-finite from step {d['diverged_at_step']:,}")
        else:
            print(f"{name:<14}{cell(d['e0'], 12)}{cell(d['e_final'], 14)}"
                  f"{d['rel_final']:>+14.4e}{d['rel_max']:>14.4e}")
    if set(drifts) == set(INTEGRATORS) and system_name in ("orbit", "spring"):
        # The headline, stated as an ordering so it holds for any seed.
        diverged = [name for name, d in drifts.items() if d["diverged"]]
        if diverged:
            verdict = f"cannot judge, {' and '.join(diverged)} diverged (try a smaller --dt)"
        else:
            euler, semi, rk4 = drifts["euler"], drifts["semi_implicit"], drifts["rk4"]
            ok = abs(euler["rel_final"]) > semi["rel_max"] > rk4["rel_max"]
            verdict = "as expected" if ok else "UNEXPECTED: investigate"
        print(f"energy drift ordering euler >> semi_implicit(bounded) > rk4: {verdict}")


# --- the run: flags and main ---


def parse_args(argv=None) -> argparse.Namespace:
    parser = OneLineParser(prog="engine.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seed", type=int_in(0, None, "--seed"), default=0,
                        help="seeds the one jittered initial condition per system (default 0)")
    parser.add_argument("--system", choices=SYSTEMS, default="orbit",
                        help="which conservative system to integrate (default orbit)")
    parser.add_argument("--integrator", choices=["all", *INTEGRATORS], default="all",
                        help="'all' runs the three-way comparison, which is the point (default all)")
    parser.add_argument("--dt", type=positive_finite("the timestep --dt"), default=0.01,
                        help="timestep in sim seconds; raise it and every drift grows (default 0.01)")
    parser.add_argument("--steps", type=int_in(1, MAX_STEPS, "--steps"), default=2000,
                        help=f"steps per integrator, 1 to {MAX_STEPS:,} (default 2000)")
    parser.add_argument("--smoke", action="store_true",
                        help=f"fixed {SMOKE_STEPS}-step run for CI; two runs write identical {METRICS_FILE}")
    parser.add_argument("--device", choices=["cpu"], default="cpu",
                        help="pure numpy runs on the CPU; the flag is there for the course's banner")
    parser.add_argument("--out", type=Path, default=Path("outputs/ch3.3-engine"),
                        help=f"folder for {METRICS_FILE} and {RECORDING_FILE} (default outputs/ch3.3-engine)")
    parser.add_argument("--rerun", dest="rerun", action="store_true", default=True,
                        help=f"write the {RECORDING_FILE} recording (the default)")
    parser.add_argument("--no-rerun", dest="rerun", action="store_false",
                        help="skip the recording; rerun is then never imported")
    args = parser.parse_args(argv)
    problem = output_folder_problem(args.out)
    if problem:
        parser.error(f"argument --out: {problem}")
    if args.rerun and not module_installed("rerun"):
        parser.error("the recording needs rerun-sdk: run `pip install -e .` first, or pass --no-rerun")
    return args


def module_installed(name: str) -> bool:
    """True if `import name` would find something; looks without importing."""
    import importlib.util

    return importlib.util.find_spec(name) is not None


def main(argv=None) -> int:
    args = parse_args(argv)
    started = time.perf_counter()
    banner("ch3.3-engine", device=args.device)
    steps = SMOKE_STEPS if args.smoke else args.steps
    names = list(INTEGRATORS) if args.integrator == "all" else [args.integrator]
    system = build_system(args.system, np.random.default_rng(args.seed))  # PCG64: the only randomness
    every = math.ceil((steps + 1) / MAX_POINTS_PER_SERIES)  # states kept for the recording; energy: every step
    show_progress = not args.smoke and steps * len(names) >= PROGRESS_FROM
    metrics_path, recording_path = args.out / METRICS_FILE, args.out / RECORDING_FILE
    try:
        runs, drifts = {}, {}
        for name in names:
            progress = progress_printer(name, steps) if show_progress else None
            runs[name] = positions, _, energies = simulate(INTEGRATORS[name], system, args.dt, steps, every, progress)
            drifts[name] = energy_drift(energies)
            drifts[name]["final_pos"] = [round(x, 6) if math.isfinite(x) else None for x in positions[-1].tolist()]
        args.out.mkdir(parents=True, exist_ok=True)
        note = record(recording_path, system, runs, kept_steps(steps, every), args.dt) if args.rerun else None
        write_atomic(metrics_path, metrics_text(build_metrics(args.system, args.dt, steps, args.seed, drifts)))
    except KeyboardInterrupt:
        print(f"\ninterrupted: {METRICS_FILE} and {RECORDING_FILE} were left as they were", file=sys.stderr)
        return 130
    print_report(args.system, args.dt, steps, drifts)
    print(f"metrics: {metrics_path}")
    if args.rerun:
        print(f"recording: {recording_path} (open it with: rerun {recording_path})")
        if note:
            print(note)
    wall_clock(started)
    return 0


if __name__ == "__main__":
    sys.exit(main())
