"""The .rrd recording, read back with Rerun's own reader: what the viewer is given (the bodies' values, each plot's
numbers, the blueprint's views and settings). How it looks without a screen: tools/screenshots.py.
"""

import json

import numpy as np
import pytest

import engine
import engine_ensembles
import engine_recording
from curriculum.common import recording as course

rerun_chunk = pytest.importorskip("rerun.chunk", reason="rerun-sdk is a core dependency; install the project")
rrb = pytest.importorskip("rerun.blueprint")

STEPS, DT = 2000, 0.01
SPATIAL = {"orbit": "orbit", "spring": "phase", "damped_spring": "phase"}  # the 3D view each system opens on


def packed(rgb):
    """Rerun stores a colour as one uint32, 0xRRGGBBAA."""
    r, g, b = rgb
    return (r << 24) | (g << 16) | (b << 8) | 0xFF


def read_recording(path):
    """(recording entry, {entity_path: [record_batch, ...]}, {blueprint_path: {column: first value}})."""
    reader = rerun_chunk.RrdReader(path)
    (recording,) = reader.recordings()
    (blueprint,) = reader.blueprints()
    entities = {}
    for chunk in reader.stream(store=recording).to_chunks():
        entities.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())
    settings = {}
    for chunk in reader.stream(store=blueprint).to_chunks():
        batch = chunk.to_record_batch()
        for name in batch.schema.names:
            if ":" in name:  # components are "Archetype:field"; the time and row-id columns are not
                values = batch.column(name).to_pylist()[0]
                settings.setdefault(chunk.entity_path, {})[name] = values[0] if len(values) == 1 else values
    return recording, entities, settings


def column(batches, name):
    """A column's values over all the entity's chunks, in step order."""
    rows = [row for batch in batches if name in batch.schema.names for row in batch.column(name).to_pylist()]
    assert rows, f"no column {name}"
    return rows


def opens_on(last_step):
    """A plot's time range: step 0 to the last, and course.END_ROOM past it, so the viewer labels the last step."""
    return {"start": 0, "end": last_step + int(np.ceil(course.END_ROOM * last_step))}


def assert_opens_the_courses_way(settings, last_step):
    """course.opening: every plot over the whole run, the side panels folded, the cursor on the step timeline
    following to the last step."""
    for (kind, origin), props in views_of(settings).items():
        if kind == "TimeSeries":
            assert props["TimeAxis:view_range"] == opens_on(last_step), f"{origin} opens on the whole run"
    for panel in ("/blueprint_panel", "/selection_panel"):
        assert settings[panel]["PanelBlueprint:state"] == rrb.components.PanelState.Hidden.value
    time_panel = settings["/time_panel"]
    assert time_panel["TimePanelBlueprint:state"] == rrb.components.PanelState.Collapsed.value
    assert time_panel["TimePanelBlueprint:timeline"] == "step"
    assert time_panel["TimePanelBlueprint:play_state"] == rrb.components.PlayState.Following.value


def views_of(settings):
    """{(class, origin): {archetype field: value, ...}} for every view in the blueprint."""
    views = {}
    for path, fields in settings.items():
        if "ViewBlueprint:class_identifier" in fields:
            props = {k: v for sub, f in settings.items() if sub.startswith(path + "/") for k, v in f.items()}
            views[(fields["ViewBlueprint:class_identifier"], fields["ViewBlueprint:space_origin"])] = props
    return views


def frame(props):  # (target, half): where the camera looks, and the least it frames either side (half its height)
    target, eye = np.array(props["EyeControls3D:look_target"]), np.array(props["EyeControls3D:position"])
    return target, (eye[2] - target[2]) / 2.0


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Each system's default run: what the recording holds, and the same run simulated here."""
    cases = {}
    for name in tuple(engine.SYSTEMS):
        out = tmp_path_factory.mktemp(name)
        assert engine.main(["--system", name, "--out", str(out)]) == 0
        system = engine.build_system(name, np.random.default_rng(0))
        runs = {i: engine.simulate(step, system, DT, STEPS) for i, step in engine.integrators_for(system).items()}
        cases[name] = (*read_recording(out / engine.RECORDING_FILE), system, runs)
    return cases


@pytest.mark.parametrize("system_name, series", [("orbit", "position_error"), ("damped_spring", "position_error"),
                                                 ("orbit", "energy_error"), ("spring", "energy_error")])
