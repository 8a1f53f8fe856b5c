"""All of Rerun for engine.py: the recording a run writes, and what the viewer opens on.

engine.py imports this only when a recording is asked for, so the physics and the tests run without
Rerun. Each system opens on its own lesson: RECORDED_VIEWS lists, per system, the views it needs, and
each log_<view>() logs its data along the `step` timeline and returns that view's layout. A new system
or view plugs in with one function and one line in the table. Comments say what the viewer will show.
"""

import math

import numpy as np

from engine_ensembles import SHOWN_MEMBERS

APPLICATION_ID = "zero2robot-ch3_3-engine"  # rerun 0.41 ids: letters, digits, '_' and '-'
COLORS = {"euler": [217, 76, 64], "semi_implicit": [76, 175, 80], "rk4": [64, 115, 217], "implicit": [155, 89, 182]}
LABELS = {"euler": "explicit Euler", "semi_implicit": "semi-implicit Euler", "rk4": "RK4",
          "implicit": "implicit (damping)"}
PLAYBACK_SECONDS = 20.0  # pressing play runs the whole recording in about this long, whatever its length
DRAW_LIMIT = 1e30  # Rerun stores float32 (up to 3.4e38): we draw coordinates below this, leaving headroom
# for the camera's distance and the labels' lifts; a diverged run's inf and NaN are never drawn


def record(system: dict, runs: dict, kept: np.ndarray, dt: float, run_id: str,
           ensemble: dict | None = None) -> tuple[bytes, str | None]:
    """The .rrd bytes of runs {integrator: (positions, velocities, energies)}, and a note if thinned.

    `kept` are the step numbers of the kept states; energies are logged at those steps too.
    `ensemble`, from an --ensemble run, adds a row below: members' paths and their error spread.
    The recording is built in memory and saved by write_run() beside metrics.json, whose
    run_id it carries as its recording id: a full disk is then our error to report, not a
    hang inside Rerun's file sink.
    """
    import rerun as rr
    import rerun.blueprint as rrb

    # The stream: built in memory under the run's id; write_run() saves it beside metrics.json.
    recording = rr.RecordingStream(APPLICATION_ID, recording_id=run_id)
    in_memory = recording.memory_recording()
    try:
        views = [log_view(rr, rrb, recording, system, runs, kept, dt) for log_view in views_for(system)]
        below = [log_view(rr, rrb, recording, ensemble, kept) for log_view in ENSEMBLE_VIEWS] if ensemble else []
        recording.send_blueprint(layout(rrb, views, below, kept), make_active=False, make_default=True)
    finally:
        data = in_memory.drain_as_bytes()  # also after a Ctrl-C: Rerun warns about data it has to drop
    steps = int(kept[-1])
    if len(kept) == steps + 1:
        return data, None
    every = int(kept[1] - kept[0])
    return data, f"recording keeps 1 state in {every} of {steps + 1:,} per integrator, to stay viewable " \
                 "(metrics use all)"


def layout(rrb, views, below, kept):
    """The first view large on the left, the others stacked on the right, `below` in a row underneath;
    the side panels folded away.

    The file opens with the time cursor on the last step (play state "following"): every body where its
    run ended, every plot whole. Pause, then play, and the viewer starts again from step 0.
    """
    first, *others = views
    story = rrb.Horizontal(first, rrb.Vertical(*others), column_shares=[3, 2]) if others else first
    if below:
        story = rrb.Vertical(story, rrb.Horizontal(*below))
    return rrb.Blueprint(
        story,
        rrb.BlueprintPanel(state="hidden"),
        rrb.SelectionPanel(state="hidden"),
        rrb.TimePanel(state="collapsed", timeline="step", play_state="following",
                      fps=max(int(kept[-1]) / PLAYBACK_SECONDS, 1.0)),
    )


def drawable(points):
    """Rows whose every coordinate Rerun can draw (a diverged run's inf and NaN are left out)."""
    return (np.abs(points) < DRAW_LIMIT).all(axis=-1)


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
    distance = 1.2 * float(max(high[0] - low[0], high[1] - low[1]) or 1.0)  # a margin for the axis names
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


def first_start(system):
    """(q0, v0) of the body the runs are: the system's own, or an ensemble's first member's."""
    q0, v0 = system["q0"], system["v0"]
    return (q0[0], v0[0]) if np.ndim(q0) == 2 else (q0, v0)


