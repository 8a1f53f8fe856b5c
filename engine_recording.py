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

import math

import numpy as np

from curriculum.common import recording as course
from engine_ensembles import SHOWN_MEMBERS
from engine_referee import distance, overflow_step, relative_energy_error

APPLICATION_ID = "zero2robot-ch3_3-engine"  # rerun 0.41 ids: letters, digits, '_' and '-'
EXACT_GREY = (120, 120, 120)  # the exact motion, drawn wide under the integrators' lines
LIFT = 1e-3  # of a view's width: how much higher each next trail is drawn, so lines on one another all show
REACH = 2.0  # a spatial view frames the runs that stay within this many times the exact motion's size
EXACT_POINTS = 100_000  # the most points the grey exact motion is drawn with, however coarse the steps


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
        looks = looks_of(runs)
        views = [log_view(rr, recording, system, runs, kept, dt, looks) for log_view in views_for(system)]
        below = [log_view(rr, recording, system, ensemble, kept, dt, looks) for log_view in ENSEMBLE_VIEWS] \
            if ensemble else []
        return layout(rrb, views, below, kept)

    data = course.recorded(APPLICATION_ID, fill, recording_id=run_id)
    steps = int(kept[-1])
    if len(kept) == steps + 1:
        return data, None
    every = int(kept[1] - kept[0])
    return data, f"recording keeps 1 state in {every} of {steps + 1:,} per integrator, to stay viewable " \
                 "(metrics use all)"


def looks_of(runs: dict) -> dict:
    """Each run's colour and label, the same in every view; a run that blew up says at which step, in the words
    and at the step the table and metrics.json use (engine_referee.overflow_step)."""
    looks = course.looks(runs)
    for name, (_, _, energies) in runs.items():
        step = overflow_step(energies)
        if step is not None:
            looks[name] = course.Look(looks[name].colour, f"{looks[name].label}: energy overflowed at step {step:,}")
    return looks


def layout(rrb, views, below, kept):
    """The first view large on the left, the others stacked on the right, `below` in a row underneath,
    opened the course's way (course.opening): the whole run, cursor on the last step, panels closed."""
    first, *others = views
    story = rrb.Horizontal(first, rrb.Vertical(*others), column_shares=[3, 2]) if others else first
    if below:
        story = rrb.Vertical(story, rrb.Horizontal(*below))
    return course.opening(story, int(kept[-1]))


def within_reach(reference, paths, reach: float = REACH) -> list:
    """The paths to frame with `reference`: drawable and within `reach` times its half-width of its centre (x, y)."""
    low, high = course.extent(reference)
    centre, half = (low + high)[:2] / 2.0, float(max(high[0] - low[0], high[1] - low[1])) / 2.0
    kept = []
    for path in paths:
        points = np.reshape(path, (-1, 3))
        if course.drawable(points).all() and (np.abs(points[:, :2] - centre) <= reach * half).all():
            kept.append(path)
    return kept


def log_flat(rr, recording, origin, name, looks, paths, kept, exact=None, anchors=(), axes=None, tilt=0.0,
             scales=(1.0, 1.0)):
    """A flat view seen from above, framed on what stays bounded: the exact motion, drawn wide and grey under the
    runs (or, without one, the runs that stay drawable), the `anchors` (the attractor, the origin) and every run
    that stays within REACH times that size. A run that goes further is seen leaving the frame, and one
    that blew up says at which step in the key, which stands beside the frame. Each run is a trail with a body
    travelling along it; trails lying on one another all show: in name order each one is drawn thinner and a
    hair higher than the one before (as the plots layer their lines). `axes` names the two axes, drawn through
    the origin, whose ticks read in true units where an axis is drawn `scales` times its size."""
    reference = [exact] if exact is not None else [p for p in paths.values() if course.drawable(p).all()]
    reference = [*(reference or paths.values()), *np.reshape(anchors, (-1, 1, 3))]
    near = within_reach(reference, paths.values())
    framed = [*reference, *near]
    low, high = course.extent(framed)
    span = float(max(high[0] - low[0], high[1] - low[1]) or 1.0)
    widths = course.layered_widths(paths, widest=3.0, thinnest=1.25)
    for rank, path_name in enumerate(sorted(paths)):
        lifted = paths[path_name] + [0.0, 0.0, LIFT * span * rank]
        leaves = not any(path is paths[path_name] for path in near)  # its trail ends where it leaves the frame
        trail = until_it_leaves(lifted, low - span, high + span) if leaves else lifted
        log_bodies(rr, recording, f"{origin}/{path_name}", looks[path_name], lifted, kept, widths[path_name], trail)
    if exact is not None:
        below = exact[course.drawable(exact)] - [0.0, 0.0, LIFT * span]
        recording.log(f"{origin}/exact", rr.LineStrips3D([below], colors=[EXACT_GREY],
                                                        radii=rr.components.Radius.ui_points(3.0)), static=True)
    if axes:  # through the origin, reaching a little past the framed paths on every side (the origin included)
        reach_low, reach_high = np.minimum(low, 0.0) - 0.08 * span, np.maximum(high, 0.0) + 0.08 * span
        course.log_axes(recording, f"{origin}/axes", reach_low, reach_high, axes, scales)
        framed.append(np.array([reach_low, reach_high]))
    key = course.log_key(recording, f"{origin}/key", looks, framed)
    # framed with room for the key's labels and, on a plane with axes, for their names past the tips
    return course.from_above(origin, name, [*framed, key], tilt=tilt, margin=1.3 if axes else 1.2)


