"""Exercise 7, predict then run: what does semi-implicit Euler keep, if not the energy?

    python -m exercises.ex7_shadow_energy                  # the formula and the question, nothing else
    python -m exercises.ex7_shadow_energy --predict spring=<word>,orbit=<word>,freefall=<word>

With V(q) the potential energy, so that the energy is E = m v . v / 2 + V(q) and the force is
F = -grad V (minus V's slope), the candidate is a nearby energy

    E~ = E - (dt/2) v . grad V(q) = E + (dt/2) v . F(q)

The program runs the chapter's three systems (seed 0, 2000 steps of dt 0.01) under semi-implicit Euler,
measures how far E and E~ each move from where they started; --more runs the orbit again with dt halved
and tries the same E~ on explicit Euler and RK4. Then it writes a recording of both errors on the step
timeline (outputs/ch3.3-engine/ex7_shadow.rrd; --no-rerun skips it, --rrd PATH puts it elsewhere).
"""

import sys

from curriculum.common.exercise import start

start(__file__)  # first: Ctrl-C is one line from here on, and the exercise runs as a file too

import argparse
from pathlib import Path

import numpy as np

from curriculum.common.cli import OneLineParser
from curriculum.common.outputs import one_line_failures, write_atomic
from curriculum.common.predict import PerName, ask, explain, verdict
from curriculum.common.viewer import recording_refused
from exercises.support import shadow
from exercises.support.shadow import DT, STEPS, SYSTEMS

CHOICES = ("as_far", "smaller", "roundoff")
LONG_STEPS = 16_000  # explicit Euler's E~ on the spring, 8 times the chapter's run
DEFAULT_RRD = Path("outputs/ch3.3-engine/ex7_shadow.rrd")
QUESTION = """\
Semi-implicit Euler does not keep the energy E = m v . v / 2 + V(q), where V is the potential
energy and F = -grad V (minus V's slope) the force. A candidate for what it keeps instead is a
nearby energy,

    E~ = E - (dt/2) v . grad V(q) = E + (dt/2) v . F(q)

(on the spring, V = k x^2 / 2, so E~ = E - k dt x v / 2). Run the spring, the orbit and the freefall for
2000 steps of dt 0.01 under semi-implicit Euler. For each system, how far does E~ move from its
start, compared with E?
  as_far:   as far as E does (or farther)
  smaller:  a real change, but smaller than E's, by a factor that shrinks with dt
  roundoff: round-off only, as if E~ were kept exactly"""


def measure_all() -> dict:
    """{system: shadow.measure(system)}: the chapter's three runs under semi-implicit Euler."""
    return {name: shadow.measure(name) for name in SYSTEMS}


def print_table(runs: dict, guess: dict) -> dict:
    """The graded table; returns the answers {system: word}."""
    answers = {name: shadow.how_far(run) for name, run in runs.items()}
    print(f"semi-implicit Euler, seed 0, {STEPS:,} steps of dt {DT} ({STEPS * DT:g} s)")
    print("band: the worst |X - X0| / |X0| over the run; round-off bound: the most rounding alone could move E~")
    print(f"{'system':<10}{'E band':>12}{'E~ band':>12}{'round-off bound':>17}{'E~ moved':>11}   you said")
    for name, run in runs.items():
        mark = "right" if guess[name] == answers[name] else "no"
        # Round-off figures are printed to one digit: the next ones are noise.
        shown = f"{run['shadow_band']:.0e}" if answers[name] == "roundoff" else f"{run['shadow_band']:.3e}"
        print(f"{name:<10}{run['energy_band']:>12.3e}{shown:>12}{run['roundoff']:>17.0e}{answers[name]:>11}"
              f"   {guess[name]} ({mark})")
    return answers


