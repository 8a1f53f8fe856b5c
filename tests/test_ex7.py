"""Exercise 7: the shadow energy E~ = E + (dt/2) v . F(q) that semi-implicit Euler keeps.

Against independent truth: the step worked out in exact fractions (E~ kept exactly for a linear and a
constant force, not for a cubic one), the freefall's closed form for E's drift, the order of the orbit's
E~ band as dt halves, and MuJoCo 3.10.0's own mjINT_EULER. The issue's table is pinned at the digits the
exercise prints, with tolerances argued from the arithmetic beside each.

`python tools/figures.py shadow` prints the MuJoCo figures that exercises/solutions/ANSWERS.md quotes.
"""

import re
from fractions import Fraction

import numpy as np
import pytest

import engine
from conftest import run_exercise
from exercises import ex7_shadow_energy as ex7
from exercises.support import shadow

EPS = np.finfo(float).eps
RIGHT = "spring=roundoff, orbit=smaller, freefall=roundoff"


@pytest.fixture(scope="module")
def chapter():
    """The chapter's three runs under semi-implicit Euler, as the exercise measures them."""
    return ex7.measure_all()


# --- the algebra, in exact arithmetic: no tolerance at all ---


def semi_implicit_exact(x, v, m, force, dt):
    """One velocity-first step in fractions, as engine.semi_implicit_step does it (one dimension)."""
    v_next = v + dt * force(x) / m
    return x + dt * v_next, v_next


def shadow_exact(x, v, m, potential, force, dt):
    return m * v * v / 2 + potential(x) + dt / 2 * v * force(x)


CASES = {  # name: (potential V(x), force -V'(x)), rational coefficients so that fractions stay exact
    "linear (a spring, k 3)": (lambda x: Fraction(3, 2) * x * x, lambda x: -3 * x),
    "constant (gravity, g 981/100)": (lambda x: Fraction(981, 100) * x, lambda x: Fraction(-981, 100)),
    "cubic (V = x^4 / 4)": (lambda x: x ** 4 / 4, lambda x: -(x ** 3)),
}


@pytest.mark.parametrize("case", CASES)
def test_in_exact_arithmetic_the_step_keeps_e_tilde_only_for_a_linear_or_constant_force(case):
    """Fractions do not round: a change of zero is zero. For a linear or a constant force E~ is kept by
    every step exactly; for a cubic one it is not (its change is of order dt^3 per step: the series goes on)."""
    potential, force = CASES[case]
    m, dt = Fraction(5, 2), Fraction(1, 100)
    x, v = Fraction(11, 10), Fraction(-3, 7)
    start = shadow_exact(x, v, m, potential, force, dt)
    changes = []
    for _ in range(3 if case.startswith("cubic") else 20):  # a cubic triples the fractions' digits every step
        x, v = semi_implicit_exact(x, v, m, force, dt)
        changes.append(shadow_exact(x, v, m, potential, force, dt) - start)
    if case.startswith("cubic"):
        assert all(change != 0 for change in changes)
        assert 0 < abs(changes[0]) < dt ** 2  # far smaller than E~'s first term, yet not zero
    else:
        assert changes == [0] * 20 and x != Fraction(11, 10)  # (and the body did move)


def test_shadow_energy_is_the_formula_on_the_engines_systems():
    """E~ = E - (dt/2) v . grad V: on the spring that is exercise 5's E - k dt x v / 2 (its own function)."""
    from exercises import ex5_phase_blob as ex5

    system = engine.build_system("spring", np.random.default_rng(0))
    q, v, _ = engine.simulate(engine.semi_implicit_step, system, 0.01, 50)
    _, _, k, _ = ex5.spring()
    x, vx = q[:, 0], v[:, 0]
    assert np.allclose(shadow.shadow_energy(system, q, v, 0.01), ex5.energy(x, vx) - 0.5 * k * 0.01 * x * vx,
                       rtol=4 * EPS, atol=0)


