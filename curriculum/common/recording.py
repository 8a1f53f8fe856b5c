"""The course's recordings: one colour-blind-safe palette (Okabe and Ito's, kept apart by tests/test_palette.py) and
one way every recording opens: the whole run, the cursor on the last step, side panels closed, everything framed.
`recorded(app_id, fill)` gives the .rrd bytes; fill(stream) logs and returns an `opening(...)`. Rerun loads late."""

import math
from collections import namedtuple

import numpy as np

from curriculum.common.outputs import signals_held

PALETTE = {  # Okabe & Ito's colour-universal set (black left out: it is the viewer's background)
    "vermillion": (213, 94, 0), "sky_blue": (86, 180, 233), "yellow": (240, 228, 66), "blue": (0, 114, 178),
    "bluish_green": (0, 158, 115), "reddish_purple": (204, 121, 167), "orange": (230, 159, 0),
}
BACKGROUND = (13, 13, 13)  # the viewer's dark background (Rerun 0.41), read off a screenshot's pixels
GREY = (150, 150, 150)  # reference lines and axes: no integrator's colour
COLOURS = {"euler": PALETTE["vermillion"], "semi_implicit": PALETTE["sky_blue"], "rk4": PALETTE["yellow"],
           "implicit": PALETTE["blue"]}
LABELS = {"euler": "explicit Euler", "semi_implicit": "semi-implicit Euler", "rk4": "RK4",
          "implicit": "implicit (damping)"}
SPARE_COLOURS = [colour for colour in PALETTE.values() if colour not in COLOURS.values()]  # for new names
PLAYBACK_SECONDS = 20.0  # pressing play runs the whole recording in about this long, whatever its length
FEW_POINTS = 50  # a plot's line with this many values or fewer also marks each one
END_ROOM = 0.04  # a plot's time axis runs this much past the last step, so the viewer labels that step too
REACH = 2.0  # a spatial view frames the runs that stay within this many times the exact motion's size
DRAW_LIMIT = 1e30  # Rerun stores float32 (to 3.4e38): headroom for the camera and labels; inf and NaN never drawn
Look = namedtuple("Look", ["colour", "label"])  # how one name's lines and points look


def looks(names) -> dict:
    """{name: Look(colour, label)}; a name the course has no colour for takes the next spare colour and its name."""
    spare = [colour for colour in SPARE_COLOURS if colour not in (COLOURS.get(name) for name in names)]
    new = [name for name in names if name not in COLOURS]
    return {name: Look(COLOURS[name] if name in COLOURS else spare[new.index(name) % len(spare)],
                       LABELS.get(name, name)) for name in names}


def opening(story, last_step: int, timeline: str = "step"):
    """The Blueprint: `story` (a view, views to stack, an rrb layout) fills the window; play takes PLAYBACK_SECONDS."""
    import rerun.blueprint as rrb

    if isinstance(story, list | tuple):  # several views: one under the other
        story = rrb.Vertical(*story)
    return rrb.Blueprint(story, rrb.BlueprintPanel(state="hidden"), rrb.SelectionPanel(state="hidden"),
                         rrb.TimePanel(state="collapsed", timeline=timeline, play_state="following",
                                       fps=max(int(last_step) / PLAYBACK_SECONDS, 1.0)))


def recorded(application_id: str, fill, recording_id: str | None = None) -> bytes:
    """The .rrd bytes of a recording built in memory: fill(stream) logs into `stream` and returns the blueprint."""
    import rerun as rr

    with signals_held():  # until the bytes are drained: a stream dropped with data in its sink prints a WARN line
        stream = rr.RecordingStream(application_id, recording_id=recording_id)
        in_memory = stream.memory_recording()
        try:
            stream.send_blueprint(fill(stream), make_active=False, make_default=True)
        finally:
            data = in_memory.drain_as_bytes()
            del in_memory, stream  # the stream's own flush (its __del__) runs now, while signals still wait
    return data


