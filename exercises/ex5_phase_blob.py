"""Exercise 5, predict then run: what happens to a blob of states in phase space?

    python -m exercises.ex5_phase_blob                  # the question, and nothing else
    python -m exercises.ex5_phase_blob --predict euler=<word>,semi_implicit=<word>,rk4=<word>

Take the spring, and instead of one starting state take a whole blob of them: a small disc in
the (x, v_x) plane, its edge sampled by 360 points. Run every point for the chapter's 2000 steps
of dt 0.01 under each integrator. The program measures the blob's area after every step, then
writes a recording of the blob moving (outputs/ch3.3-engine/ex5_blob.rrd; --no-rerun skips it).
"""

import sys

from curriculum.common.exercise import start

start(__file__)  # first: Ctrl-C is one line from here on, and the exercise runs as a file too

import argparse
import math
from fractions import Fraction
from pathlib import Path

import numpy as np

import engine
from curriculum.common import recording as course
from curriculum.common.cli import OneLineParser
from curriculum.common.outputs import one_line_failures, write_atomic
from curriculum.common.predict import PerName, ask, explain, verdict
from curriculum.common.viewer import recording_refused

CHOICES = ("grows", "stays", "shrinks")
STEPS, DT, COARSE_DT = 2000, 0.01, 0.1
PAST_LIMIT_DT, PAST_LIMIT_STEPS = 1.05, 10  # w dt = 2.1, just past the semi-implicit step's stability limit
CENTRE, RADIUS, EDGE_POINTS = (1.0, 0.0), 0.25, 360  # the chapter's spring starts near x = 1, v = 0
SAME = 1e-12  # |area ratio - 1| below this is "stays": round-off in 2000 steps is ~100x smaller
RECORD_EVERY, RECORD_POINTS = 5, 120  # the recording's frames and edge points: enough to see, small to open

# --- the blob and its area ---

def spring():
    """(m, force, k, omega): the chapter's spring; its stiffness read off its own force law."""
    system = engine.build_system("spring", np.random.default_rng(0))
    m, force = system["m"], system["force"]
    k = -force(np.array([1.0, 0.0, 0.0]), np.zeros(3))[0]  # force per metre of stretch
    return m, force, k, math.sqrt(k / m)


def energy(x, v):
    """The spring's true energy along x: kinetic + spring."""
    m, _, k, _ = spring()
    return 0.5 * m * v * v + 0.5 * k * x * x


def blob_edge(points: int = EDGE_POINTS):
    """(q, v), each (points, 3): the disc's edge in order round the circle, all motion along x."""
    angle = np.arange(points) * (2.0 * math.pi / points)
    q, v = np.zeros((points, 3)), np.zeros((points, 3))
    q[:, 0] = CENTRE[0] + RADIUS * np.cos(angle)
    v[:, 0] = CENTRE[1] + RADIUS * np.sin(angle)
    return q, v