def until_it_leaves(points, low, high):
    """A path up to its first point outside low..high (x and y) or not drawable, that point included if drawable:
    a run that leaves the frame is drawn leaving it once, not zigzagging across the whole view."""
    inside = course.drawable(points) & (points[:, :2] >= low[:2]).all(axis=1) & (points[:, :2] <= high[:2]).all(axis=1)
    if inside.all():
        return points
    first_out = int(np.argmin(inside))
    return points[:first_out + 1] if course.drawable(points[first_out:first_out + 1]).all() else points[:first_out]


def log_bodies(rr, recording, entity, look, points, kept, width, trail=None):
    """One run in a spatial view: its path as a trail `width` points wide (`trail`, if given: the part drawn),
    and a body that travels along the whole run, the wider the trail the bigger the body (so bodies on one
    another show as rings round the smallest).

    Sizes are in screen points, so a body stays a visible dot and a trail a thin line at any zoom.
    """
    shown = course.drawable(points)
    colour = [look.colour]
    trail = points[shown] if trail is None else trail[course.drawable(trail)]
    trail = rr.LineStrips3D([trail], colors=colour, radii=rr.components.Radius.ui_points(width / 2.0))
    recording.log(f"{entity}/trail", trail, static=True)
    body = rr.Points3D.from_fields(colors=colour, radii=rr.components.Radius.ui_points(3.0 + 2.0 * width))
    recording.log(f"{entity}/body", body, static=True)
    if shown.any():  # never an empty column (see course.log_series)
        recording.send_columns(f"{entity}/body", indexes=[rr.TimeColumn("step", sequence=kept[shown])],
                               columns=rr.Points3D.columns(positions=points[shown]))


def first_start(system):
    """(q0, v0) of the body the runs are: the system's own, or an ensemble's first member's."""
    q0, v0 = system["q0"], system["v0"]
    return (q0[0], v0[0]) if np.ndim(q0) == 2 else (q0, v0)


def exact_path(system, kept, dt):
    """Where the exact motion puts the runs' body at the kept steps, or None for a system without one."""
    return system["exact"](*first_start(system), kept * dt) if system.get("exact") else None