def test_each_error_is_the_log_of_its_truth_step_for_step(recorded, system_name, series):
    """log10 of the distance to the exact motion (Kepler's equation for the orbit, the closed form for the damped
    spring, the implicit step's too), or of the relative energy drift; exact zeros have no logarithm."""
    _, entities, _, system, runs = recorded[system_name]
    exact, finals = system["exact"](system["q0"], system["v0"], np.arange(STEPS + 1) * DT), {}
    for name, (positions, _, energies) in runs.items():
        truth = (np.sqrt(np.sum((positions - exact) ** 2, axis=1)) if series == "position_error"
                 else np.abs(energies - energies[0]) / abs(energies[0]))
        logged = entities[f"/{series}/{name}"]
        steps = column(logged, "step")
        assert steps == [i for i in range(STEPS + 1) if truth[i] > 1e-14], "only exact zeros have no log"
        np.testing.assert_allclose(np.ravel(column(logged, "Scalars:scalars")), np.log10(truth[steps]),
                                   rtol=1e-12 if series == "position_error" else 0)
        look = course.looks(runs)[name]
        assert column(logged, "SeriesLines:colors")[0] == [packed(look.colour)]
        assert column(logged, "SeriesLines:names")[0] == [look.label]
        finals[name] = np.log10(truth[-1])
    if (system_name, series) == ("orbit", "position_error"):  # metres off after 20 s: Euler by its whole radius,
        assert finals["euler"] > -0.5 and -4 < finals["semi_implicit"] < -1 and finals["rk4"] < -7  # mm, nm


def test_freefall_shows_the_signed_energy_change_and_the_height(recorded):
    _, entities, settings, _, runs = recorded["freefall"]
    finals = {}
    for name, (positions, _, energies) in runs.items():
        change = entities[f"/energy_change/{name}"]
        assert column(change, "step") == list(range(STEPS + 1))
        logged = np.ravel(column(change, "Scalars:scalars"))
        np.testing.assert_array_equal(logged, (energies - energies[0]) / abs(energies[0]) * 100.0)
        finals[name] = logged[-1]
        np.testing.assert_array_equal(np.ravel(column(entities[f"/height/{name}"], "Scalars:scalars")),
                                      positions[:, 2])
    drift = engine.energy_drift(runs["euler"][2])["rel_final"] * 100.0  # the report's +9.3%
    assert finals["euler"] == pytest.approx(drift) and finals["euler"] > 9.0
    assert finals["semi_implicit"] == pytest.approx(-finals["euler"], rel=1e-9), "the same amount, the other way"
    assert abs(finals["rk4"]) < 1e-6
    low, high = views_of(settings)[("TimeSeries", "energy_change")]["ScalarAxis:range"]
    assert low == -high and high > finals["euler"], "zero in the middle: the two signs are what the eye sees"


EXPECTED_VIEWS = {
    "orbit": {("3D", "orbit"), ("TimeSeries", "position_error"), ("TimeSeries", "energy_error")},
    "spring": {("3D", "phase"), ("TimeSeries", "energy_error")},
    "freefall": {("TimeSeries", "energy_change"), ("TimeSeries", "height")},
    "damped_spring": {("3D", "phase"), ("TimeSeries", "position_error")},
}


@pytest.mark.parametrize("system_name", engine.SYSTEMS)
def test_each_system_opens_on_its_own_views_and_every_plot_on_the_whole_run(recorded, system_name):
    """Its views, every plot over all the steps with every value on screen, the side panels folded, and the file
    opening on the last step."""
    recording, entities, settings, _, _ = recorded[system_name]
    assert recording.application_id == "zero2robot-ch3_3-engine"
    views = views_of(settings)
    if system_name in EXPECTED_VIEWS:
        assert set(views) == EXPECTED_VIEWS[system_name], "the views this system's lesson needs, and no others"
    else:  # a system declared later, before anyone chose its views: the default ones
        assert ("TimeSeries", "energy_error") in views, views
    assert_opens_the_courses_way(settings, STEPS)
    for (kind, origin), props in views.items():
        if kind != "TimeSeries":
            continue
        low, high = props["ScalarAxis:range"]
        values = np.concatenate([np.ravel(column(batches, "Scalars:scalars"))
                                 for path, batches in entities.items() if path.startswith(f"/{origin}/")])
        assert low < values.min() and values.max() < high, f"{origin}: every value on screen"
        assert props["PlotInteraction:tooltip_mode"] == rrb.components.TooltipMode.All.value
    assert settings["/time_panel"]["TimePanelBlueprint:fps"] * course.PLAYBACK_SECONDS == pytest.approx(STEPS)