def on_steps(steps):
    import rerun as rr

    return [rr.TimeColumn("step", sequence=steps)]


def log_series(stream, entity: str, steps, values, look: Look, width: float | None = None):
    """One line on the `step` timeline, non-finite values left out, a short line's values marked; no column for no value
    (empty columns crash Rerun 0.41's viewer). Returns the values logged."""
    import rerun as rr

    steps, values = np.asarray(steps), np.asarray(values, dtype=float)
    style = rr.SeriesLines(colors=[look.colour], names=[look.label], widths=None if width is None else [width])
    stream.log(entity, style, static=True)
    shown = np.isfinite(values)
    level = np.count_nonzero(shown) == 2 and np.ptp(values[shown]) == 0.0  # a reference across the run: no marks
    if 0 < np.count_nonzero(shown) <= FEW_POINTS and not level:  # a short run: mark each value (one draws no line)
        marker = rr.SeriesPoints(colors=[look.colour], names=[look.label], marker_sizes=[3.0 + (width or 1.0)])
        stream.log(entity, marker, static=True)
    if shown.any():
        stream.send_columns(entity, indexes=on_steps(steps[shown]), columns=rr.Scalars.columns(scalars=values[shown]))
    return values[shown]


def layered_widths(names, widest: float = 7.0, thinnest: float = 1.5) -> dict:
    """{name: line width} so that lines on one another all show: the first drawn (in name order) is the widest."""
    step = (widest - thinnest) / max(len(names) - 1, 1)
    return {name: widest - i * step if len(names) > 1 else thinnest for i, name in enumerate(sorted(names))}


def padded(values, margin: float = 0.05):
    """(low, high) of the finite values with a margin; (-1.0, 1.0) when none is finite."""
    values = np.concatenate([np.ravel(v) for v in values]) if isinstance(values, list | tuple) else np.ravel(values)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return (-1.0, 1.0)
    low, high = float(values.min()), float(values.max())
    pad = margin * ((high - low) or 1.0)
    return (low - pad, high + pad)


def time_series(origin: str, name: str, last_step: int, values=None, legend: str = "RightBottom", y_range=None):
    """A plot of every series under `origin` on steps 0..last_step, its y range fitted to `values` or y_range."""
    import rerun as rr
    import rerun.blueprint as rrb

    end = int(last_step) + math.ceil(END_ROOM * int(last_step))
    whole_run = rr.TimeRange(start=rrb.TimeRangeBoundary.absolute(seq=0), end=rrb.TimeRangeBoundary.absolute(seq=end))
    return rrb.TimeSeriesView(origin=origin, name=name, axis_x=rrb.TimeAxis(view_range=whole_run),
                              axis_y=rrb.ScalarAxis(range=y_range or padded(values if values is not None else [])),
                              plot_legend=rrb.PlotLegend(corner=legend),
                              interaction=rrb.PlotInteraction(tooltip_mode="All"))


def drawable(points):
    return (np.abs(points) < DRAW_LIMIT).all(axis=-1)


def extent(paths):
    """The corners (low, high) of the box around the paths' drawable points; a unit box if there are none."""
    points = np.concatenate([np.reshape(p, (-1, 3))[drawable(np.reshape(p, (-1, 3)))] for p in paths])
    if len(points) == 0:
        return np.full(3, -1.0), np.full(3, 1.0)
    return points.min(axis=0), points.max(axis=0)


def near(reference, paths, reach: float = REACH) -> list:
    """The paths to frame with `reference`: drawable and within `reach` times its half-width of its centre (x, y)."""
    low, high = extent(reference)
    centre, half = (low + high)[:2] / 2.0, float(max(high[0] - low[0], high[1] - low[1])) / 2.0
    kept = []
    for path in paths:
        points = np.reshape(path, (-1, 3))
        if drawable(points).all() and (np.abs(points[:, :2] - centre) <= reach * half).all():
            kept.append(path)
    return kept