def log_phase_plane(rr, rrb, recording, system, runs, kept, dt):
    """x across, v_x up: a closed curve is an oscillation that keeps its energy; Euler's spirals out."""
    planes = {name: np.stack([positions[:, 0], velocities[:, 0], np.zeros(len(kept))], axis=1)
              for name, (positions, velocities, _) in runs.items()}
    lifts = label_lifts(planes)
    for name, plane in planes.items():
        log_bodies(rr, recording, f"phase/{name}", name, plane, kept, label_lift=lifts[name])
    # The exact motion, wide and grey, a hair below the plane so the integrators' lines lie on top of it.
    # Its velocity is the exact position's central difference over a microsecond.
    q0, v0 = first_start(system)
    t, h = kept * dt, 1e-6
    x = system["exact"](q0, v0, t)[:, 0]
    v = (system["exact"](q0, v0, t + h)[:, 0] - system["exact"](q0, v0, t - h)[:, 0]) / (2.0 * h)
    low, high = extent(planes.values())
    below = -0.002 * float(max(high[0] - low[0], high[1] - low[1]) or 1.0)
    exact = np.stack([x, v, np.full(len(kept), below)], axis=1)
    recording.log("phase/exact", rr.LineStrips3D([exact[drawable(exact)]], colors=[[120, 120, 120]],
                                                 radii=rr.components.Radius.ui_points(3.0)), static=True)
    log_axes(rr, recording, "phase/axes", np.maximum(-low, high)[:2] * 1.1, ("x (m)", "v_x (m/s)"))
    name = f"{system['name']}: phase plane, x against v_x (grey: the exact motion)"
    return rrb.Spatial3DView(origin="phase", name=name,
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
    exact = system["exact"](*first_start(system), kept * dt)
    curves = {}
    for name, (positions, _, _) in runs.items():
        miss = positions - exact
        with np.errstate(all="ignore"):
            curves[name] = log10_of(np.sqrt(np.square(miss).sum(axis=-1)))  # distance from the exact path
    logged = log_curves(rr, recording, "position_error", curves, kept)
    # log10 = 0: off by 1 m, the size of the orbit (or of the spring's swing) itself. "zero" sorts last.
    log_level(rr, recording, "position_error/zero", "1 m, the size of the motion", 0.0, kept)
    return plot(rr, rrb, "position_error", "position error against the exact motion: log10 |q - q_exact| (m)", kept,
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


def log_member_paths(rr, rrb, recording, ensemble, kept):
    """An ensemble's 3D view: the first members' paths, one strip each, in the integrator's colour."""
    for name, summary in ensemble.items():
        strips = [member[drawable(member)] for member in summary["paths"].swapaxes(0, 1)]
        lines = rr.LineStrips3D(strips, colors=[COLORS[name]], radii=rr.components.Radius.ui_points(0.75))
        recording.log(f"ensemble_paths/{name}", lines, static=True)
    return rrb.Spatial3DView(origin="ensemble_paths", name=f"the first {SHOWN_MEMBERS} members' paths")


def log_error_spread(rr, rrb, recording, ensemble, kept):
    """Three curves per integrator, min, median and max of log10 |E - E0| / |E0| over all members.

    Their gap is how much the seed matters: wide for the orbit, round-off for the linear spring.
    """
    logged = []
    for name, summary in ensemble.items():
        for column, (which, width) in enumerate((("min", 0.5), ("median", 2.0), ("max", 0.5))):
            curve = log10_of(summary["error_spread"][:, column])
            style = rr.SeriesLines(colors=[COLORS[name]], names=[f"{LABELS[name]} {which}"], widths=[width])
            recording.log(f"ensemble_error/{name}/{which}", style, static=True)
            shown = np.isfinite(curve)
            recording.send_columns(f"ensemble_error/{name}/{which}", indexes=on_steps(rr, kept[shown]),
                                   columns=rr.Scalars.columns(scalars=curve[shown]))
            logged.append(curve[shown])
    return plot(rr, rrb, "ensemble_error", "log10 |E - E0| / |E0|: min, median, max over members", kept,
                padded(np.concatenate(logged)), "RightBottom")


RECORDED_VIEWS = {  # per system, the views its lesson needs; the first one opens large on the left
    "orbit": (log_orbit, log_position_error, log_energy_error),
    "spring": (log_phase_plane, log_energy_error),
    "freefall": (log_energy_change, log_height),
    "damped_spring": (log_phase_plane, log_position_error),  # energy drains by design: the exact motion referees
}


def views_for(system: dict) -> tuple:
    """The system's own views, or for a system that has none in the table: its energy error, and its position
    error against the exact motion where it has one."""
    if system["name"] in RECORDED_VIEWS:
        return RECORDED_VIEWS[system["name"]]
    return (log_energy_error, log_position_error) if system.get("exact") else (log_energy_error,)


ENSEMBLE_VIEWS = (log_member_paths, log_error_spread)  # an --ensemble run adds these in a row below
