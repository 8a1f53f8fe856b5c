"""All of Rerun for engine.py: the recording a run writes, and what the viewer opens on.

engine.py imports this module, which imports nothing of engine's and loads Rerun only inside record(),
when a recording is asked for: the physics and the tests run without Rerun. Each system opens on its
own lesson: RECORDED_VIEWS lists, per system, the views it needs, and each log_<view>() logs its data
along the `step` timeline and returns that view's layout. A new system records its paths, its energy
error and its position error where it has an exact motion (views_for) until it gets a line of its own
in the table; a new view is one function. Colours, labels and the way the file opens are the course's
(curriculum/common/recording.py): an integrator the course has no colour for takes the next spare one
from the colour-blind-safe palette, so a new name is never a KeyError. Comments say what the viewer shows.
"""

import numpy as np

from curriculum.common import recording as course
from engine_ensembles import SHOWN_MEMBERS
from engine_referee import distance, relative_energy_error

APPLICATION_ID = "zero2robot-ch3_3-engine"  # rerun 0.41 ids: letters, digits, '_' and '-'
EXACT_GREY = (120, 120, 120)  # the exact motion, drawn wide under the integrators' lines


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

    def fill(recording):
        views = [log_view(rr, rrb, recording, system, runs, kept, dt) for log_view in views_for(system)]
        below = [log_view(rr, rrb, recording, ensemble, kept) for log_view in ENSEMBLE_VIEWS] if ensemble else []
        return layout(rrb, views, below, kept)

    data = course.recorded(APPLICATION_ID, fill, recording_id=run_id)
    steps = int(kept[-1])
    if len(kept) == steps + 1:
        return data, None
    every = int(kept[1] - kept[0])
    return data, f"recording keeps 1 state in {every} of {steps + 1:,} per integrator, to stay viewable " \
                 "(metrics use all)"


def layout(rrb, views, below, kept):
    """The first view large on the left, the others stacked on the right, `below` in a row underneath,
    opened the course's way (course.opening): the whole run, cursor on the last step, panels closed."""
    first, *others = views
    story = rrb.Horizontal(first, rrb.Vertical(*others), column_shares=[3, 2]) if others else first
    if below:
        story = rrb.Vertical(story, rrb.Horizontal(*below))
    return course.opening(story, int(kept[-1]))


def log_bodies(rr, recording, entity, look, points, kept):
    """One integrator in a spatial view: its whole path as a trail, and a body that travels along it.

    Sizes are in screen points, so a body stays a visible dot and a trail a thin line at any zoom.
    """
    shown = course.drawable(points)
    colour = [look.colour]
    trail = rr.LineStrips3D([points[shown]], colors=colour, radii=rr.components.Radius.ui_points(1.0))
    recording.log(f"{entity}/trail", trail, static=True)
    body = rr.Points3D.from_fields(colors=colour, radii=rr.components.Radius.ui_points(7.0))
    recording.log(f"{entity}/body", body, static=True)
    recording.send_columns(f"{entity}/body", indexes=course.on_steps(kept[shown]),
                           columns=rr.Points3D.columns(positions=points[shown]))


def log_paths(rr, rrb, recording, system, runs, kept, dt, origin="paths", name="the paths, from above"):
    """3D, seen from above at a slight tilt: each integrator's path as a trail, its body at the end, a key."""
    paths = {integrator: positions for integrator, (positions, _, _) in runs.items()}
    looks = course.looks(paths)
    for integrator, positions in paths.items():
        log_bodies(rr, recording, f"{origin}/{integrator}", looks[integrator], positions, kept)
    key = course.log_key(recording, f"{origin}/key", looks, paths.values())
    return course.from_above(origin, name, [*paths.values(), key], tilt=0.35)


def log_orbit(rr, rrb, recording, system, runs, kept, dt):
    """The paths around the attractor: Euler's spiralling out, the other two together."""
    attractor = rr.Points3D([[0.0, 0.0, 0.0]], radii=rr.components.Radius.ui_points(6.0), colors=[[230, 230, 230]],
                            labels=["attractor"])
    recording.log("orbit/attractor", attractor, static=True)
    return log_paths(rr, rrb, recording, system, runs, kept, dt, "orbit", "orbit: the paths, from above")


def first_start(system):
    """(q0, v0) of the body the runs are: the system's own, or an ensemble's first member's."""
    q0, v0 = system["q0"], system["v0"]
    return (q0[0], v0[0]) if np.ndim(q0) == 2 else (q0, v0)


