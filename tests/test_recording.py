"""The .rrd recording, read back with Rerun's own reader and checked against the run.

What pytest cannot see without a screen (how the views look) tools/screenshots.py shows in the real
viewer; here we check what the viewer is given: the moving bodies' values, each plot's numbers, and
the blueprint's views and settings.
"""

import numpy as np
import pytest

import engine
import engine_ensembles
import engine_recording

rerun_chunk = pytest.importorskip("rerun.chunk", reason="rerun-sdk is a core dependency; install the project")
rrb = pytest.importorskip("rerun.blueprint")

STEPS, DT = 2000, 0.01


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
    rows = []
    for batch in batches:
        if name in batch.schema.names:
            rows += batch.column(name).to_pylist()
    assert rows, f"no column {name}"
    return rows


def views_of(settings):
    """{(class, origin): {archetype field: value, ...}} for every view in the blueprint."""
    views = {}
    for path, fields in settings.items():
        if "ViewBlueprint:class_identifier" in fields:
            props = {k: v for sub, f in settings.items() if sub.startswith(path + "/") for k, v in f.items()}
            key = (fields["ViewBlueprint:class_identifier"], fields["ViewBlueprint:space_origin"])
            views[key] = props
    return views


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Each system's default run: what the recording holds, and the same run simulated here."""
    cases = {}
    for name in engine.SYSTEMS:
        out = tmp_path_factory.mktemp(name)
        assert engine.main(["--system", name, "--out", str(out)]) == 0
        system = engine.build_system(name, np.random.default_rng(0))
        runs = {i: engine.run(name, i, DT, STEPS) for i in engine.integrators_for(system)}
        cases[name] = (*read_recording(out / engine.RECORDING_FILE), system, runs)
    return cases


def test_application_id_is_valid_and_there_is_one_recording(recorded):
    recording, entities, _, _, _ = recorded["orbit"]
    assert recording.application_id == "zero2robot-ch3_3-engine"
    assert "/orbit/attractor" in entities


@pytest.mark.parametrize("system_name", ["orbit", "spring"])
def test_each_body_travels_its_run_step_by_step_along_its_whole_path(recorded, system_name):
    _, entities, _, _, runs = recorded[system_name]
    view = {"orbit": "orbit", "spring": "phase"}[system_name]
    bodies, labels = {}, {}
    for name, (positions, velocities, _) in runs.items():
        # the orbit's bodies move in space; the spring's in the phase plane (x, v_x)
        shown = positions if system_name == "orbit" else np.stack(
            [positions[:, 0], velocities[:, 0], np.zeros(STEPS + 1)], axis=1)
        body = entities[f"/{view}/{name}/body"]
        assert column(body, "step") == list(range(STEPS + 1)), "one position per step, on the step timeline"
        np.testing.assert_array_equal(np.concatenate(column(body, "Points3D:positions")), shown.astype(np.float32))
        assert column(body, "Points3D:colors")[0] == [packed(engine_recording.COLORS[name])]

        (trail,) = column(entities[f"/{view}/{name}/trail"], "LineStrips3D:strips")[0]
        np.testing.assert_array_equal(np.array(trail), shown.astype(np.float32))
        colour = [packed(engine_recording.COLORS[name])]
        assert column(entities[f"/{view}/{name}/trail"], "LineStrips3D:colors")[0] == colour

        label = entities[f"/{view}/{name}/label"]
        assert column(label, "Points3D:labels")[0] == [engine_recording.LABELS[name]]
        assert column(label, "Points3D:colors")[0] == [packed(engine_recording.COLORS[name])]
        assert column(label, "step") == list(range(STEPS + 1))
        riding = np.concatenate(column(label, "Points3D:positions")) - shown.astype(np.float32)
        assert np.allclose(riding[:, [0, 2]], 0.0), "the label moves with its body, only lifted up or down"
        bodies[name], labels[name] = shown[:, 1], shown[:, 1] + riding[:, 1]
    # Three readable labels at every step, even where the bodies sit on one another (all of them at
    # step 0): in the bodies' own up-down order, each at least one label-gap above the next.
    bodies, labels = np.stack(list(bodies.values()), axis=1), np.stack(list(labels.values()), axis=1)
    order = np.argsort(bodies, axis=1, kind="stable")
    gaps = np.diff(np.take_along_axis(labels, order, axis=1), axis=1)
    assert gaps[0].min() > 0.05, "the bodies start together, so their labels stack one gap apart"
    assert (gaps >= gaps[0].min() * 0.999).all()