def from_above(origin: str, name: str, paths, tilt: float = 0.0, margin: float = 1.2):
    """A 3D view looking down on z = 0 at `paths`, +y up the screen (Rerun's 2D views point y down)."""
    import rerun.blueprint as rrb

    low, high = extent(paths)
    centre = (low + high) / 2.0
    distance = margin * float(max(high[0] - low[0], high[1] - low[1]) or 1.0)
    up = [0.0, 0.0, 1.0] if tilt else [0.0, 1.0, 0.0]
    eye = rrb.EyeControls3D(kind="Orbital", look_target=centre.tolist(), eye_up=up,
                            position=(centre + [0.0, -tilt * distance, distance]).tolist())
    lines = rrb.LineGrid3D(visible=True, spacing=0.5)
    return rrb.Spatial3DView(origin=origin, name=name, eye_controls=eye, line_grid=lines)


def log_key(stream, entity: str, looks: dict, paths):
    """A spatial view's key right of `paths`, a dot and a label per name. Returns its points, for from_above()."""
    import rerun as rr

    low, high = extent(paths)
    span = float(max(high[0] - low[0], high[1] - low[1]) or 1.0)
    # rows share the paths' height, never closer than a tenth of the view (a flat phase plane piles labels up)
    gap = max(min(0.2 * span, float(high[1] - low[1] or span) / max(len(looks), 1)), 0.1 * span)
    names = list(looks)
    positions = np.array([[float(high[0]) + 0.15 * span, float(high[1]) - i * gap, 0.0] for i in range(len(names))])
    labels = [looks[n].label.replace(": ", "\n", 1) for n in names]
    key = rr.Points3D(positions, colors=[looks[n].colour for n in names], labels=labels,
                      radii=rr.components.Radius.ui_points(6.0), show_labels=True)
    stream.log(entity, key, static=True)
    return positions


def log_axes(stream, entity: str, low, high, names: tuple[str, str], scales=(1.0, 1.0)) -> None:
    """Two axes through the origin, named past their tips, ticked at round numbers as far apart on both, in true
    units (`scales`)."""
    import rerun as rr

    grey = [GREY]
    (x0, y0), (x1, y1) = (float(low[0]), float(low[1])), (float(high[0]), float(high[1]))
    lines = rr.LineStrips3D([[[x0, 0, 0], [x1, 0, 0]], [[0, y0, 0], [0, y1, 0]]], colors=grey,
                            radii=rr.components.Radius.ui_points(1.0))
    stream.log(entity, lines, static=True)
    tips = rr.Points3D([[x1, 0, 0], [0, y1, 0]], radii=[0.0], colors=[[200, 200, 200]], labels=list(names),
                       show_labels=True)
    stream.log(f"{entity}/names", tips, static=True)
    ticks = []
    longest = max(abs(x0), abs(x1), abs(y0), abs(y1))  # one spacing for both axes, from the longer: 4 to 9 ticks
    unit = 10.0 ** math.floor(math.log10(longest)) if longest > 0.0 else 1.0
    unit /= 5.0 if longest < 2.0 * unit else 2.0 if longest < 5.0 * unit else 1.0
    for axis, (start, end) in enumerate(((x0, x1), (y0, y1))):
        for k in range(math.ceil(start / unit), math.floor(end / unit) + 1):
            at_tip = abs(k * unit - end) < 0.15 * (end - start)  # a tick there would sit under the axis name
            if k and not at_tip:
                ticks.append([k * unit if axis == 0 else 0.0, k * unit if axis == 1 else 0.0, 0.0])
    marks = rr.Points3D(ticks, radii=rr.components.Radius.ui_points(3.0), colors=grey,
                        labels=[f"{t[0] / scales[0] + t[1] / scales[1]:g}" for t in ticks], show_labels=True)
    stream.log(f"{entity}/ticks", marks, static=True)
