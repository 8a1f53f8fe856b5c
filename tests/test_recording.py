"""The .rrd recording, read back with Rerun's own reader and checked against the run."""

import numpy as np
import pytest

import engine

rerun_chunk = pytest.importorskip("rerun.chunk", reason="rerun-sdk is a core dependency; install the project")


def packed(rgb):
    """Rerun stores a colour as one uint32, 0xRRGGBBAA."""
    r, g, b = rgb
    return (r << 24) | (g << 16) | (b << 8) | 0xFF


def read_recording(path):
    """{entity_path: [record_batch, ...]} for the recording store, and the blueprint's batches."""
    reader = rerun_chunk.RrdReader(path)
    (recording,) = reader.recordings()
    (blueprint,) = reader.blueprints()
    entities = {}
    for chunk in reader.stream(store=recording).to_chunks():
        entities.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())
    views = [c.to_record_batch() for c in reader.stream(store=blueprint).to_chunks()]
    return recording, entities, views


def column(batches, name):
    for batch in batches:
        if name in batch.schema.names:
            return batch.column(name).to_pylist()
    raise AssertionError(f"no column {name}")


@pytest.fixture(scope="module")
def orbit_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("orbit")
    assert engine.main(["--out", str(out)]) == 0
    system = engine.build_system("orbit", np.random.default_rng(0))
    runs = {name: engine.simulate(step, system, 0.01, 2000)[::2] for name, step in engine.INTEGRATORS.items()}
    return read_recording(out / "engine.rrd"), runs


def test_application_id_is_valid_and_there_is_one_recording(orbit_run):
    (recording, entities, _), _ = orbit_run
    assert recording.application_id == "zero2robot-ch3_3-engine"
    assert "/world/attractor" in entities


def test_paths_are_the_simulated_trajectories_in_the_integrators_colours(orbit_run):
    (_, entities, _), runs = orbit_run
    for name, (trajectory, _) in runs.items():
        (strip,) = column(entities[f"/world/{name}"], "LineStrips3D:strips")[0]
        np.testing.assert_array_equal(np.array(strip), trajectory.astype(np.float32))
        assert column(entities[f"/world/{name}"], "LineStrips3D:colors")[0] == [packed(engine.COLORS[name])]


def test_energy_and_log_error_series_match_the_run_step_for_step(orbit_run):
    (_, entities, _), runs = orbit_run
    for name, (_, energies) in runs.items():
        series = entities[f"/energy/{name}"]
        assert column(series, "step") == list(range(2001))
        np.testing.assert_array_equal(np.ravel(column(series, "Scalars:scalars")), energies)
        assert column(series, "SeriesLines:colors")[0] == [packed(engine.COLORS[name])]

        rel = np.abs(energies - energies[0]) / abs(energies[0])
        steps = column(entities[f"/rel_error/{name}"], "step")
        assert steps == [i for i in range(2001) if rel[i] > 0]  # exact zeros have no logarithm
        logged = np.ravel(column(entities[f"/rel_error/{name}"], "Scalars:scalars"))
        np.testing.assert_array_equal(logged, np.log10(rel[steps]))
        assert column(entities[f"/rel_error/{name}"], "SeriesLines:colors")[0] == [packed(engine.COLORS[name])]
    # the three curves are far apart on a log scale: that is why the plot uses one
    finals = {name: np.ravel(column(entities[f"/rel_error/{name}"], "Scalars:scalars"))[-1] for name in runs}
    assert finals["euler"] > -1 > finals["semi_implicit"] > -5 > -9 > finals["rk4"]


def test_blueprint_puts_the_paths_beside_one_overlaid_error_plot(orbit_run):
    (_, _, views), _ = orbit_run
    by_origin = {}
    for batch in views:
        if "ViewBlueprint:space_origin" in batch.schema.names:
            origin = batch.column("ViewBlueprint:space_origin").to_pylist()[0][0]
            by_origin[origin] = batch.column("ViewBlueprint:class_identifier").to_pylist()[0][0]
    assert by_origin == {"world": "3D", "rel_error": "TimeSeries", "energy": "TimeSeries"}
    tabs = [b for b in views if "ContainerBlueprint:active_tab" in b.schema.names]
    assert len(tabs) == 1, "the two plots share one slot as tabs, the error plot in front"


@pytest.mark.slow
def test_long_runs_are_decimated_in_the_recording_but_not_in_the_metrics(tmp_path, capsys):
    steps = 250_000
    assert engine.main(["--integrator", "euler", "--steps", str(steps), "--out", str(tmp_path)]) == 0
    assert "recording keeps 1 state in 3 of 250,001 per integrator" in capsys.readouterr().out
    _, entities, _ = read_recording(tmp_path / "engine.rrd")
    logged_steps = column(entities["/energy/euler"], "step")
    assert len(logged_steps) <= engine.MAX_POINTS_PER_SERIES + 1
    assert logged_steps[0] == 0 and logged_steps[-1] == steps
    (strip,) = column(entities["/world/euler"], "LineStrips3D:strips")[0]
    assert len(strip) == len(logged_steps)
