"""Exercise 3, predict then run: halve the timestep. By what factor does each error shrink?

    python -m exercises.ex3_halve_dt                                          # the question
    python -m exercises.ex3_halve_dt --predict euler=?,semi_implicit=?,rk4=?  # your three factors
    python -m exercises.ex3_halve_dt --predict ... --system spring            # the same on the spring

The simulated time stays fixed (5 s) while dt walks down a ladder of five halvings. At each rung
two errors are measured: how far the final position is from the exact solution (Kepler's equation
for the orbit, the cosine for the spring), and the energy's worst relative excursion. The table
shows by what factor each error shrank from one rung to the next.
"""

import sys

from curriculum.common.exercise import start

start(__file__)  # first: Ctrl-C is one line from here on, and the exercise runs as a file too

import argparse
import math

import numpy as np

import engine
from curriculum.common.cli import OneLineParser
from curriculum.common.outputs import one_line_failures
from curriculum.common.predict import PerName, ask, explain, verdict
from engine_referee import distance

SIM_SECONDS = 5.0  # not a whole number of periods: at one, some error terms cancel and the ladder zigzags
# Each ladder starts where its method's error is already small. RK4's is so small by its last rungs
# that its finest errors fall below FLOOR, where a factor would start to show rounding: those show as (<5e-11).
LADDERS = {"euler": [0.01 / 2**k for k in range(6)], "semi_implicit": [0.01 / 2**k for k in range(6)],
           "rk4": [0.1 / 2**k for k in range(6)]}
FACTORS = [1, 2, 4, 8, 16, 32]
SYSTEMS = ["orbit", "spring"]  # the two whose motion comes back, with their exact motions in engine.py
# The rounding in these errors, measured against the same runs in 50-digit arithmetic, is up to 1.4e-14
# in a final position and 1.8e-15 in an energy error. Within about 3,000 times that, a factor's second
# decimal (0.03% of 16) could be rounding, not the method: a factor whose finer error is under this display
# threshold is not shown. (RK4's last position factor on the orbit would print 16.18; its exact value is 16.16.)
FLOOR = {"position": 5e-11, "energy": 5e-12}


def measure(system_name: str = "orbit", seed: int = 0) -> dict:
    """{measure: {integrator: [error at each rung of its ladder]}} for measure in ("position", "energy")."""
    system = engine.build_system(system_name, np.random.default_rng(seed))
    errors = {"position": {}, "energy": {}}
    for name in engine.CHAPTER_INTEGRATORS:
        step = engine.INTEGRATORS[name]
        errors["position"][name], errors["energy"][name] = [], []
        for dt in LADDERS[name]:
            steps = round(SIM_SECONDS / dt)
            trajectory, _, energies = engine.simulate(step, system, dt, steps)
            exact_final = system["exact"](system["q0"], system["v0"], [steps * dt])[0]
            errors["position"][name].append(float(distance(trajectory[-1], exact_final)))
            errors["energy"][name].append(engine.energy_drift(energies)["rel_max"])
    return errors


def shrink_factors(rung_errors: list, floor: float) -> list:
    """error(dt) / error(dt / 2) down the ladder; None where the finer error is below the floor."""
    return [coarse / fine if fine > floor else None for coarse, fine in zip(rung_errors, rung_errors[1:], strict=False)]


def settled(factors: list) -> float | None:
    """What the ladder converges to: the last factor above the round-off floor."""
    usable = [f for f in factors if f is not None]
    return usable[-1] if usable else None


def nearest_power_of_two(factor: float) -> int:
    return 2 ** round(math.log2(factor))


def print_ladder(errors: dict) -> None:
    for measure_name, by_integrator in errors.items():
        what = "final position error |q - q_exact|" if measure_name == "position" else "energy error max|E-E0|/|E0|"
        print(f"\n{what}: shrink factor per halving of dt")
        below = f"(<{FLOOR[measure_name]:g})"  # the finer error is below the floor: no factor shown
        for name, rung_errors in by_integrator.items():
            ladder = LADDERS[name]
            cells = shrink_factors(rung_errors, FLOOR[measure_name])
            span = f"dt {ladder[0]:g} -> {ladder[-1]:g}:"
            print(f"  {name:<15}{span:<24}"
                  + "".join(f"{f:>8.2f}" if f else f"{below:>12}" for f in cells))


def lesson(system_name: str, errors: dict) -> str:
    """The short lesson: the one figure is where RK4's position ladder settles."""
    rk4 = settled(shrink_factors(errors["position"]["rk4"], FLOOR["position"]))
    energy = ("on the spring RK4's stays near 32" if system_name == "spring" else
              "on the orbit RK4's slides from near 32 towards 16")
    return (f"Halve dt and both Eulers' position error halves: order 1. RK4's shrinks about 16-fold, order 4:"
            f" its ladder settles at {rk4:.2f}. Semi-implicit Euler's bounded energy does not raise its order: its"
            f" position error, though smaller here, still only halves. The energy error keeps a ladder of its own:"
            f" {energy}. Ask"
            " which error, and at which dt, before you quote a factor.")