def log_phase_plane(rr, rrb, recording, system, runs, kept, dt):
    """x across, v_x up: a closed curve is an oscillation that keeps its energy; Euler's spirals out."""
    planes = {name: np.stack([positions[:, 0], velocities[:, 0], np.zeros(len(kept))], axis=1)
              for name, (positions, velocities, _) in runs.items()}
    looks = course.looks(planes)
    for name, plane in planes.items():
        log_bodies(rr, recording, f"phase/{name}", looks[name], plane, kept)
    low, high = course.extent(planes.values())
    span = float(max(high[0] - low[0], high[1] - low[1]) or 1.0)
    if system.get("exact"):
        # The exact motion, wide and grey, a hair below the plane so the integrators' lines lie on top of it.
        # Its velocity is the exact position's central difference over a microsecond.
        q0, v0 = first_start(system)
        t, h = kept * dt, 1e-6
        x = system["exact"](q0, v0, t)[:, 0]
        v = (system["exact"](q0, v0, t + h)[:, 0] - system["exact"](q0, v0, t - h)[:, 0]) / (2.0 * h)
        exact = np.stack([x, v, np.full(len(kept), -0.002 * span)], axis=1)
        recording.log("phase/exact", rr.LineStrips3D([exact[course.drawable(exact)]], colors=[EXACT_GREY],
                                                     radii=rr.components.Radius.ui_points(3.0)), static=True)
    # The axes cross at the origin and reach a little past the paths on every side (the origin included).
    reach_low, reach_high = np.minimum(low, 0.0) - 0.08 * span, np.maximum(high, 0.0) + 0.08 * span
    course.log_axes(recording, "phase/axes", reach_low, reach_high, ("x (m)", "v_x (m/s)"))
    axes_box = np.array([reach_low, reach_high])
    key = course.log_key(recording, "phase/key", looks, [*planes.values(), axes_box])
    grey = " (grey: the exact motion)" if system.get("exact") else ""
    name = f"{system['name']}: phase plane, x against v_x{grey}"
    # framed with room above the v_x name and beside the x name, which sit just past the axes' tips
    return course.from_above("phase", name, [*planes.values(), axes_box, key], margin=1.3)


def log_curves(rr, recording, origin, curves, kept, widths=None):
    """One line per integrator on the `step` timeline, in its colour. Returns the finite values logged."""
    looks = course.looks(curves)
    logged = [course.log_series(recording, f"{origin}/{name}", kept, values, looks[name],
                                None if widths is None else widths[name]) for name, values in curves.items()]
    return np.concatenate(logged)


def log_level(rr, recording, entity, label, value, kept):
    """A grey line at `value` across the whole run, to read the curves against."""
    course.log_series(recording, entity, [0, int(kept[-1])], [value, value], course.Look(course.GREY, label))


def log10_of(x):
    """log10 where x > 0, NaN elsewhere (exact zeros, which have no logarithm, are not drawn)."""
    with np.errstate(all="ignore"):
        return np.where(x > 0.0, np.log10(np.where(x > 0.0, x, 1.0)), np.nan)


def log_position_error(rr, rrb, recording, system, runs, kept, dt):
    """log10 |q - q_exact| in metres: RK4 sits orders of magnitude below semi-implicit Euler."""
    exact = system["exact"](*first_start(system), kept * dt)
    curves = {name: log10_of(distance(positions, exact)) for name, (positions, _, _) in runs.items()}
    logged = log_curves(rr, recording, "position_error", curves, kept)
    # log10 = 0: off by 1 m, the size of the orbit (or of the spring's swing) itself. "zero" sorts last.
    log_level(rr, recording, "position_error/zero", "1 m, the size of the motion", 0.0, kept)
    return course.time_series("position_error", "position error against the exact motion: log10 |q - q_exact| (m)",
                              kept[-1], [logged, [0.0]])


def log_energy_error(rr, rrb, recording, system, runs, kept, dt):
    """log10 |E - E0| / |E0|, digits of energy lost: Euler climbs to 0 (100%), semi-implicit stays in a band."""
    curves = {}
    for name, (_, _, energies) in runs.items():
        curves[name] = log10_of(np.abs(relative_energy_error(energies[kept])))
    logged = log_curves(rr, recording, "energy_error", curves, kept)
    log_level(rr, recording, "energy_error/zero", "100% of E0", 0.0, kept)  # log10 = 0: all of it
    return course.time_series("energy_error", "energy error: log10 |E - E0| / |E0|", kept[-1], [logged, [0.0]])