# --- the table (seed 0, dt 0.01, 2,000 steps, semi-implicit Euler) ---
# The physics is deterministic IEEE arithmetic (dot3, no BLAS: docs/DEVELOPING.md), so a figure printed
# to four digits reproduces to the last bit on any CPU: pinning it to half a unit in its last printed
# digit is a tolerance of the printing, not of the physics.


def pinned(value, printed: float, digits: int = 4) -> bool:
    unit = 10.0 ** (np.floor(np.log10(abs(printed))) - (digits - 1))
    return abs(value - printed) <= unit / 2


def test_the_spring_keeps_e_tilde_to_round_off_while_e_moves_a_percent(chapter):
    spring = chapter["spring"]
    assert pinned(spring["energy_band"], 1.010e-2)
    # The round-off bound: 8 ulps of E~'s largest terms (about E) per step, added up linearly over 2,001
    # states: 8 * 2001 * 2.2e-16 * 4.2 / 2.1 = 7e-12. E~ must stay under it; E's band is 1e9 times larger,
    # so a wrong sign in the correction (E~'s band would be 2e-2) or a missing m or k fails here.
    assert spring["roundoff"] < 1e-11
    assert spring["shadow_band"] <= spring["roundoff"] < 1e-8 * spring["energy_band"]


def test_mass_and_stiffness_enter_where_the_formula_says():
    """A spring with k 3 and m 2.5 (not the chapter's 4 and 1): E moves 5.5e-3, E~ only by round-off."""
    run = shadow.measure("spring", system=shadow.spring_of(3.0, 2.5))
    assert pinned(run["energy_band"], 5.507e-3)
    assert run["shadow_band"] <= run["roundoff"] < 1e-11


def test_the_freefall_keeps_e_tilde_to_round_off_at_the_size_of_its_terms(chapter):
    fall = chapter["freefall"]
    system = fall["system"]
    m, g, dt, seconds = system["m"], 9.81, shadow.DT, shadow.DT * shadow.STEPS
    e0 = fall["energy"][0]
    # E drifts by exactly E~'s correction term, -(dt/2) m g^2 t: 9.3415e-2 of E0. Both sides are sums of a
    # few thousand roundings of numbers up to ~2e4 J, so they agree to ~1e-9 relative, far inside 1e-6.
    drift = (fall["energy"][-1] - e0) / abs(e0)
    assert drift == pytest.approx(-0.5 * dt * m * g * g * seconds / abs(e0), rel=1e-6)
    assert pinned(fall["energy_band"], 9.341e-2)
    # E~ is kept to round-off, but round-off at the size of its terms, not of E~ (103 J): two kilometres
    # down, m g |z| is about 19,000 J, and the kinetic energy as much. The bound scales with them.
    depth = -fall["positions"][:, 2].min()
    assert 1900 < depth < 2000
    scale_floor = shadow.ROUNDOFF_ULPS_PER_STEP * (shadow.STEPS + 1) * EPS * m * g * depth / abs(e0)
    assert fall["roundoff"] >= scale_floor  # the bound counts the potential term at its full size
    assert fall["shadow_band"] <= fall["roundoff"] < 1e-8  # while E moves 9.3e-2
    # and the round-off it shows is that size: more than E~'s own round-off (2e-14 relative) could give
    assert fall["shadow_band"] > 100 * EPS


def test_the_orbit_keeps_e_tilde_to_its_first_term_only(chapter):
    orbit = chapter["orbit"]
    assert pinned(orbit["energy_band"], 3.203e-4)
    assert pinned(orbit["shadow_band"], 7.703e-6)  # the 7.7e-6
    assert orbit["shadow_band"] > 1e5 * orbit["roundoff"]  # a real change, not rounding
    assert round(orbit["energy_band"] / orbit["shadow_band"]) == 42