def story(system_name: str, errors: dict) -> list:
    """The full explanation (--more), from this run's numbers: every row of both tables, for this system."""
    def factors(measure_name, name):
        return shrink_factors(errors[measure_name][name], FLOOR[measure_name])

    def span(values):
        shown = [f for f in values if f is not None]
        return f"{shown[0]:.2f}" if len(shown) == 1 else f"from {shown[0]:.2f} to {shown[-1]:.2f}"

    rk4_position, rk4_energy = factors("position", "rk4"), factors("energy", "rk4")
    side = "above" if rk4_position[0] > 16 else "below"
    finest = errors["position"]["rk4"][-1]
    lines = [
        "What the ladder shows:",
        f"- Position, euler ({span(factors('position', 'euler'))}) and semi_implicit"
        f" ({span(factors('position', 'semi_implicit'))}): both settle at 2, order 1. Halve dt, halve the"
        " error. Semi-implicit Euler's energy stays bounded, yet its position error is first order like"
        " explicit Euler's: bounded and accurate are different virtues.",
        f"- Position, rk4 ({span(rk4_position)}): order 4, a factor of 16. It comes to 16 from {side}: at the"
        f" coarse rungs the next term of RK4's error, of order dt^5, {'adds to' if side == 'above' else 'takes from'}"
        " the dt^4 term, and it fades as dt shrinks. RK4's ladder starts at dt 0.1, ten times coarser than"
        f" the Eulers': from 0.01 its error would drop below {FLOOR['position']:g} within two halvings, and the"
        " table shows no factor below that. The threshold sits far above the rounding itself (about 1e-14),"
        " so that no digit shown is rounding. " + (
            "Here RK4's finest error falls below it: that rung shows no factor." if finest <= FLOOR["position"] else
            f"Here RK4's finest error, {finest:.2e}, stays above it: every factor shows."),
        f"- Energy, euler ({span(factors('energy', 'euler'))}) and semi_implicit"
        f" ({span(factors('energy', 'semi_implicit'))}): first order too. For semi-implicit Euler this error is"
        " its band's farthest reach from E0, and it halves with dt.",
    ]
    if system_name == "spring":
        lines.append(
            f"- Energy, rk4 ({span(rk4_energy)}): 32 at every rung, not 16. For a linear force like the spring's,"
            " RK4's energy error per step is of order dt^6, so over a fixed time it is order 5: a factor of 32.")
    else:
        lines.append(
            f"- Energy, rk4 ({span(rk4_energy)}): not 16 either. The orbit's energy error has a dt^5 term and a"
            " smaller dt^4 one: at coarse dt the first dominates (a factor near 32), and as dt shrinks the dt^4"
            " term takes over and the factor slides towards 16. (On the spring, whose force is linear, there is"
            " no dt^4 term: try --system spring.)")
    lines.append("- So \"order 4\" is a statement about the position error, once dt is small. Ask which error,"
                 " and at which dt, before you quote a factor.")
    return lines


@one_line_failures("exercises.ex3_halve_dt")  # Ctrl-C or a closed stdout (`| head`): one line, no traceback
def main(argv=None) -> int:
    parser = OneLineParser(prog="exercises.ex3_halve_dt", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--system", choices=SYSTEMS, default="orbit", help="which system (default orbit)")
    prediction = ask(parser,
                     f"Halve dt, keeping {SIM_SECONDS:g} s of simulated time. By what factor does each integrator's"
                     " final position error shrink?", PerName(engine.CHAPTER_INTEGRATORS, FACTORS), argv,
                     variant="system")
    system_name = parser.parsed.system

    errors = measure(system_name)
    print(f"{system_name}, seed 0, {SIM_SECONDS:g} s of simulated time, dt halved five times")
    print_ladder(errors)

    print("\nGraded on the position error, against where its ladder settles:")
    truths = {}
    for name, guess in prediction.items():
        factor = settled(shrink_factors(errors["position"][name], FLOOR["position"]))
        truths[name] = truth = nearest_power_of_two(factor)
        mark = "right" if guess == truth else "not quite"
        print(f"  {name:<15} you said {guess:>2}, measured {factor:5.2f} -> {truth:>2}: {mark}"
              f" (order {math.log2(truth):g})")
    verdict(truths)
    explain("", lesson(system_name, errors), more=lambda: story(system_name, errors))
    return 0


if __name__ == "__main__":
    sys.exit(main())