def log_energy_change(rr, rrb, recording, system, runs, kept, dt):
    """(E - E0) / |E0| in percent, sign kept: on freefall the two Eulers miss by the same amount, opposite ways."""
    curves = {}
    for name, (_, _, energies) in runs.items():
        with np.errstate(all="ignore"):
            curves[name] = relative_energy_error(energies[kept]) * 100.0
    logged = log_curves(rr, recording, "energy_change", curves, kept)
    reach = 1.15 * float(np.abs(logged).max(initial=0.0)) or 1.0
    return course.time_series("energy_change", "energy change (E - E0) / |E0|, %", kept[-1], legend="LeftTop",
                              y_range=(-reach, reach))


def log_height(rr, rrb, recording, system, runs, kept, dt):
    """Height z against the step: the body falls and never comes back, so no error is ever paid back."""
    curves = {name: positions[:, 2] for name, (positions, _, _) in runs.items()}
    # The default run's heights end 2 m apart after a 2 km fall: one line to the eye. Drawn widest first,
    # every one shows.
    logged = log_curves(rr, recording, "height", curves, kept, course.layered_widths(curves))
    ends = [heights[-1] for heights in curves.values() if np.isfinite(heights[-1])]
    apart = f": the curves end {max(ends) - min(ends):.2g} m apart" if len(ends) > 1 else ""
    return course.time_series("height", f"height z (m){apart}", kept[-1], logged, legend="LeftBottom")


def log_member_paths(rr, rrb, recording, ensemble, kept):
    """An ensemble's 3D view: the first members' paths, one strip each, in the integrator's colour."""
    looks = course.looks(ensemble)
    every_path = []
    for name, summary in ensemble.items():
        strips = [member[course.drawable(member)] for member in summary["paths"].swapaxes(0, 1)]
        lines = rr.LineStrips3D(strips, colors=[looks[name].colour], radii=rr.components.Radius.ui_points(0.75))
        recording.log(f"ensemble_paths/{name}", lines, static=True)
        every_path += strips
    key = course.log_key(recording, "ensemble_paths/key", looks, every_path)
    return course.from_above("ensemble_paths", f"the first {SHOWN_MEMBERS} members' paths", [*every_path, key],
                             tilt=0.35)


def log_error_spread(rr, rrb, recording, ensemble, kept):
    """Per integrator, each member's worst |E - E0| / |E0| so far (log10): the median member as a thick line,
    and thin lines for the best and the worst member, which share one entry in the legend.

    The worst-so-far never falls, so the curves read as "how bad it has got", with no spikes where an
    error happens to cross zero; the gap between the thin lines is how much the seed matters."""
    looks = course.looks(ensemble)
    logged = []
    for name, summary in ensemble.items():
        colour, label = looks[name]
        spread = course.Look(colour, f"{label}: best and worst member")  # one name: one legend entry for both
        median = course.Look(colour, f"{label}: median member")
        for column, (path, look, width) in enumerate((("min", spread, 1.0), ("median", median, 3.5),
                                                       ("max", spread, 1.0))):
            curve = log10_of(summary["error_spread"][:, column])
            logged.append(course.log_series(recording, f"ensemble_error/{name}/{path}", kept, curve, look, width))
    low, high = course.padded(logged)
    # room under the lowest curve for the legend, which lists two lines per integrator
    title = "each member's worst log10 |E - E0| / |E0| so far: the median (thick), the best and the worst member"
    return course.time_series("ensemble_error", title, kept[-1], y_range=(low - 0.4 * (high - low), high))


RECORDED_VIEWS = {  # per system, the views its lesson needs; the first one opens large on the left
    "orbit": (log_orbit, log_position_error, log_energy_error),
    "spring": (log_phase_plane, log_energy_error),
    "freefall": (log_energy_change, log_height),
    "damped_spring": (log_phase_plane, log_position_error),  # energy drains by design: the exact motion referees
}


def views_for(system: dict) -> tuple:
    """The system's own views, or for a system that has no line in the table: where the bodies went, its
    energy error, and its position error against the exact motion where it has one."""
    if system["name"] in RECORDED_VIEWS:
        return RECORDED_VIEWS[system["name"]]
    return (log_paths, log_energy_error, log_position_error) if system.get("exact") else (log_paths, log_energy_error)


ENSEMBLE_VIEWS = (log_member_paths, log_error_spread)  # an --ensemble run adds these in a row below