def test_the_answers_are_what_the_exercise_grades(chapter):
    assert {name: shadow.how_far(run) for name, run in chapter.items()} == {
        "spring": "roundoff", "orbit": "smaller", "freefall": "roundoff"}


def test_halving_dt_divides_the_orbits_e_tilde_band_by_four_and_es_by_two():
    """E~'s band is the series' dt^2 term, plus a dt^3 one that fades as dt shrinks: the factor is
    4 (1 + O(dt)), measured 4.02, 4.01, 4.00. E's band is the dt term (plus dt^2): 2.20, 2.10, 2.05,
    coming down to 2 as the dt^2 part fades (it halves its distance from 2 with every halving)."""
    ladder = shadow.halving_ladder("orbit")
    assert [(dt, steps) for dt, steps, _, _ in ladder] == [(0.01, 2000), (0.005, 4000), (0.0025, 8000),
                                                           (0.00125, 16000)]
    shadow_factors = [a[3] / b[3] for a, b in zip(ladder, ladder[1:], strict=False)]
    energy_factors = [a[2] / b[2] for a, b in zip(ladder, ladder[1:], strict=False)]
    assert all(abs(f - 4.0) < 0.05 for f in shadow_factors), shadow_factors
    assert all(1.9 < f < 2.3 for f in energy_factors) and energy_factors == sorted(energy_factors, reverse=True)
    assert pinned(shadow_factors[0], 4.02, 3) and pinned(energy_factors[0], 2.20, 3)


# --- this E~ is semi-implicit Euler's, not the other integrators' (spring and orbit only) ---


@pytest.mark.parametrize("system_name", ["spring", "orbit"])
def test_explicit_euler_does_not_keep_it_and_its_e_tilde_grows_with_the_run(system_name):
    run = shadow.measure(system_name, "euler")
    assert run["shadow_band"] > 0.9 * run["energy_band"] > 0.1  # E~ goes as far as E: 1.2 / 0.22
    assert shadow.how_far(run) == "as_far"
    if system_name == "spring":
        long = shadow.measure("spring", "euler", steps=ex7.LONG_STEPS)
        assert pinned(run["shadow_band"], 1.203) and pinned(long["shadow_band"], 595.1)


@pytest.mark.parametrize("system_name, wobble", [("spring", 1.000e-2), ("orbit", 2.654e-4)])
def test_rk4_keeps_e_so_its_e_tilde_carries_the_corrections_wobble(system_name, wobble):
    """RK4's E is nearly constant, so E~ - E~0 is the correction's own change, (dt/2)(v.F - v0.F0)."""
    run = shadow.measure(system_name, "rk4")
    system, q, v = run["system"], run["positions"], run["velocities"]
    correction = 0.5 * shadow.DT * engine.dot3(v, system["force"](q, v))
    own = np.max(np.abs(correction - correction[0])) / abs(run["shadow"][0])
    # E~ - E~0 = (E - E0) + correction change; E's part is at most 1.8e-9, under 1e-6 of the wobble
    assert run["shadow_band"] == pytest.approx(own, rel=1e-6)
    assert pinned(run["shadow_band"], wobble) and run["shadow_band"] > 1e5 * run["energy_band"]


# --- MuJoCo's own semi-implicit Euler keeps it too ---


def mujoco_spring(k: float, m: float, dt: float = shadow.DT, steps: int = shadow.STEPS, damping: float = 0.0):
    """(qpos, qvel) after every mj_step of MuJoCo's mjINT_EULER on one slide joint with a stiffness (and a
    damper), started where the chapter's spring starts (seed 0)."""
    import mujoco

    from mujoco_models import damped_xml

    model = mujoco.MjModel.from_xml_string(damped_xml("Euler", dt, {"k": k, "b": damping, "m": m}))
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    data = mujoco.MjData(model)
    data.qpos[0] = engine.build_system("spring", np.random.default_rng(0))["q0"][0]
    states = [(data.qpos[0], data.qvel[0])]
    for _ in range(steps):
        mujoco.mj_step(model, data)
        states.append((data.qpos[0], data.qvel[0]))
    return np.array(states).T


