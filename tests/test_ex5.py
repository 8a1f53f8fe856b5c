"""Exercise 5: the blob's area against closed-form determinants worked out here in exact fractions."""

import math
from fractions import Fraction

import numpy as np
import pytest

import engine
from curriculum.common import recording as course
from exercises import ex5_phase_blob as ex5


def exact_det(name, h):
    """One step's matrix on (x, v/omega) in exact rational arithmetic, from the methods' definitions."""
    h = Fraction(h)
    identity, rotation = ((1, 0), (0, 1)), ((0, 1), (-1, 0))  # (x, v/omega)' = omega * rotation

    def mul(a, b):
        return tuple(tuple(sum(a[i][k] * b[k][j] for k in range(2)) for j in range(2)) for i in range(2))

    def add(a, b, scale=1):
        return tuple(tuple(a[i][j] + scale * b[i][j] for j in range(2)) for i in range(2))

    if name == "euler":
        step = add(identity, rotation, h)
    elif name == "semi_implicit":  # v first: v' = v - h x; then x' = x + h v'
        kick, drift = ((1, 0), (-h, 1)), ((1, h), (0, 1))
        step = mul(drift, kick)
    else:  # RK4 on a linear system is the Taylor polynomial of degree 4 of exp(h * rotation)
        step, term = identity, identity
        for n in range(1, 5):
            term = mul(term, rotation)
            step = add(step, term, h ** n / math.factorial(n))
    return step[0][0] * step[1][1] - step[0][1] * step[1][0]


@pytest.mark.parametrize("name", list(engine.CHAPTER_INTEGRATORS))
@pytest.mark.parametrize("h", [0.02, 0.2, 2.1])
def test_closed_form_determinants_are_the_methods_own(name, h):
    minus_one, _ = ex5.one_step_determinant(name, h)
    exact = exact_det(name, h) - 1
    assert minus_one == pytest.approx(float(exact), rel=1e-12, abs=0.0)


def test_the_engine_steps_are_the_matrices_the_closed_form_assumes():
    """Step the unit states through the engine's own integrators: the 2x2 matrix's determinant."""
    m, force, k, omega = ex5.spring()
    dt = 0.1
    for name in engine.CHAPTER_INTEGRATORS:
        step = engine.INTEGRATORS[name]
        q = np.zeros((2, 3))
        v = np.zeros((2, 3))
        q[0, 0], v[1, 0] = 1.0, omega  # (x, v/omega) = (1, 0) and (0, 1)
        q1, v1 = step(q, v, m, force, dt)
        columns = np.array([[q1[0, 0], q1[1, 0]], [v1[0, 0] / omega, v1[1, 0] / omega]])
        det = columns[0, 0] * columns[1, 1] - columns[0, 1] * columns[1, 0]
        assert det - 1 == pytest.approx(ex5.one_step_determinant(name, omega * dt)[0], rel=1e-9, abs=1e-15)


@pytest.fixture(scope="module")
def chapter_table():
    return ex5.measure(ex5.DT, ex5.STEPS)


@pytest.fixture(scope="module")
def blob(chapter_table, tmp_path_factory):
    """(entities, blueprint settings) of the recording the exercise writes, read back with Rerun's reader."""
    from test_recording import read_recording

    path = tmp_path_factory.mktemp("ex5") / "blob.rrd"
    ex5.record(path, chapter_table)
    return read_recording(path)[1:]


@pytest.mark.parametrize("dt", [ex5.DT, ex5.COARSE_DT])
def test_measured_area_follows_the_closed_form_every_step(dt, chapter_table):
    table = chapter_table if dt == ex5.DT else ex5.measure(dt, ex5.STEPS)
    for name, row in table.items():
        assert row["worst_gap"] < 1e-12, name
    answers = {name: ex5.what_the_area_does(row["measured"]) for name, row in table.items()}
    assert answers == {"euler": "grows", "semi_implicit": "stays", "rk4": "shrinks"}


def test_rk4_shrink_at_the_chapter_dt_is_far_above_the_round_off_floor(chapter_table):
    table = chapter_table
    rk4, floor = table["rk4"]["measured"], abs(table["semi_implicit"]["measured"])
    assert rk4 == pytest.approx(-1.7777e-9, rel=1e-3)  # 2000 * (0.02^6 / 72) = 1.78e-9
    assert floor < 1e-13 and abs(rk4) > 1e4 * floor


def test_past_the_limit_area_holds_but_energy_runs_away():
    """At dt 1.05 (|trace| > 2) the points' exact area changes by ~1e-11 (their rounding); the float shoelace says
    ~5e-9 (+2.4e-11 and -4.7e-9 when measured), while the energy grows 1e5-fold."""
    areas, x, v = ex5.run_blob("semi_implicit", ex5.PAST_LIMIT_DT, ex5.PAST_LIMIT_STEPS)
    assert ex5.one_step_determinant("semi_implicit", 2.0 * ex5.PAST_LIMIT_DT)[1] < -2.0
    assert ex5.exact_area(np.array([0.0, 1.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0, 1.0])) == 1  # a unit square
    exact_change = float(ex5.exact_area(x[-1], v[-1]) / ex5.exact_area(x[0], v[0]) - 1)
    assert abs(exact_change) < 1e-10 < 1e-9 < abs(areas[-1] / areas[0] - 1) < 1e-6
    assert np.max(ex5.energy(x[-1], v[-1]) / ex5.energy(x[0], v[0])) > 1e5