@pytest.mark.parametrize("system_name", SPATIAL)
def test_each_body_travels_its_path_beside_its_key_and_the_camera_frames_them_all(recorded, system_name):
    """Each body moves step by step along its whole run, its trail drawn in its colour. The key names every
    integrator in its colour, in a column right of every path, one row apart: never on a trail (RK4's on the
    spring's red trails), never piled up (the damped spring's four at the origin). The camera is centred on the
    box around every trail, the key and the axes' names, and high enough to frame it; a phase plane draws its
    exact motion a hair below the integrators' lines."""
    _, entities, settings, system, runs = recorded[system_name]
    origin, looks = SPATIAL[system_name], course.looks(runs)
    for name, (positions, velocities, _) in runs.items():  # the orbit's bodies in space, a spring's in (x, v_x)
        plane = np.stack([positions[:, 0], velocities[:, 0], 0 * velocities[:, 0]], axis=1)
        shown = positions if origin == "orbit" else plane
        body, trail = entities[f"/{origin}/{name}/body"], entities[f"/{origin}/{name}/trail"]
        assert column(body, "step") == list(range(STEPS + 1)), "one position per step, on the step timeline"
        travelled = np.concatenate(column(body, "Points3D:positions"))
        np.testing.assert_array_equal(travelled[:, :2], shown[:, :2].astype(np.float32))
        lift = travelled[:, 2] - shown[:, 2].astype(np.float32)  # drawn a hair above or below the others
        assert np.ptp(lift) < 1e-6, "the same lift at every step"
        assert abs(lift[0]) < 0.01 * np.ptp(shown[:, :2], axis=0).max(), "a hair: under 1% of the path's size"
        np.testing.assert_array_equal(np.array(column(trail, "LineStrips3D:strips")[0][0]), travelled)
        colour = [packed(looks[name].colour)]
        assert column(body, "Points3D:colors")[0] == column(trail, "LineStrips3D:colors")[0] == colour
    key = entities[f"/{origin}/key"]
    assert column(key, "Points3D:labels")[0] == [look.label for look in looks.values()]
    assert column(key, "Points3D:colors")[0] == [packed(look.colour) for look in looks.values()]
    spots = np.array(column(key, "Points3D:positions")[0])
    trails = np.concatenate([np.array(column(entities[f"/{origin}/{name}/trail"], "LineStrips3D:strips")[0][0])
                             for name in runs])
    span = np.ptp(trails[:, :2], axis=0).max()
    assert (spots[:, 0] > trails[:, 0].max() + 0.1 * span).all(), "right of every path, clear of the trails"
    assert (np.diff(spots[:, 1]) < -0.05 * span).all(), "one row per name, top to bottom, apart"
    axes = entities.get(f"/{origin}/axes")  # the phase plane's axes and their names
    axes = [np.array(strip) for strip in column(axes, "LineStrips3D:strips")[0]] if axes else []
    points = np.concatenate([trails, *axes, spots])
    target, half = frame(views_of(settings)[("3D", origin)])
    np.testing.assert_allclose(target[:2], (points.min(axis=0)[:2] + points.max(axis=0)[:2]) / 2, atol=1e-6)
    assert 2 * half >= np.ptp(points[:, :2], axis=0).max(), "high enough that the widest path fits the view"
    assert (np.abs(spots[:, :2] - target[:2]) < half).all(), "the key is inside the framed view"
    if origin == "phase":
        exact = np.array(column(entities["/phase/exact"], "LineStrips3D:strips")[0][0])
        times = np.arange(STEPS + 1) * DT
        np.testing.assert_allclose(exact[:, 0], system["exact"](system["q0"], system["v0"], times)[:, 0], atol=1e-6)
        if system_name == "spring":  # x = x0 cos(2t): v = -2 x0 sin(2t)
            np.testing.assert_allclose(exact[:, 1], -2.0 * system["q0"][0] * np.sin(2.0 * times), atol=1e-5)
        assert (exact[:, 2] < 0).all(), "a hair below the plane, so the integrators' lines lie on top"