def mujoco_bands(k: float, m: float, dt: float = shadow.DT, damping: float = 0.0) -> tuple:
    """(E's band, E~'s band, round-off bound) from mj_step's own qpos and qvel."""
    qpos, qvel = mujoco_spring(k, m, dt, damping=damping)
    energy = 0.5 * m * qvel * qvel + 0.5 * k * qpos * qpos
    nearby = energy - 0.5 * dt * qvel * k * qpos  # E~ = E - (dt/2) v . grad V, grad V = k x
    # the same bound as the exercise's: 8 ulps of the largest terms per step, added up linearly
    terms = np.max(0.5 * m * qvel * qvel + 0.5 * k * qpos * qpos + np.abs(0.5 * dt * qvel * k * qpos))
    roundoff = shadow.ROUNDOFF_ULPS_PER_STEP * len(qpos) * EPS * terms / abs(nearby[0])
    return shadow.band(energy), shadow.band(nearby), roundoff


@pytest.mark.parametrize("k, m, damping", [(4.0, 1.0, 0.0), (3.0, 2.5, 0.0), (4.0, 1.0, 0.5)])
def test_mujocos_euler_keeps_e_tilde_on_an_undamped_spring_only(k, m, damping):
    """mj_Euler (MuJoCo 3.10.0): qvel += h qacc, then qpos += h qvel. E moves (1.0e-2 on the chapter's spring,
    5.5e-3 at k 3, m 2.5, where MuJoCo divides by the mass itself); E~ from its own state only by round-off.
    With joint damping (what the exercise's sentence leaves out on purpose) E drains, and E~ with it."""
    pytest.importorskip("mujoco", reason="MuJoCo's Euler needs the 'mujoco' extra: pip install -e '.[mujoco]'")
    energy_band, shadow_band, roundoff = mujoco_bands(k, m, damping=damping)
    assert energy_band > 5e-3
    assert (shadow_band <= roundoff < 1e-8 * energy_band) if not damping else shadow_band > 1e6 * roundoff


# --- the exercise as a student runs it ---


def test_graded_both_ways(capsys):
    assert ex7.main(["--predict", "Spring = round-off,", "orbit: smaller, freefall=roundoff", "--no-rerun"]) == 0
    right = capsys.readouterr().out
    assert "Right: spring roundoff, orbit smaller, freefall roundoff." in right
    assert ex7.main(["--predict", "spring=roundoff,orbit=smaller,freefall=as-far", "--no-rerun", "--more"]) == 0
    wrong = capsys.readouterr().out
    assert "Not quite: you said spring=roundoff, orbit=smaller, freefall=as_far, but" in wrong
    assert re.search(r"\nfreefall +9\.341e-02 +1e-11 +1e-09 +roundoff +as_far \(no\)\n", wrong)
    right, wrong = (" ".join(out.split()) for out in (right, wrong))  # as read, not as wrapped
    for out in (right, wrong):  # the lesson comes either way, right or wrong, with its one figure
        assert "On the orbit it moved 42 times less than E" in out
    # the whole explanation only with --more, with the figures the issue asks for
    assert "Hairer, Lubich and Wanner" in wrong and "mjINT_EULER" in wrong and "Hairer" not in right
    assert "E~'s band shrinks by 4.02 (dt^2), E's by 2.20 (dt)" in wrong
    assert "-9.3415e-02 of E0 after 20 s; measured -9.3415e-02" in wrong


# --- the recording, read back with Rerun's own reader ---


@pytest.fixture(scope="module")
def recording(tmp_path_factory, chapter):
    """What a student's run writes: (entities, blueprint settings) read back from the .rrd, and the runs."""
    pytest.importorskip("rerun.chunk", reason="rerun-sdk is a core dependency; install the project")
    from test_recording import read_recording

    rrd = tmp_path_factory.mktemp("ex7") / "shadow.rrd"
    assert ex7.main(["--predict", RIGHT, "--rrd", str(rrd)]) == 0
    _, entities, settings = read_recording(rrd)
    return entities, settings, chapter