def test_nearby_energy_is_kept_and_true_energy_stays_in_its_band(chapter_table):
    table = chapter_table
    true_band, nearby_band = ex5.modified_energy_drift(table["semi_implicit"]["x"], table["semi_implicit"]["v"], ex5.DT)
    h = 2.0 * ex5.DT
    assert nearby_band < 1e-13
    assert 0.5 * h < true_band <= (1 + h / 2) / (1 - h / 2) - 1
    # and for explicit Euler the same quadratic is not kept at all
    _, euler_nearby = ex5.modified_energy_drift(table["euler"]["x"], table["euler"]["v"], ex5.DT)
    assert euler_nearby > 0.5


def test_graded_both_ways(capsys):
    assert ex5.main(["--predict", "Euler = grows,", "semi-implicit: stays, rk4=shrinks", "--no-rerun"]) == 0
    assert "Right: euler grows, semi_implicit stays, rk4 shrinks." in capsys.readouterr().out
    assert ex5.main(["--predict", "euler=grows,semi_implicit=stays,rk4=stays", "--no-rerun"]) == 0
    wrong = capsys.readouterr().out
    assert "Not quite: you said euler=grows, semi_implicit=stays, rk4=stays, but" in wrong and "rk4 shrinks" in wrong


def test_the_recording_opens_the_courses_way_with_every_blob_framed_and_named(chapter_table, blob):
    """Like engine.py's: the whole run, the cursor on the last step, panels closed; every frame of every blob
    inside the camera's view, the axes named at their own tips, a key naming each integrator in its colour."""
    from test_recording import assert_opens_the_courses_way, column, packed, views_of

    entities, settings = blob
    assert_opens_the_courses_way(settings, ex5.STEPS)
    views = views_of(settings)
    assert set(views) == {("3D", "phase"), *(("TimeSeries", f"area/{name}") for name in chapter_table)}
    camera = views[("3D", "phase")]
    target, eye = np.array(camera["EyeControls3D:look_target"]), np.array(camera["EyeControls3D:position"])
    assert eye[1] == pytest.approx(target[1]) and eye[2] > target[2], "straight down: v_x up the screen"
    looks = course.looks(chapter_table)
    for name, look in looks.items():
        frames = column(entities[f"/phase/{name}"], "LineStrips3D:strips")
        assert len(frames) == len(range(0, ex5.STEPS + 1, ex5.RECORD_EVERY))
        edges = np.array([strip for frame in frames for strip in frame]).reshape(-1, 3)
        assert (np.abs(edges[:, :2] - target[:2]) < (eye[2] - target[2]) / 2).all(), f"{name}: every frame framed"
        assert column(entities[f"/phase/{name}"], "LineStrips3D:colors")[0] == [packed(look.colour)]
    (names,) = column(entities["/phase/axes/names"], "Points3D:labels")
    tips = np.array(column(entities["/phase/axes/names"], "Points3D:positions")[0])
    assert names == ["x", "v_x"] and tips[0, 0] > 0 and tips[0, 1] == 0 and tips[1, 1] > 0 and tips[1, 0] == 0
    assert column(entities["/phase/key"], "Points3D:labels")[0] == [look.label for look in looks.values()]


def test_each_area_change_is_drawn_at_its_true_size_and_sign(chapter_table, blob):
    """Each integrator's area / area0 - 1 in its own plot, in units of a power of ten its title names, so its
    largest value reads 1 to 10: explicit Euler's up to +1.23, RK4's down to -1.78 (units of 1e-09),
    semi-implicit Euler's round-off titled as such; a grey 0 in each."""
    from test_recording import column, packed

    entities, settings = blob
    titles = {f["ViewBlueprint:space_origin"]: f["ViewBlueprint:display_name"] for f in settings.values()
              if f.get("ViewBlueprint:class_identifier") == "TimeSeries"}
    for name, row in chapter_table.items():
        series = entities[f"/area/{name}/change"]
        assert column(series, "step") == list(range(ex5.STEPS + 1)), "from step 0, like the other plots"
        drawn, unit = np.ravel(column(series, "Scalars:scalars")), ex5.unit_of(row["ratios"])
        assert np.log10(unit) == round(np.log10(unit)) and 1 <= np.abs(drawn).max() < 10
        np.testing.assert_allclose(drawn * unit, row["ratios"], rtol=1e-6)  # Rerun keeps float64 scalars
        zero = entities[f"/area/{name}/zero"]
        assert np.ravel(column(zero, "Scalars:scalars")).tolist() == [0.0, 0.0]
        assert column(zero, "SeriesLines:colors")[0] == [packed(course.GREY)], "grey: a reference"
        assert (f"in units of {unit:.0e}" in titles[f"area/{name}"]) == (unit != 1.0)
    assert titles["area/euler"].endswith("at the end +1.23") and titles["area/rk4"].endswith("at the end -1.78e-09")
    assert titles["area/semi_implicit"].endswith("at the end round-off (under 1e-12)")