def shoelace_areas(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Area inside each closed polygon (x[k, i], y[k, i]) over i, one per row k, by the shoelace formula.

    Each product x_i y_(i+1) is rounded once, to about 1e-16 of itself, and math.fsum then adds the
    rounded terms exactly and rounds once more. So an area carries the rounding of its products on top
    of the rounding already in the points: some 1e-15 of the area while the coordinates are the size of
    the disc, which is what lets a change of 1e-9 show. On a long thin needle the products are far larger
    than the area and cancel, and their rounding is what shows (see exact_area)."""
    terms = x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y
    return np.array([0.5 * abs(math.fsum(row)) for row in terms.tolist()])


def exact_area(x: np.ndarray, y: np.ndarray) -> Fraction:
    """The area inside one polygon of float points, in exact rational arithmetic: no rounding at all."""
    xs, ys = [Fraction(value) for value in x.tolist()], [Fraction(value) for value in y.tolist()]
    return abs(sum(a * d - c * b for a, b, c, d in zip(xs, ys, xs[1:] + xs[:1], ys[1:] + ys[:1], strict=True))) / 2


def run_blob(name: str, dt: float, steps: int):
    """Step the whole edge at once. Returns areas (steps+1,) and the edge's positions x and
    velocities v along the spring's axis, each (steps+1, points)."""
    m, force, _, _ = spring()
    q, v = blob_edge()
    x, vx = np.empty((steps + 1, len(q))), np.empty((steps + 1, len(q)))
    x[0], vx[0] = q[:, 0], v[:, 0]
    with np.errstate(all="ignore"):  # past the stability limit the edge runs off towards inf
        for i in range(1, steps + 1):
            q, v = engine.INTEGRATORS[name](q, v, m, force, dt)
            x[i], vx[i] = q[:, 0], v[:, 0]
    return shoelace_areas(x, vx), x, vx


def one_step_determinant(name: str, h: float) -> tuple[float, float]:
    """(det - 1, trace) of one step's 2x2 matrix on the harmonic oscillator, h = omega * dt.

    On (x, v/omega): explicit Euler [[1, h], [-h, 1]]; semi-implicit Euler [[1 - h^2, h], [-h, 1]];
    RK4 the degree-4 Taylor polynomial of the exact rotation. det - 1 is returned, not det, so
    RK4's -h^6/72 survives at h = 0.02 (1 + 1e-12 would already have lost digits)."""
    if name == "euler":
        return h * h, 2.0
    if name == "semi_implicit":
        return 0.0, 2.0 - h * h
    h2 = h * h
    return -h2 * h2 * h2 / 72.0 + h2 * h2 * h2 * h2 / 576.0, 2.0 - h2 + h2 * h2 / 12.0


def closed_form_ratio(name: str, h: float, steps: int) -> float:
    """det ** steps - 1, computed as expm1(steps * log1p(det - 1)) to keep the small ones' digits."""
    return math.expm1(steps * math.log1p(one_step_determinant(name, h)[0]))


def what_the_area_does(ratio_minus_one: float) -> str:
    if ratio_minus_one > SAME:
        return "grows"
    return "shrinks" if ratio_minus_one < -SAME else "stays"


def measure(dt: float, steps: int) -> dict:
    """{integrator: {"areas", "ratios", "measured", "closed_form", "worst_gap", "x", "v"}}: ratios are
    area / area0 - 1 after every step, measured the last of them, worst_gap the largest relative gap
    between the measured area and the closed form's, over every step."""
    h = spring()[3] * dt
    table = {}
    for name in engine.CHAPTER_INTEGRATORS:
        areas, x, vx = run_blob(name, dt, steps)
        with np.errstate(all="ignore"):
            ratios = areas / areas[0] - 1.0
        closed = np.array([closed_form_ratio(name, h, n) for n in range(steps + 1)])
        gap = np.abs((ratios - closed) / (1.0 + closed))  # relative to the area itself
        table[name] = {"areas": areas, "ratios": ratios, "measured": float(ratios[-1]),
                       "closed_form": float(closed[-1]), "worst_gap": float(np.max(gap)),
                       "x": x, "v": vx}
    return table


def modified_energy_drift(x: np.ndarray, v: np.ndarray, dt: float) -> tuple[float, float]:
    """For semi-implicit Euler on the spring: (worst relative change of the true energy, of the
    nearby quadratic E~ = E - k dt x v / 2), over every point and step. E~ is what the step keeps."""
    _, _, k, _ = spring()
    true = energy(x, v)
    nearby = true - 0.5 * k * dt * x * v
    return (float(np.max(np.abs(true / true[0] - 1.0))), float(np.max(np.abs(nearby / nearby[0] - 1.0))))

# --- the recording ---

def unit_of(ratios: np.ndarray) -> float:
    """The power of ten the recording draws an area change in: its largest |area / area0 - 1| reads 1 to 10."""
    top = float(np.max(np.abs(ratios)))
    return 10.0 ** math.floor(math.log10(top)) if top > 0.0 else 1.0


def record(path: Path, table: dict) -> None:
    """The blob's edge in the (x, v_x) plane on the `step` timeline, one colour per integrator, the
    starting disc in grey, and beside it each area's change, signed, in its own plot. Built in memory,
    then written atomically (write_atomic); it opens the course's way (curriculum/common/recording.py).

    The file opens on the last step: explicit Euler's blob swollen and far out, the other two on top of
    each other where the disc would be. Drag the timeline: the three circle the origin together."""
    import rerun as rr
    import rerun.blueprint as rrb

    def flat(x, v):  # the (x, v_x) plane as z = 0 of a 3D view seen from above: v_x points up, as on paper
        return np.stack([x, v, np.zeros_like(x)], axis=-1)

    def fill(stream):
        every_k = EDGE_POINTS // RECORD_POINTS
        frames = np.arange(0, STEPS + 1, RECORD_EVERY)
        looks = course.looks(table)
        edges = {name: flat(row["x"][frames][:, ::every_k], row["v"][frames][:, ::every_k])
                 for name, row in table.items()}
        start = next(iter(edges.values()))[0]
        stream.log("phase/start", rr.LineStrips3D([np.vstack([start, start[:1]])], colors=[course.GREY],
                                                  radii=rr.components.Radius.ui_points(1.5)), static=True)
        # rk4's blob and semi_implicit's coincide: each is drawn a little wider and a little lower (z) than
        # the next, so the thinner shows on top of the wider and both are seen
        widths = course.layered_widths(edges, widest=6.0, thinnest=2.0)
        for name, edge in edges.items():
            edge[..., 2] = -0.001 * widths[name]
            outline = rr.LineStrips3D.from_fields(colors=[looks[name].colour],
                                                  radii=rr.components.Radius.ui_points(widths[name] / 2))
            stream.log(f"phase/{name}", outline, static=True)
            for i, shape in zip(frames, edge, strict=True):  # one closed outline per frame
                stream.set_time("step", sequence=int(i))
                stream.log(f"phase/{name}", rr.LineStrips3D([np.vstack([shape, shape[:1]])]))
        low, high = course.extent(edges.values())
        span = float(max(high[0] - low[0], high[1] - low[1]))
        reach_low, reach_high = np.minimum(low, 0.0) - 0.08 * span, np.maximum(high, 0.0) + 0.08 * span
        course.log_axes(stream, "phase/axes", reach_low, reach_high, ("x", "v_x"))
        axes_box = np.array([reach_low, reach_high])
        key = course.log_key(stream, "phase/key", looks, [*edges.values(), axes_box])
        plane = course.from_above("phase", "the blob in (x, v_x), grey: where it started",
                                  [*edges.values(), axes_box, key], margin=1.3)

        # each area's change in its own plot, in true units times a power of ten the title names, the sign kept
        steps, plots = np.arange(STEPS + 1), []
        for name, row in table.items():
            unit, label = unit_of(row["ratios"]), looks[name].label
            change = course.log_series(stream, f"area/{name}/change", steps, row["ratios"] / unit, looks[name])
            course.log_series(stream, f"area/{name}/zero", [0, STEPS], [0.0, 0.0], course.Look(course.GREY, "0"))
            scale = "" if unit == 1.0 else f", in units of {unit:.0e}"
            verdict = f"round-off (under {SAME:g})" if abs(row["measured"]) < SAME else f"{row['measured']:+.3g}"
            plots.append(course.time_series(f"area/{name}", f"{label}: area / area0 - 1{scale}; at the end {verdict}",
                                            STEPS, [change, [0.0]]))
        area = rrb.Vertical(*plots)
        return course.opening(rrb.Horizontal(plane, area), STEPS)

    write_atomic(path, course.recorded("zero2robot-ch3_3-ex5", fill))

def the_whole_story(table: dict, omega: float) -> list:
    """The full explanation (--more): the coarse run and the run past the limit, measured here, then every figure."""
    coarse = measure(COARSE_DT, STEPS)
    print(f"the same at dt {COARSE_DT} (omega dt = {omega * COARSE_DT:g}), where RK4's change is plain:")
    for name, row in coarse.items():
        print(f"{name:<15}{row['measured']:>+15.4e}{row['closed_form']:>+15.4e}{row['worst_gap']:>26.1e}")
    print()

    h = omega * PAST_LIMIT_DT
    areas, x, v = run_blob("semi_implicit", PAST_LIMIT_DT, PAST_LIMIT_STEPS)
    growth = np.max(energy(x[-1], v[-1]) / energy(x[0], v[0]))
    needle_change = float(exact_area(x[-1], v[-1]) / exact_area(x[0], v[0]) - 1)  # exact, then rounded once
    needle_products = np.max(np.abs(x[-1] * np.roll(v[-1], -1)))  # the shoelace terms' size on the needle
    semi = table["semi_implicit"]
    true_band, _ = modified_energy_drift(semi["x"], semi["v"], DT)
    rk4_noise = abs(semi["measured"]) if semi["measured"] else 2.0 ** -52
    return [
        f"- euler: each step's matrix has determinant 1 + (omega dt)^2 = 1 + {(omega * DT) ** 2:.1e}; raised to"
        f" {STEPS} steps that is {1 + table['euler']['closed_form']:.4f}, and the blob measures"
        f" {1 + table['euler']['measured']:.4f}. The spring is linear, so the polygon maps to a polygon and"
        " its area follows the determinant exactly, however coarse the edge.",
        f"- semi_implicit: determinant exactly 1. The measured change, {semi['measured']:+.1e}, is round-off,"
        " in the points and in the shoelace formula's products: it is the floor below which nothing can be seen.",
        f"- rk4: determinant 1 - (omega dt)^6/72 + (omega dt)^8/576, a shrink of {-table['rk4']['closed_form']:.2e}"
        f" over the run, measured {table['rk4']['measured']:+.2e}:"
        f" about {abs(table['rk4']['measured']) / rk4_noise:.0e} times the floor. It shows because float64 keeps"
        " 16 digits, the shoelace sum adds its (rounded) products exactly (math.fsum)"
        f" and the closed form is computed as expm1/log1p. At dt {COARSE_DT} the same formula gives"
        f" {coarse['rk4']['closed_form']:+.2e}, plain to see.",
        "What the area has to do with energy: area 1 alone is not enough. Past omega dt = 2 the"
        f" semi-implicit step's trace 2 - (omega dt)^2 falls below -2. At dt {PAST_LIMIT_DT} (omega dt = {h:g})"
        f" its determinant is still exactly 1, and after {PAST_LIMIT_STEPS} steps the area of the blob's points,"
        f" computed exactly (fractions), has changed by {needle_change:+.1e}:"
        " round-off in the points. (The shoelace formula in floats says"
        f" {areas[-1] / areas[0] - 1:+.1e}: its products, up to {needle_products:.0e}, cancel"
        f" to an area of {areas[-1]:.2f}, and their rounding is what it measures.) Yet the energy of the points"
        f" has grown {growth:.1e} times: the disc is stretched into a thin needle that runs off to infinity.",
        f"With area 1 and a stable step (|trace| < 2, here {2 - (omega * DT) ** 2:g} at dt {DT}) both eigenvalues"
        " of the step lie on the unit circle, so nothing grows: every point goes round the origin for ever. Over"
        f" every point and step the true energy E moved by at most {true_band:.2e} and came back. That is the"
        " band: E is not conserved, but it is held near where it started, however long the run.",
        "Explicit Euler has no such bound (its area grows, so the points spiral out), and RK4's area shrinks by"
        " a hair each step: on this linear spring its energy goes down at every step, never back. Exercise 4"
        " measured how long such a creep takes to matter on the orbit.",
        "So on the spring the energy follows the area for explicit Euler and RK4, whose steps are a rotation"
        " times a scale, but not for semi-implicit Euler: its area is kept exactly while its E moves and comes"
        " back. What does it keep, if not E? Exercise 7 asks, with a nearby energy, E - k dt x v / 2 on this"
        " spring and E - (dt/2) v . grad V for any force.",
    ]


# --- the exercise ---


@one_line_failures("exercises.ex5_phase_blob")
def main(argv=None) -> int:
    parser = OneLineParser(prog="exercises.ex5_phase_blob", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--no-rerun", dest="rerun", action="store_false", help="skip writing the recording")
    parser.add_argument("--rrd", type=Path, metavar="PATH", default=Path("outputs/ch3.3-engine/ex5_blob.rrd"),
                        help="where the recording goes (default outputs/ch3.3-engine/ex5_blob.rrd)")
    guess = ask(parser, "A disc of starting states in the spring's (x, v_x) plane runs 2000 steps of dt 0.01"
                " under each integrator. What happens to the disc's area under each one?",
                PerName(list(engine.CHAPTER_INTEGRATORS), CHOICES), argv,
                check=lambda args: recording_refused(parser.prog, args))
    args = parser.parsed

    omega = spring()[3]
    table = measure(DT, STEPS)
    answers = {name: what_the_area_does(row["measured"]) for name, row in table.items()}
    print(f"spring (omega = {omega:g} rad/s), {EDGE_POINTS}-point edge, {STEPS} steps of dt {DT}"
          f" (omega dt = {omega * DT:g}): area after / area before - 1")
    print(f"{'integrator':<15}{'measured':>15}{'closed form':>15}{'worst rel. gap, any step':>26}   you said")
    for name, row in table.items():
        mark = "right" if guess[name] == answers[name] else f"no: it {answers[name]}"
        print(f"{name:<15}{row['measured']:>+15.4e}{row['closed_form']:>+15.4e}{row['worst_gap']:>26.1e}"
              f"   {guess[name]} ({mark})")
    verdict(answers)

    rk4 = table["rk4"]
    agrees = ("the closed form agrees at every digit shown" if f"{rk4['measured']:.4e}" == f"{rk4['closed_form']:.4e}"
              else f"the closed form says {-rk4['closed_form']:.2e}")
    explain("", "On the spring every step is a fixed 2x2 matrix, so each step multiplies the blob's area by that"
            " matrix's determinant. Explicit Euler's is 1 + (omega dt)^2: the area grows. Semi-implicit Euler's is"
            f" exactly 1: the area stays, up to round-off. RK4's is just under 1: its area shrank by"
            f" {-rk4['measured']:.2e}, a hair, and {agrees}. Keeping area is what symplectic means. It"
            " does not keep the energy, and area alone does not even bound it: past omega dt = 2 a step of"
            " determinant 1 runs away.", more=lambda: the_whole_story(table, omega))
    if args.rerun:
        record(args.rrd, table)
        print(f"\nrecording: {args.rrd} (open it with: rerun {args.rrd}; drag the `step` timeline)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