def smooth(exact_at, kept, dt):
    """exact_at(times) drawn as a smooth grey curve: at the kept steps, each step between them cut into as many
    pieces as the longest step's chord is fiftieths of the motion's size (at most EXACT_POINTS points in all).
    At a large dt the kept steps alone would join far-apart points of the orbit by chords across it."""
    coarse = exact_at(kept * dt)
    shown = coarse[course.drawable(coarse)][:, :2]
    if len(shown) < 2:
        return coarse
    chord = float(np.max(np.abs(np.diff(shown, axis=0))))
    pieces = min(math.ceil(chord / (0.02 * (float(np.ptp(shown, axis=0).max()) or 1.0))), EXACT_POINTS // len(kept))
    if pieces <= 1:
        return coarse
    steps = (kept[:-1, None] + np.arange(pieces) / pieces * np.diff(kept)[:, None]).ravel()
    return exact_at(np.append(steps, kept[-1]) * dt)


def log_paths(rr, recording, system, runs, kept, dt, looks, origin="paths", title="the paths", anchors=()):
    """3D, seen from above at a slight tilt: each integrator's path as a trail, its body at the end, a key."""
    paths = {integrator: positions for integrator, (positions, _, _) in runs.items()}
    exact = smooth(lambda t: system["exact"](*first_start(system), t), kept, dt) if system.get("exact") else None
    grey = " (grey: the exact motion)" if exact is not None else ""
    return log_flat(rr, recording, origin, f"{title}, from above{grey}", looks, paths, kept, exact, anchors,
                    tilt=0.35)


def log_orbit(rr, recording, system, runs, kept, dt, looks):
    """The paths around the attractor: Euler's spiralling out, the other two on the exact orbit."""
    attractor = rr.Points3D([[0.0, 0.0, 0.0]], radii=rr.components.Radius.ui_points(6.0), colors=[[230, 230, 230]],
                            labels=["attractor"])
    recording.log("orbit/attractor", attractor, static=True)
    return log_paths(rr, recording, system, runs, kept, dt, looks, "orbit", "orbit: the paths", [0.0, 0.0, 0.0])


def flat(x, v):
    """(x, v) as points (x, v, 0): a phase plane drawn flat in a view from above."""
    return np.stack([x, v, np.zeros_like(x)], axis=-1)


def log_phase_plane(rr, recording, system, runs, kept, dt, looks):
    """x across, v_x up: a closed curve is an oscillation that keeps its energy; Euler's spirals out."""
    exact, stretch = None, 1.0
    if system.get("exact"):  # its velocity is the exact position's central difference over a microsecond
        q0, v0 = first_start(system)

        def phase(t, h=1e-6):
            x_of = system["exact"]
            return flat(x_of(q0, v0, t)[:, 0], (x_of(q0, v0, t + h)[:, 0] - x_of(q0, v0, t - h)[:, 0]) / (2.0 * h))

        at_steps = phase(kept * dt)
        stretch = stretch_for(at_steps[:, 0], at_steps[:, 1])
        exact = smooth(lambda t: phase(t) * [1.0, stretch, 1.0], kept, dt)
    planes = {name: flat(positions[:, 0], stretch * velocities[:, 0])
              for name, (positions, velocities, _) in runs.items()}
    grey = " (grey: the exact motion)" if exact is not None else ""
    v_name = "v_x (m/s)" if stretch == 1.0 else f"v_x (m/s), drawn {stretch:g}x taller"
    return log_flat(rr, recording, "phase", f"{system['name']}: phase plane, x against v_x{grey}", looks, planes,
                    kept, exact, axes=("x (m)", v_name), scales=(1.0, stretch))


def stretch_for(x, v) -> float:
    """1, or the power of ten that v is drawn times its size so the exact motion (with the origin) is no flatter
    than a fifth of its width: a heavily damped spring creeps along x at a velocity a hundred times smaller."""
    with np.errstate(all="ignore"):
        ratio = np.ptp(np.append(x, 0.0)) / np.ptp(np.append(v, 0.0))
    return 10.0 ** round(math.log10(ratio)) if np.isfinite(ratio) and ratio > 5.0 else 1.0


def log_curves(rr, recording, origin, curves, kept, looks, widths=None):
    """One line per integrator on the `step` timeline, in its colour. Lines lying on one another all show: the
    first in name order (the order the viewer draws them in) widest, each next one thinner. Returns the finite
    values logged."""
    widths = widths or course.layered_widths(curves, widest=4.0, thinnest=1.5)
    logged = [course.log_series(recording, f"{origin}/{name}", kept, values, looks[name], widths[name])
              for name, values in curves.items()]
    return np.concatenate(logged)


def log_level(rr, recording, entity, label, value, kept):
    """A grey line at `value` across the whole run, to read the curves against."""
    course.log_series(recording, entity, [0, int(kept[-1])], [value, value], course.Look(course.GREY, label))


def log10_of(x):
    """log10 where x > 0, NaN elsewhere (exact zeros, which have no logarithm, are not drawn)."""
    with np.errstate(all="ignore"):
        return np.where(x > 0.0, np.log10(np.where(x > 0.0, x, 1.0)), np.nan)


def log_position_error(rr, recording, system, runs, kept, dt, looks):
    """log10 |q - q_exact| in metres: RK4 sits orders of magnitude below semi-implicit Euler."""
    exact = exact_path(system, kept, dt)
    curves = {name: log10_of(distance(positions, exact)) for name, (positions, _, _) in runs.items()}
    log_curves(rr, recording, "position_error", curves, kept, looks)
    # log10 = 0: off by 1 m, the size of the orbit (or of the spring's swing) itself. "zero" sorts last.
    log_level(rr, recording, "position_error/zero", "1 m, the size of the motion", 0.0, kept)
    return course.time_series("position_error", "position error against the exact motion: log10 |q - q_exact| (m)",
                              kept[-1], [*fitted(curves, runs), [0.0]])


def log_energy_error(rr, recording, system, runs, kept, dt, looks):
    """log10 |E - E0| / |E0|, digits of energy lost: Euler climbs to 0 (100%), semi-implicit stays in a band."""
    curves = {}
    for name, (_, _, energies) in runs.items():
        curves[name] = log10_of(np.abs(relative_energy_error(energies[kept])))
    log_curves(rr, recording, "energy_error", curves, kept, looks)
    log_level(rr, recording, "energy_error/zero", "100% of E0", 0.0, kept)  # log10 = 0: all of it
    return course.time_series("energy_error", "energy error: log10 |E - E0| / |E0|", kept[-1],
                              [*fitted(curves, runs), [0.0]])


def fitted(curves: dict, runs: dict) -> list:
    """The curves a plot's y range is fitted to: those of the runs that did not blow up (all, if every one did),
    so a run that blew up is seen climbing out of the plot instead of squashing the others flat."""
    finite = [curves[name] for name, (_, _, energies) in runs.items() if overflow_step(energies) is None]
    return finite or list(curves.values())


def log_energy_change(rr, recording, system, runs, kept, dt, looks):
    """(E - E0) / |E0| in percent, sign kept: on freefall the two Eulers miss by the same amount, opposite ways."""
    curves = {}
    for name, (_, _, energies) in runs.items():
        with np.errstate(all="ignore"):
            curves[name] = relative_energy_error(energies[kept]) * 100.0
    logged = log_curves(rr, recording, "energy_change", curves, kept, looks)
    reach = 1.15 * float(np.abs(logged).max(initial=0.0)) or 1.0
    return course.time_series("energy_change", "energy change (E - E0) / |E0|, %", kept[-1], legend="LeftTop",
                              y_range=(-reach, reach))


def log_height(rr, recording, system, runs, kept, dt, looks):
    """Height z against the step: the body falls and never comes back, so no error is ever paid back."""
    curves = {name: positions[:, 2] for name, (positions, _, _) in runs.items()}
    # The default run's heights end 2 m apart after a 2 km fall: one line to the eye. Drawn widest first,
    # every one shows.
    logged = log_curves(rr, recording, "height", curves, kept, looks, course.layered_widths(curves))
    ends = [heights[-1] for heights in curves.values() if np.isfinite(heights[-1])]
    apart = f": the curves end {max(ends) - min(ends):.2g} m apart" if len(ends) > 1 else ""
    return course.time_series("height", f"height z (m){apart}", kept[-1], logged, legend="LeftBottom")


def log_member_paths(rr, recording, system, ensemble, kept, dt, looks):
    """An ensemble's 3D view: the first members' paths, one strip each, in the integrator's colour, framed on
    their exact motions and on the integrators whose members all stay near them (as log_flat frames)."""
    every_path, framed = [], []
    if system.get("exact"):
        framed.append(system["exact"](system["q0"][:SHOWN_MEMBERS], system["v0"][:SHOWN_MEMBERS], kept * dt))
    for name, summary in ensemble.items():
        strips = [member[course.drawable(member)] for member in summary["paths"].swapaxes(0, 1)]
        lines = rr.LineStrips3D(strips, colors=[looks[name].colour], radii=rr.components.Radius.ui_points(0.75))
        recording.log(f"ensemble_paths/{name}", lines, static=True)
        every_path.append(summary["paths"])
    framed += within_reach(framed, every_path) if framed else [p for p in every_path if course.drawable(p).all()]
    key_looks = course.looks(ensemble)  # the key says how many members blew up, where any did
    for name, summary in ensemble.items():
        if summary["diverged"].any():
            key_looks[name] = course.Look(key_looks[name].colour, f"{key_looks[name].label}:"
                                          f" {np.count_nonzero(summary['diverged']):,} members' energy overflowed")
    key = course.log_key(recording, "ensemble_paths/key", key_looks, framed or every_path)
    return course.from_above("ensemble_paths", f"the first {SHOWN_MEMBERS} members' paths",
                             [*(framed or every_path), key], tilt=0.35)


ROUNDOFF = 1e-16  # the ensemble's error spread draws anything smaller here: round-off of a number near 1


def log_error_spread(rr, recording, system, ensemble, kept, dt, looks):
    """Per integrator, each member's worst |E - E0| / |E0| so far (log10): the median member as a thick line,
    and thin lines for the best and the worst member, which share one entry in the legend.

    The worst-so-far never falls, so the curves read as "how bad it has got", with no spikes where an
    error happens to cross zero; the gap between the thin lines is how much the seed matters. Anything
    below ROUNDOFF is drawn on a grey floor there, so every curve starts at step 0 (where nothing has moved)."""
    logged = []
    for name, summary in ensemble.items():
        colour, label = course.looks(ensemble)[name]
        spread = course.Look(colour, f"{label}: best and worst member")  # one name: one legend entry for both
        median = course.Look(colour, f"{label}: median member")
        for column, (path, look, width) in enumerate((("min", spread, 1.0), ("median", median, 3.5),
                                                       ("max", spread, 1.0))):
            curve = log10_of(np.maximum(summary["error_spread"][:, column], ROUNDOFF))
            logged.append(course.log_series(recording, f"ensemble_error/{name}/{path}", kept, curve, look, width))
    log_level(rr, recording, "ensemble_error/roundoff", f"round-off (1e{np.log10(ROUNDOFF):.0f} and below)",
              np.log10(ROUNDOFF), kept)
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