def test_a_batchs_exact_motion_is_each_members_own():
    """The exact motions themselves are tested against their force laws in test_closed_form.py."""
    times = np.linspace(0.0, 300.0, 13)
    ensemble = engine_ensembles.build_ensemble("orbit", [0, 1, 2])
    batched = ensemble["exact"](ensemble["q0"], ensemble["v0"], times)
    for i in range(3):
        member = engine.build_system("orbit", np.random.default_rng(i))
        np.testing.assert_array_equal(batched[:, i], member["exact"](member["q0"], member["v0"], times))


def test_orbit_position_error_is_measured_against_keplers_exact_orbit(recorded):
    _, entities, _, system, runs = recorded["orbit"]
    steps = np.arange(STEPS + 1)
    exact = engine.kepler_orbit(system["q0"], system["v0"], steps * DT, system["mu"])  # Kepler's equation
    finals = {}
    for name, (positions, _, _) in runs.items():
        series = entities[f"/position_error/{name}"]
        miss = np.sqrt(np.sum((positions - exact) ** 2, axis=1))
        logged_steps = column(series, "step")
        assert logged_steps == [i for i in steps if miss[i] > 1e-14], "only step 0, where the error is 0, has no log"
        logged = np.ravel(column(series, "Scalars:scalars"))
        np.testing.assert_allclose(logged[1:], np.log10(miss[logged_steps[1:]]), atol=1e-3)
        assert column(series, "SeriesLines:colors")[0] == [packed(engine_recording.COLORS[name])]
        finals[name] = logged[-1]
    # metres off after 20 s: Euler by its whole radius, semi-implicit by millimetres, RK4 by nanometres
    assert finals["euler"] > -0.5 and -4 < finals["semi_implicit"] < -1 and finals["rk4"] < -7


@pytest.mark.parametrize("system_name", ["orbit", "spring"])
def test_energy_error_is_the_log_of_the_relative_drift_step_for_step(recorded, system_name):
    _, entities, _, _, runs = recorded[system_name]
    for name, (_, _, energies) in runs.items():
        rel = np.abs(energies - energies[0]) / abs(energies[0])
        series = entities[f"/energy_error/{name}"]
        steps = column(series, "step")
        assert steps == [i for i in range(STEPS + 1) if rel[i] > 0]  # exact zeros have no logarithm
        np.testing.assert_array_equal(np.ravel(column(series, "Scalars:scalars")), np.log10(rel[steps]))
        assert column(series, "SeriesLines:names")[0] == [engine_recording.LABELS[name]]


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
}


@pytest.mark.parametrize("system_name", engine.SYSTEMS)
def test_each_system_opens_on_its_own_views_and_every_plot_on_the_whole_run(recorded, system_name):
    _, entities, settings, _, _ = recorded[system_name]
    views = views_of(settings)
    assert set(views) == EXPECTED_VIEWS[system_name], "the views this system's lesson needs, and no others"
    for (kind, origin), props in views.items():
        if kind != "TimeSeries":
            continue
        assert props["TimeAxis:view_range"] == {"start": 0, "end": STEPS}, f"{origin} opens on all the steps"
        low, high = props["ScalarAxis:range"]
        values = np.concatenate([np.ravel(column(batches, "Scalars:scalars"))
                                 for path, batches in entities.items() if path.startswith(f"/{origin}/")])
        assert low < values.min() and values.max() < high, f"{origin}: every value on screen"
        assert props["PlotInteraction:tooltip_mode"] == rrb.components.TooltipMode.All.value


@pytest.mark.parametrize("system_name", ["orbit", "spring"])
def test_the_camera_looks_down_on_every_path(recorded, system_name):
    _, entities, settings, _, _ = recorded[system_name]
    origin = {"orbit": "orbit", "spring": "phase"}[system_name]
    props = views_of(settings)[("3D", origin)]
    points = np.concatenate([np.array(column(b, "LineStrips3D:strips")[0][0])
                             for path, b in entities.items() if path.endswith("/trail")])
    target, eye = np.array(props["EyeControls3D:look_target"]), np.array(props["EyeControls3D:position"])
    np.testing.assert_allclose(target[:2], (points.min(axis=0)[:2] + points.max(axis=0)[:2]) / 2, atol=1e-6)
    span = (points.max(axis=0) - points.min(axis=0))[:2].max()
    assert eye[2] - target[2] >= span, "high enough above the plane that the widest path fits the view"