def test_long_runs_are_thinned_in_the_recording(tmp_path, capsys, monkeypatch):
    """Past MAX_POINTS_PER_SERIES states (100,000; 1,000 here, so the run is short) every k-th step is kept."""
    monkeypatch.setattr(engine, "MAX_POINTS_PER_SERIES", 1_000)
    steps = 2_500
    assert engine.main(["--integrator", "euler", "--steps", str(steps), "--out", str(tmp_path)]) == 0
    assert "recording keeps 1 state in 3 of 2,501 per integrator" in capsys.readouterr().out
    _, entities, settings, = read_recording(tmp_path / engine.RECORDING_FILE)
    logged_steps = column(entities["/energy_error/euler"], "step")
    assert len(logged_steps) <= engine.MAX_POINTS_PER_SERIES + 1
    assert logged_steps[0] <= 3 and logged_steps[-1] == steps
    assert column(entities["/orbit/euler/body"], "step") == engine.kept_steps(steps, 3).tolist()
    assert_opens_the_courses_way(settings, steps)


def test_a_new_system_or_integrator_records_before_anyone_writes_it_a_view_or_a_colour(tmp_path):
    """A maintainer adds a system (an anharmonic spring, no exact motion) or an integrator (velocity Verlet) and has
    not touched the recording: the system gets its paths and energy error (and its position error where it has an
    exact motion), the integrator a spare colour and its own name."""
    assert set(engine_recording.RECORDED_VIEWS) <= set(engine.SYSTEMS)
    spring = {**engine.build_system("spring", np.random.default_rng(0)), "name": "anharmonic"}
    paths, energy = engine_recording.log_paths, engine_recording.log_energy_error
    assert engine_recording.views_for(spring) == (paths, energy, engine_recording.log_position_error)
    assert engine_recording.views_for({**spring, "exact": None}) == (paths, energy)
    system = {**spring, "exact": None}
    runs = {name: engine.simulate(step, system, DT, 100) for name, step in engine.integrators_for(system).items()}
    runs["verlet"] = runs["rk4"]
    data, _ = engine_recording.record(system, runs, engine.kept_steps(100), DT, run_id="new")
    (tmp_path / "made.rrd").write_bytes(data)
    _, entities, settings = read_recording(tmp_path / "made.rrd")
    assert set(views_of(settings)) == {("3D", "paths"), ("TimeSeries", "energy_error")}
    colours = {name: column(entities[f"/paths/{name}/trail"], "LineStrips3D:colors")[0][0] for name in runs}
    assert len(set(colours.values())) == len(runs), "every integrator its own colour"
    assert colours["verlet"] in [packed(colour) for colour in course.SPARE_COLOURS]
    assert column(entities["/paths/key"], "Points3D:labels")[0][-1] == "verlet"
    assert column(entities["/energy_error/verlet"], "SeriesLines:names")[0] == ["verlet"]


def test_the_ensemble_recording_holds_member_paths_and_tells_every_curve_apart(tmp_path):
    """Best, median and worst member of max over steps 0..k of |E - E0| / |E0|, against a plain loop (with
    every=7 the steps between kept ones count too); then what an --ensemble run records."""
    rng = np.random.default_rng(3)
    energies = 1.0 + np.cumsum(rng.normal(0.0, 1e-3, (50, 5)), axis=0)
    energies[0] = 1.0
    energies[30:, 4] = np.nan  # a member that diverged at step 30
    kept = engine.kept_steps(49, 7)
    spread = engine_ensembles.error_spread(energies, kept)
    for row, k in enumerate(kept):
        worst = [np.max(np.abs(energies[: k + 1, i] - 1.0)) if np.isfinite(energies[: k + 1, i]).all() else np.inf
                 for i in range(5)]
        np.testing.assert_allclose(spread[row], [min(worst), np.median(worst), max(worst)], rtol=1e-12)
    assert (spread[1:] >= spread[:-1]).all(), "a worst-so-far never falls: no spikes"
    assert engine.main(["--ensemble", "30", "--out", str(tmp_path)]) == 0
    _, entities, settings = read_recording(tmp_path / engine.RECORDING_FILE)
    looks = course.looks(engine.integrators_for(engine.build_system("orbit", np.random.default_rng(0))))
    legend = {}
    for name, look in looks.items():
        assert len(column(entities[f"/ensemble_paths/{name}"], "LineStrips3D:strips")[0]) == 20  # SHOWN_MEMBERS
        for which, width in (("min", 1.0), ("median", 3.5), ("max", 1.0)):
            series = entities[f"/ensemble_error/{name}/{which}"]
            assert 1900 < len(column(series, "step")) <= STEPS + 1
            assert column(series, "SeriesLines:colors")[0] == [packed(look.colour)]
            assert column(series, "SeriesLines:widths")[0] == [width], "the median thick, the spread thin"
            (label,) = column(series, "SeriesLines:names")[0]
            legend.setdefault(label, set()).add(which)
            assert (np.diff(np.ravel(column(series, "Scalars:scalars"))) >= 0).all(), f"{name} {which} never falls"
    assert sorted(map(sorted, legend.values())) == [["max", "min"]] * len(looks) + [["median"]] * len(looks), \
        "one legend entry per median, one shared by each integrator's best and worst member"
    assert len(set(legend)) == 2 * len(looks)
    (key_names,) = column(entities["/ensemble_paths/key"], "Points3D:labels")
    assert key_names == [look.label for look in looks.values()]
    assert ("3D", "ensemble_paths") in views_of(settings)


