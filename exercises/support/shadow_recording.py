"""Exercise 7's recording: E's and E~'s errors for each system, side by side on the `step` timeline.

One plot per system (spring, orbit, freefall, left to right), each with two lines: semi-implicit Euler's
energy E and its shadow energy E~. Each line is the worst relative change so far, |X - X0| / |X0|, as a
power of ten; a running maximum never comes down, so round-off reads as a flat line instead of noise.
One grey line, the run's round-off bound (the most that rounding alone could move E~, the exercise's
test for "roundoff"), is the floor: anything below it is drawn on it, so a line lying on the grey one
has moved no more than rounding can. All of Rerun for exercise 7 is here, loaded only when the exercise
records; it opens the course's way (curriculum/common/recording.py).
"""


import numpy as np

from curriculum.common import recording as course
from exercises.support.shadow import STEPS, worst_so_far

APPLICATION_ID = "zero2robot-ch3_3-ex7"
# E is semi-implicit Euler's energy, in that integrator's colour; E~ in a colour no integrator has.
LOOKS = {"energy": course.Look(course.COLOURS["semi_implicit"], "E: energy (semi-implicit Euler)"),
         "shadow": course.Look(course.PALETTE["bluish_green"], "E~: shadow energy")}
TOP = 0.5  # a little above log10 = 0, an error as large as the quantity itself: every curve fits under it
LEGEND_ROOM = 2.0  # decades below the lowest floor kept empty for the legend, so it covers no curve


def record(runs: dict) -> bytes:
    """The .rrd bytes for runs {system: shadow.measure(system)}: the caller writes them atomically."""
    lowest = min(float(np.log10(run["roundoff"])) for run in runs.values())

    def fill(stream):
        views = [log_system(stream, name, run, lowest) for name, run in runs.items()]
        import rerun.blueprint as rrb

        return course.opening(rrb.Horizontal(*views), STEPS)

    return course.recorded(APPLICATION_ID, fill)


def log_system(stream, name: str, run: dict, lowest: float):
    """One system's plot: E's and E~'s worst change so far, log10, drawn down to the run's round-off bound,
    which a grey line marks. Every plot shares one y range, from `lowest` (the lowest bound) to TOP."""
    steps = np.arange(len(run["energy"]))
    last = int(steps[-1])
    bound = float(np.log10(run["roundoff"]))
    # The grey floor first (its entity sorts first), wide, so a curve lying on it is drawn on top and still shows.
    course.log_series(stream, f"{name}/a_roundoff", [0, last], [bound, bound],
                      course.Look(course.GREY, "round-off: the most rounding could move E~ (less is drawn here)"),
                      width=5.0)
    course.log_series(stream, f"{name}/energy", steps, worst_so_far(run["energy"], run["roundoff"]),
                      LOOKS["energy"], width=2.0)
    course.log_series(stream, f"{name}/energy_shadow", steps, worst_so_far(run["shadow"], run["roundoff"]),
                      LOOKS["shadow"], width=2.0)
    return course.time_series(name, f"{name}: log10 of the worst |X - X0| / |X0| so far", last,
                              legend="RightBottom", y_range=(lowest - LEGEND_ROOM, TOP))