def print_ladder(ladder: list) -> None:
    print(f"the orbit at a fixed {STEPS * DT:g} s while dt halves: each band, and the factor it shrank by")
    print(f"{'dt':>9}{'steps':>9}{'E band':>13}{'factor':>8}{'E~ band':>13}{'factor':>8}")
    previous = None
    for dt, steps, energy_band, shadow_band in ladder:
        factors = ("", "") if previous is None else (f"{previous[0] / energy_band:.2f}",
                                                    f"{previous[1] / shadow_band:.2f}")
        print(f"{dt:>9g}{steps:>9,}{energy_band:>13.3e}{factors[0]:>8}{shadow_band:>13.3e}{factors[1]:>8}".rstrip())
        previous = (energy_band, shadow_band)


def other_integrators() -> dict:
    """{(system, integrator): run} for explicit Euler and RK4 on the spring and the orbit. Not the freefall:
    under a constant force each of them keeps some nearby quantity exactly too, which would blur the lesson."""
    return {(name, integrator): shadow.measure(name, integrator)
            for name in ("spring", "orbit") for integrator in ("euler", "rk4")}


@one_line_failures("exercises.ex7_shadow_energy")  # Ctrl-C or a closed stdout: one line, no traceback
def main(argv=None) -> int:
    parser = OneLineParser(prog="exercises.ex7_shadow_energy", description=__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--no-rerun", dest="rerun", action="store_false", help="skip writing the recording")
    parser.add_argument("--rrd", type=Path, metavar="PATH", default=DEFAULT_RRD,
                        help=f"where the recording goes (default {DEFAULT_RRD})")
    guess = ask(parser, QUESTION, PerName(list(SYSTEMS), CHOICES), argv,
                check=lambda args: recording_refused(parser.prog, args))
    args = parser.parsed

    runs = measure_all()
    answers = print_table(runs, guess)
    verdict(answers)

    explain_all(runs)
    if args.rerun:
        from exercises.support.shadow_recording import record

        write_atomic(args.rrd, record(runs))  # built in memory, then written whole, as exercise 5's
        print(f"\nrecording: {args.rrd} (open it with: rerun {args.rrd})")
    return 0


def explain_all(runs: dict) -> None:
    """The lesson; with --more, the ladder and the other integrators, measured then, and the whole story."""
    orbit = runs["orbit"]
    explain("", "On the spring and the freefall E~ moved by round-off only: semi-implicit Euler keeps it exactly"
            f" there. On the orbit it moved {orbit['energy_band'] / orbit['shadow_band']:.0f} times less than E,"
            " and it shrinks like dt^2 where E's band shrinks like dt: E~ is the first two terms of an energy the"
            " step keeps (backward error analysis). Since E = E~ - (dt/2) v . F(q), E stays in a band wherever v"
            " and F keep coming back. On the freefall v_z grows without end, so E drifts while E~ holds.",
            more=lambda: the_whole_story(runs))


def the_whole_story(runs: dict) -> list:
    """The full explanation (--more): two more tables, measured here, then every figure of the three."""
    ladder = shadow.halving_ladder("orbit")
    print_ladder(ladder)
    others = other_integrators()
    long_euler = shadow.measure("spring", "euler", steps=LONG_STEPS)
    print(f"\nthe same E~ under the other two integrators, dt {DT}, {STEPS:,} steps (not on the freefall: see below)")
    print(f"{'system':<10}{'integrator':<12}{'E band':>13}{'E~ band':>13}")
    for (name, integrator), run in others.items():
        print(f"{name:<10}{integrator:<12}{run['energy_band']:>13.3e}{run['shadow_band']:>13.3e}")
        if (name, integrator) == ("spring", "euler"):
            print(f"{'':<22}{long_euler['energy_band']:>13.3e}{long_euler['shadow_band']:>13.3e}"
                  f"   after {LONG_STEPS:,} steps")

    spring, orbit, freefall = runs["spring"], runs["orbit"], runs["freefall"]
    fall = freefall["system"]
    g = -fall["force"](fall["q0"], fall["v0"])[2] / fall["m"]
    seconds = STEPS * DT
    drift = (freefall["energy"][-1] - freefall["energy"][0]) / abs(freefall["energy"][0])
    predicted = -0.5 * DT * fall["m"] * g * g * seconds / abs(freefall["energy"][0])
    depth = -float(np.min(freefall["positions"][:, 2]))
    (_, _, e_first, s_first), (_, _, e_next, s_next) = ladder[0], ladder[1]
    return [
        "",
        "Backward error analysis (Hairer, Lubich and Wanner, Geometric Numerical Integration, chapter IX) turns"
        " the question round: not how far the steps are from the true motion, but which motion they follow"
        " exactly. For semi-implicit Euler the answer is, very nearly, the exact motion of a slightly different"
        " system; because the method is symplectic, that system is again a mechanical one, with an energy of its"
        " own, E + (dt/2) v . F(q) + (terms in dt^2, dt^3, ...). The steps keep that energy, not E (to an error"
        " too small to see, for a time that grows exponentially as dt shrinks). The E~ you measured is its first"
        " two terms.",
        f"- spring: a linear force. The step is a fixed 2x2 map (exercise 5), and E~ = E - k dt x v / 2 is"
        " kept by it exactly (the rest of the series only multiplies it by a constant): what you see,"
        f" {spring['shadow_band']:.0e}, is round-off, under the"
        f" {spring['roundoff']:.0e} that rounding could do in {STEPS:,} steps. E itself moves by"
        f" {spring['energy_band']:.2e} and comes back.",
        f"- orbit: a force that is not linear, so the series goes on past E~, and what E~ leaves out is of"
        f" order dt^2. E~ moves by {orbit['shadow_band']:.2e}, {orbit['energy_band'] / orbit['shadow_band']:.0f}"
        f" times less than E. Halve dt at a fixed {seconds:g} s and E~'s band shrinks by"
        f" {s_first / s_next:.2f} (dt^2), E's by {e_first / e_next:.2f} (dt): E's band is the dt term itself.",
        f"- freefall: a constant force, the series stops at E~, and E~ = E - (dt/2) m g v_z is"
        f" kept exactly too (one step: v_z loses"
        f" g dt, z gains dt v_z_new, and the three terms cancel). The {freefall['shadow_band']:.0e} is round-off"
        f" at a depth of {depth:,.0f} m, where the kinetic and the potential energy are each about"
        f" {round(fall['m'] * g * depth, -3):,.0f} J and each rounds at that size; it grows with the run.",
        "Why E stays in a band: E = E~ - (dt/2) v . F(q). E~ stays put, so E can only move as far as that last"
        " term does, and on the spring and the orbit v and F keep returning to where they were: a band whose"
        " width is proportional to dt, however long the run.",
        f"Why the freefall breaks it: there v_z = -g t grows without end, and so does (dt/2) m g v_z. E must"
        f" drift by exactly -(dt/2) m g^2 t, {predicted:+.4e} of E0 after {seconds:g} s; measured"
        f" {drift:+.4e}. The method is just as symplectic here, and keeps E~ just as well: it is the distance"
        " between E and E~ that has no bound.",
        f"- This E~ is semi-implicit Euler's. Explicit Euler is not symplectic: on the spring and the orbit it"
        f" keeps no nearby energy, and its E~ grows with its E (spring:"
        f" {others[('spring', 'euler')]['shadow_band']:.2g} after {STEPS:,} steps,"
        f" {long_euler['shadow_band']:.0f} after {LONG_STEPS:,}). RK4 nearly keeps E itself, so its E~ wobbles"
        f" by the correction's own size ({others[('spring', 'rk4')]['shadow_band']:.1e} on the spring,"
        f" {others[('orbit', 'rk4')]['shadow_band']:.1e} on the orbit), far above RK4's own error. (Not on the"
        " freefall: under a constant force explicit Euler keeps E + (dt/2) v . grad V exactly, the same"
        " correction with the other sign, and RK4 keeps E itself, which would blur the comparison.)",
        "- MuJoCo keeps it too. mj_step with mjINT_EULER (MuJoCo 3.10.0, mj_Euler) on an undamped spring, a slide"
        " joint with a stiffness, keeps E~ computed from its own qpos and qvel to round-off (tests/test_ex7.py"
        " runs it). That is a linear spring without damping: with joint damping mj_Euler is implicit in the"
        " damper (exercise 6), and contacts are another chapter.",
    ]


if __name__ == "__main__":
    sys.exit(main())