@pytest.mark.parametrize("system_name", engine.SYSTEMS)
def test_side_panels_are_folded_and_the_file_opens_on_the_last_step(recorded, system_name):
    _, _, settings, _, _ = recorded[system_name]
    assert settings["/blueprint_panel"]["PanelBlueprint:state"] == rrb.components.PanelState.Hidden.value
    assert settings["/selection_panel"]["PanelBlueprint:state"] == rrb.components.PanelState.Hidden.value
    time_panel = settings["/time_panel"]
    assert time_panel["TimePanelBlueprint:state"] == rrb.components.PanelState.Collapsed.value
    assert time_panel["TimePanelBlueprint:timeline"] == "step"
    assert time_panel["TimePanelBlueprint:play_state"] == rrb.components.PlayState.Following.value
    assert time_panel["TimePanelBlueprint:fps"] * engine_recording.PLAYBACK_SECONDS == pytest.approx(STEPS)


@pytest.mark.slow
def test_long_runs_are_thinned_in_the_recording_but_not_in_the_metrics(tmp_path, capsys):
    steps = 250_000
    assert engine.main(["--integrator", "euler", "--steps", str(steps), "--out", str(tmp_path)]) == 0
    assert "recording keeps 1 state in 3 of 250,001 per integrator" in capsys.readouterr().out
    _, entities, settings, = read_recording(tmp_path / engine.RECORDING_FILE)
    logged_steps = column(entities["/energy_error/euler"], "step")
    assert len(logged_steps) <= engine.MAX_POINTS_PER_SERIES + 1
    assert logged_steps[0] <= 3 and logged_steps[-1] == steps
    assert column(entities["/orbit/euler/body"], "step") == engine.kept_steps(steps, 3).tolist()
    for (kind, origin), props in views_of(settings).items():
        if kind == "TimeSeries":
            assert props["TimeAxis:view_range"] == {"start": 0, "end": steps}, f"{origin} opens on the whole run"


def test_a_system_without_its_own_views_gets_the_energy_error_and_its_position_error():
    """A new system records before anyone writes it a view: RECORDED_VIEWS only tells a system's own story."""
    assert set(engine_recording.RECORDED_VIEWS) <= {*engine.SYSTEMS, *engine.DAMPED_SYSTEMS}
    orbit = engine.build_system("orbit", np.random.default_rng(0))
    unknown = {**orbit, "name": "unlisted"}
    energy, position = engine_recording.log_energy_error, engine_recording.log_position_error
    assert engine_recording.views_for(unknown) == (energy, position)
    assert engine_recording.views_for({**unknown, "exact": None}) == (energy,)


def test_the_damped_spring_opens_on_its_phase_plane_beside_its_error_against_the_exact_motion(tmp_path):
    assert engine.main(["--system", "damped_spring", "--out", str(tmp_path)]) == 0
    _, entities, settings = read_recording(tmp_path / engine.RECORDING_FILE)
    assert set(views_of(settings)) == {("3D", "phase"), ("TimeSeries", "position_error")}
    system = engine.build_system("damped_spring", np.random.default_rng(0))
    exact = system["exact"](system["q0"], system["v0"], np.arange(STEPS + 1) * DT)
    for name in engine.integrators_for(system):  # the implicit step too
        positions, velocities, _ = engine.simulate(engine.integrators_for(system)[name], system, DT, STEPS)
        plane = np.concatenate(column(entities[f"/phase/{name}/body"], "Points3D:positions"))
        np.testing.assert_array_equal(plane[:, :2], np.stack([positions[:, 0], velocities[:, 0]], axis=1)
                                      .astype(np.float32))
        miss = np.sqrt(np.sum((positions - exact) ** 2, axis=1))
        logged = np.ravel(column(entities[f"/position_error/{name}"], "Scalars:scalars"))
        np.testing.assert_allclose(logged, np.log10(miss[miss > 0]), atol=1e-9)


@pytest.mark.parametrize("system_name", ["spring", "damped_spring"])
def test_the_phase_plane_draws_the_exact_motion_under_the_integrators(tmp_path, system_name):
    assert engine.main(["--system", system_name, "--out", str(tmp_path)]) == 0
    _, entities, _ = read_recording(tmp_path / engine.RECORDING_FILE)
    (exact,) = column(entities["/phase/exact"], "LineStrips3D:strips")[0]
    exact = np.array(exact)
    system = engine.build_system(system_name, np.random.default_rng(0))
    times = np.arange(STEPS + 1) * DT
    x = system["exact"](system["q0"], system["v0"], times)[:, 0]
    np.testing.assert_allclose(exact[:, 0], x, atol=1e-6)
    if system_name == "spring":  # x = x0 cos(2t): v = -2 x0 sin(2t)
        np.testing.assert_allclose(exact[:, 1], -2.0 * system["q0"][0] * np.sin(2.0 * times), atol=1e-5)
    assert (exact[:, 2] < 0).all(), "a hair below the plane, so the integrators' lines lie on top"
