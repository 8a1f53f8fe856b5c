"""Exercise 1, predict then run: does each integrator's energy error grow with the run, or stay in a band?

    python -m exercises.ex1_band                                            # the question, and nothing else
    python -m exercises.ex1_band --predict euler=?,semi_implicit=?,rk4=?   # grows or stays, for each ?

The evidence is the chapter's orbit (seed 0, dt 0.01) run 1x, 2x, 4x, 8x and 16x as long as the
chapter's 2000 steps. For each integrator and each length the program shows the signed energy
error (E - E0) / |E0| at its lowest and at its highest from the start to the end of that run. An
error that grows with the run keeps widening that range when the run doubles; one that stays in a
band stops widening.
"""

import sys

from curriculum.common.exercise import start

start(__file__)  # first: Ctrl-C is one line from here on, and the exercise runs as a file too

import argparse
import functools

import numpy as np

import engine
import engine_ensembles
from curriculum.common.cli import OneLineParser
from curriculum.common.outputs import one_line_failures
from curriculum.common.predict import PerName, ask, explain, verdict
from engine_referee import relative_energy_error

NAMES = list(engine.CHAPTER_INTEGRATORS)  # the chapter's three
WORDS = ["grows", "stays"]  # grows with the run, or stays in a band
# The question's own phrases, and the chapter's word for a band, read as the two answers.
HORIZONS = [1, 2, 4, 8, 16]  # multiples of the chapter's run
CHAPTER_STEPS, DT = 2000, 0.01
BAND_SLACK = 0.01  # a range that widens by less than 1% when the run doubles has stopped: a band
SEEDS = range(1000)  # is RK4's sign seed 0's? asked of these seeds, stepped as one batch


def measure(seed: int = 0) -> dict:
    """{integrator: [(lowest, highest, final) of (E - E0) / |E0| over the first h chapter-runs, for h in HORIZONS]}.

    One run of the longest horizon per integrator; the shorter ones are its beginnings."""
    system = engine.build_system("orbit", np.random.default_rng(seed))
    table = {}
    for name in NAMES:
        _, _, energies = engine.simulate(engine.INTEGRATORS[name], system, DT, CHAPTER_STEPS * HORIZONS[-1])
        error = relative_energy_error(energies)
        table[name] = [(float(error[: CHAPTER_STEPS * h + 1].min()), float(error[: CHAPTER_STEPS * h + 1].max()),
                        float(error[CHAPTER_STEPS * h])) for h in HORIZONS]
    return table


def widening(rows: list) -> float:
    """How many times wider the range of the last row is than that of the one before it (1.0: not at all)."""
    (low_before, high_before, _), (low, high, _) = rows[-2], rows[-1]
    return (high - low) / (high_before - low_before)


def answer(rows: list) -> str:
    return "grows" if widening(rows) > 1.0 + BAND_SLACK else "stays"


def rk4_above_e0(seeds=SEEDS) -> tuple[int, int]:
    """Over many seeds (one batch), the chapter's run under RK4: (members whose energy is above E0 at some step,
    members that end below E0)."""
    batch = engine_ensembles.build_ensemble(functools.partial(engine.build_system, "orbit"), seeds)
    _, _, energies = engine.simulate_long(engine.rk4_step, batch, DT, CHAPTER_STEPS, every=CHAPTER_STEPS)
    error = energies - energies[0]
    return int(np.count_nonzero((error > 0).any(axis=0))), int(np.count_nonzero(error[-1] < 0))


def print_table(table: dict) -> None:
    print(f"orbit, seed 0, dt {DT}: the signed energy error (E - E0) / |E0|, its lowest and highest over each run")
    print(f"{'run':<24}" + "".join(f"{f'{h}x':>12}" for h in HORIZONS))
    print(f"{'integrator':<15}{'steps':<9}" + "".join(f"{h * CHAPTER_STEPS:>12,}" for h in HORIZONS))
    for name, rows in table.items():
        print(f"{name:<15}{'highest':<9}" + "".join(f"{high:>+12.3e}" for _, high, _ in rows))
        print(f"{'':<15}{'lowest':<9}" + "".join(f"{low:>+12.3e}" for low, _, _ in rows))