def test_the_courses_recording_api_opens_any_time_series_the_same_way(tmp_path):
    """curriculum/common/recording.py as its docstring shows it (exercise 7's shape): a few lines, the engine's
    opening (checked on every system above), and NaN left out, not drawn."""
    steps = np.arange(301)
    errors = {"orbit": {"euler": steps * 1e-3, "verlet": np.cos(steps / 10.0)},
              "spring": {"rk4": np.full(301, np.nan), "semi_implicit": -steps * 1e-4}}

    def fill(stream):
        views = []
        for system, curves in errors.items():
            look = course.looks(curves)
            logged = [course.log_series(stream, f"{system}/{n}", steps, curves[n], look[n]) for n in curves]
            views.append(course.time_series(system, f"{system}: (E - E0) / |E0|", steps[-1], logged))
        return course.opening(rrb.Vertical(*views), steps[-1])

    (tmp_path / "made.rrd").write_bytes(course.recorded("zero2robot-test", fill))
    recording, entities, settings = read_recording(tmp_path / "made.rrd")
    views = views_of(settings)
    assert recording.application_id == "zero2robot-test" and set(views) == {("TimeSeries", "orbit"),
                                                                           ("TimeSeries", "spring")}
    assert views[("TimeSeries", "orbit")]["TimeAxis:view_range"] == {"start": 0, "end": 312}, "4% past the end"
    assert_opens_the_courses_way(settings, 300)
    low, high = views[("TimeSeries", "orbit")]["ScalarAxis:range"]
    assert low < -0.99 and high > 0.99, "fitted to every value logged"
    assert column(entities["/orbit/verlet"], "SeriesLines:names")[0] == ["verlet"]
    assert not any("Scalars:scalars" in b.schema.names for b in entities["/spring/rk4"]), "NaN is left out"
    assert len(column(entities["/spring/semi_implicit"], "Scalars:scalars")) == 301


# --- every recording the issue names, and the edges of the flags: framed, every integrator seen ---

LISTED = {  # issue 24's recordings, made as a student makes them (the README's spring command included)
    "orbit": ["--system", "orbit"],
    "spring": ["--system", "spring"],
    "spring at dt 0.05": ["--system", "spring", "--dt", "0.05"],
    "freefall": ["--system", "freefall"],
    "damped spring": ["--system", "damped_spring"],
    "damped spring at b 300": ["--system", "damped_spring", "--damping", "300"],
    "orbit at dt 0.5": ["--system", "orbit", "--dt", "0.5"],
    "ensemble of 1000": ["--ensemble", "1000"],
}  # exercises 5 and 7 frame and fill their own recordings: tests/test_ex5.py, tests/test_ex7.py
EDGES = {  # where every integrator diverges, the damping limit, one step, a blow-up at the very first step
    "spring at dt 3": ["--system", "spring", "--dt", "3"],
    "damped spring at b 1e6": ["--system", "damped_spring", "--damping", "1e6"],
    "orbit, 1 step": ["--system", "orbit", "--steps", "1"],
    "ensemble, 1 step": ["--ensemble", "20", "--steps", "1"],
    "spring at dt 1e300": ["--system", "spring", "--dt", "1e300", "--steps", "3"],
    "orbit at dt 5": ["--system", "orbit", "--dt", "5"],
}
# where the grey exact motion must be drawn smooth; at dt 1e300 even its own samples are round-off (cos 2e300)
SMOOTH = {*LISTED, "orbit at dt 5"}


def is_grey(packed_colour):
    return len({(packed_colour >> shift) & 0xFF for shift in (24, 16, 8)}) == 1  # red == green == blue