@pytest.mark.parametrize("system_name", shadow.SYSTEMS)
def test_the_recording_holds_e_and_e_tilde_worst_so_far_at_every_step(recording, system_name):
    """Each line is the worst change so far, drawn down to the run's round-off bound, the one grey line: a line
    lying on it has moved no more than rounding can (the exercise's "roundoff")."""
    from test_recording import column, packed

    from curriculum.common import recording as course

    entities, _, chapter = recording
    run = chapter[system_name]
    bound = np.log10(run["roundoff"])
    for entity, values in (("energy", run["energy"]), ("energy_shadow", run["shadow"])):
        batches = entities[f"/{system_name}/{entity}"]
        assert column(batches, "step") == list(range(shadow.STEPS + 1))
        logged = np.ravel(column(batches, "Scalars:scalars"))
        worst = np.maximum.accumulate(np.abs(values - values[0]) / abs(values[0]))
        np.testing.assert_array_equal(logged, np.log10(np.maximum(worst, run["roundoff"])))
        assert np.all(np.diff(logged) >= 0), "a running maximum: round-off draws flat, never as noise"
    e_tilde = np.ravel(column(entities[f"/{system_name}/energy_shadow"], "Scalars:scalars"))
    assert e_tilde[0] == bound  # nothing has moved at step 0: it sits on the floor
    floor = entities[f"/{system_name}/a_roundoff"]
    assert np.ravel(column(floor, "Scalars:scalars")).tolist() == [bound, bound]
    assert "round-off" in column(floor, "SeriesLines:names")[0][0]
    greys = [path for path, batches in entities.items() if path.startswith(f"/{system_name}/")
             and column(batches, "SeriesLines:colors")[0] == [packed(course.GREY)]]
    assert greys == [f"/{system_name}/a_roundoff"], "one grey line: no second grey to tell apart"
    # the lesson at the last step: on the floor on the spring and the freefall, above it on the orbit
    assert (e_tilde[-1] == bound) == (system_name != "orbit")


def test_the_recording_opens_on_three_plots_of_the_whole_run_in_the_course_palette(recording):
    """Each plot from its floor to an error as large as the quantity; E in semi-implicit Euler's colour, E~ (no
    integrator) in a spare one; opened the course's way."""
    from test_recording import assert_opens_the_courses_way, column, packed, views_of

    from curriculum.common import recording as course

    entities, settings, chapter = recording
    views = views_of(settings)
    assert set(views) == {("TimeSeries", name) for name in shadow.SYSTEMS}
    assert_opens_the_courses_way(settings, shadow.STEPS)
    for (_, origin), props in views.items():
        low, high = props["ScalarAxis:range"]
        assert low < np.log10(chapter[origin]["roundoff"]) and high > 0.0, origin
    assert column(entities["/orbit/energy"], "SeriesLines:colors")[0][0] == packed(course.COLOURS["semi_implicit"])
    e_tilde = column(entities["/orbit/energy_shadow"], "SeriesLines:colors")[0][0]
    assert e_tilde in [packed(c) for c in course.SPARE_COLOURS], "E~ is no integrator: a colour none of them has"


@pytest.mark.slow
def test_as_a_student_runs_it_the_recording_goes_under_outputs(tmp_path):
    result = run_exercise("ex7_shadow_energy", "--predict", RIGHT, cwd=tmp_path)
    assert result.returncode == 0 and result.stderr == ""
    assert (tmp_path / "outputs" / "ch3.3-engine" / "ex7_shadow.rrd").stat().st_size > 0
    assert [p.name for p in (tmp_path / "outputs" / "ch3.3-engine").iterdir()] == ["ex7_shadow.rrd"]