@one_line_failures("exercises.ex1_band")  # Ctrl-C or a closed stdout (`| head`): one line, no traceback
def main(argv=None) -> int:
    parser = OneLineParser(prog="exercises.ex1_band", description=__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    prediction = ask(parser, f"The chapter's orbit, run {', '.join(f'{h}x' for h in HORIZONS[:-1])} and"
                     f" {HORIZONS[-1]}x as long as its {CHAPTER_STEPS:,} steps: for each integrator, does the energy"
                     " error grow with the run, or stay in a band?", PerName(NAMES, WORDS), argv)

    table = measure()
    print_table(table)
    answers = {name: answer(rows) for name, rows in table.items()}
    print(f"\nGraded per integrator: 'grows' if the range widened by more than {BAND_SLACK:.0%} from"
          f" {HORIZONS[-2]}x to {HORIZONS[-1]}x, else 'stays':")
    for name, rows in table.items():
        mark = "right" if prediction[name] == answers[name] else "not quite"
        print(f"  {name:<15} you said {prediction[name]:<6} measured: {widening(rows):.3f} times as wide as at"
              f" {HORIZONS[-2]}x -> {answers[name]}: {mark}")
    verdict(answers)

    rk4 = table["rk4"]
    explain("", "Two grow and one stays, at very different sizes. Explicit Euler's error is big and every doubling"
            " widens it: the orbit spirals out. Semi-implicit Euler's goes up and comes back, inside a band its first"
            f" run already filled. RK4's is tiny, yet it grows about in proportion to the run:"
            f" {widening(rk4[:1] + rk4[-1:]):.1f} times as wide after {HORIZONS[-1]} times as long. Small and bounded"
            " are different things.", more=lambda: the_whole_story(table))
    return 0


def the_whole_story(table: dict) -> list:
    """The full explanation (--more), every figure from this run; the seeds' signs measured here, only for it."""
    euler, semi, rk4 = table["euler"], table["semi_implicit"], table["rk4"]
    above, ends_below = rk4_above_e0()
    semi_width = semi[-1][1] - semi[-1][0]
    longest = f"{HORIZONS[-1]}x"
    worst_is_final = all(final == high for _, high, final in euler)
    return [
        f"- euler: {euler[0][1]:+.1%} after the chapter's run, {euler[-1][1]:+.1%} after {longest}"
        f"{', its worst excursion always the last step' if worst_is_final else ''}, and"
        f" {'never once below E0: its lowest is the start itself' if euler[-1][0] == 0 else 'below E0 at times'}."
        f" Each doubling widens the range less than the one before ({widening(euler[:2]):.2f} times from 1x to 2x,"
        f" {widening(euler):.2f} from {HORIZONS[-2]}x to {longest}), but every one widens it: it grows with the"
        " run, and it is big. Each step moves the position with the old velocity, which overshoots outwards: the"
        " orbit spirals out.",
        f"- semi_implicit: from {semi[0][0]:+.3e} to {semi[0][1]:+.3e} after the chapter's run, which ends at"
        f" {semi[0][2]:+.3e}: its worst excursion is bigger than where it ends, because the energy went up and came"
        f" back. After {longest} the range is {widening(semi[:1] + semi[-1:]):.7f} times as wide. The error stays"
        " on both sides of E0, inside a band that the first run already filled: it does not grow with the run."
        " Exercise 5 shows what holds it there.",
        f"- rk4: after the chapter's run its error is {-rk4[0][0]:.2e} of the energy, {semi[0][1] / -rk4[0][0]:.1e}"
        f" times below the top of semi-implicit Euler's band. Its lowest goes from {rk4[0][0]:+.2e} to"
        f" {rk4[-1][0]:+.2e}, {widening(rk4[:1] + rk4[-1:]):.1f} times as wide for {HORIZONS[-1]} times the run:"
        " it grows with the run, about in proportion. For seed 0 it goes one way"
        f"{', down: its highest is the start itself' if rk4[-1][1] == 0 else ''}. That sign is seed 0's,"
        f" not RK4's: run seeds {SEEDS[0]}-{SEEDS[-1]} for the chapter's {CHAPTER_STEPS:,} steps, and {above:,} of"
        f" the {len(SEEDS):,} are above E0 at some step ({ends_below:,} end below it).",
        f"- So two grow, at very different sizes: after {longest} explicit Euler's error is {euler[-1][1]:.2f} of"
        f" the energy and RK4's {-rk4[-1][0]:.1e}, still {semi_width / (rk4[-1][1] - rk4[-1][0]):.1e} times"
        f" narrower than semi-implicit Euler's band ({semi_width:.1e} wide). Small and bounded are different"
        " things: exercise 4 asks how long a run has to be for RK4's growing error to leave the band.",
    ]


if __name__ == "__main__":
    sys.exit(main())