def must_frame(entities, origin, labels):
    """The points a spatial view must frame, as the recording holds them: its exact motion where it draws one,
    or else every path of a run whose key names no blow-up (an ensemble's members)."""
    if f"/{origin}/exact" in entities:
        return [np.array(strip) for strip in column(entities[f"/{origin}/exact"], "LineStrips3D:strips")[0]]
    bounded = [name for name, label in labels.items() if "overflowed" not in label]
    return [np.array(strip) for path, batches in entities.items() for name in bounded
            if path in (f"/{origin}/{name}", f"/{origin}/{name}/trail")
            for strips in column(batches, "LineStrips3D:strips") for strip in strips]


def key_labels(entities, origin, names):
    """{integrator: its label in the view's key}, each found by its colour."""
    key = entities[f"/{origin}/key"]
    label_of = dict(zip(column(key, "Points3D:colors")[0], column(key, "Points3D:labels")[0], strict=True))
    return {name: label_of[packed(look.colour)] for name, look in course.looks(names).items()}


@pytest.mark.parametrize("case", [pytest.param(case, marks=pytest.mark.slow if case == "ensemble of 1000" else ())
                                  for case in [*LISTED, *EDGES]])
def test_every_recording_frames_what_stays_bounded_and_shows_every_integrator(case, tmp_path):
    """Issue 24, from what each recording holds: every spatial view's camera frames the exact motion (or the runs
    that stay bounded), and the exact motion fills a good part of it (not a dot in a corner, not off the edge);
    a run that blew up says so in the key with the step metrics.json names; every integrator in a plot has a
    value to draw; lines that could lie on one another differ in width; and no empty column (which crashes the
    viewer) is ever sent. pytest never opens a viewer: tools/screenshots.py shows the same recordings."""
    assert engine.main([*{**LISTED, **EDGES}[case], "--out", str(tmp_path)]) == 0
    _, entities, settings = read_recording(tmp_path / engine.RECORDING_FILE)
    metrics = json.loads((tmp_path / engine.METRICS_FILE).read_text())
    listed = case in LISTED
    for path, batches in entities.items():
        assert all(batch.num_rows > 0 for batch in batches), f"{path}: an empty column (Rerun 0.41's viewer panics)"
    integrators = list(metrics["drift"])
    for (kind, origin), props in views_of(settings).items():
        if kind == "3D":
            names = integrators if f"/{origin}/key" in entities else []
            labels = key_labels(entities, origin, names) if names else {}
            for name, label in labels.items():  # the step a run blew up at: the table's and metrics.json's
                step = metrics["drift"][name].get("energy_overflow_step")
                if origin != "ensemble_paths":
                    assert (f"energy overflowed at step {step:,}" in label) if step else ("overflowed" not in label)
            points = np.concatenate([p.reshape(-1, 3) for p in must_frame(entities, origin, labels)])
            target, half = frame(props)
            assert (np.abs(points[:, :2] - target[:2]) <= half).all(), f"{case}, {origin}: all of it in the frame"
            size = np.ptp(points[:, :2], axis=0).max()
            if listed:
                assert size >= 0.4 * half, f"{case}, {origin}: the motion fills the frame, {size:.3g} of {half:.3g}"
            if case in SMOOTH and f"/{origin}/exact" in entities:  # a curve, not chords across the orbit
                chord = np.abs(np.diff(points[:, :2], axis=0)).max()
                assert chord <= 0.1 * size, f"{case}: the exact motion's points {chord:.3g} apart, {size:.3g} across"
            trails = [f"/{origin}/{name}/trail" for name in names if f"/{origin}/{name}/trail" in entities]
            radii = [column(entities[trail], "LineStrips3D:radii")[0][0] for trail in trails]
            assert len(set(radii)) == len(radii), f"{case}, {origin}: trails that coincide still show"
        else:
            lines = {path: batches for path, batches in entities.items() if path.startswith(f"/{origin}/")
                     and not is_grey(column(batches, "SeriesLines:colors")[0][0])}
            assert lines, f"{case}, {origin}: a plot with nothing but references"
            for path, batches in lines.items():
                values = [v for b in batches if "Scalars:scalars" in b.schema.names
                          for v in np.ravel(b.column("Scalars:scalars").to_pylist())]
                if listed:
                    assert np.isfinite(values).any(), f"{case}: {path} has no value to draw"
            by_name = {path.rsplit("/", 1)[1]: batches for path, batches in lines.items()}
            if set(by_name) <= set(integrators) and len(by_name) > 1:  # one line per integrator: layered
                widths = [column(batches, "SeriesLines:widths")[0][0] for batches in by_name.values()]
                assert len(set(widths)) == len(widths), f"{case}, {origin}: lines that coincide still show"
