"""Exercise 7's recording: E's and E~'s errors for each system, side by side on the `step` timeline.

One plot per system (spring, orbit, freefall, left to right), each with two lines: semi-implicit Euler's
energy E and its shadow energy E~. Each line is the worst relative change so far, |X - X0| / |X0|, as a
power of ten; a running maximum never comes down, so round-off reads as a flat line instead of noise.
Anything below 1e-16 is drawn at -16, where a grey line says "round-off"; a darker one marks the most
that rounding alone could have moved E~ in that run (the exercise's round-off bound). All of Rerun for exercise 7
is here, loaded only when the exercise records; it opens the course's way (curriculum/common/recording.py).
"""


import numpy as np

from curriculum.common import recording as course
from exercises.support.shadow import FLOOR, STEPS, worst_so_far

APPLICATION_ID = "zero2robot-ch3_3-ex7"
# E is semi-implicit Euler's energy, in that integrator's colour; E~ takes the palette's next free colour.
LOOKS = {"energy": course.Look(course.COLOURS["semi_implicit"], "E: energy (semi-implicit Euler)"),
         "shadow": course.Look(course.SPARE_COLOURS[0], "E~: shadow energy")}
TOP = 0.5  # a little above log10 = 0, an error as large as the quantity itself: every curve fits under it
LEGEND_ROOM = 3.5  # decades below the floor kept empty for the legend, so it covers no curve
BOUND_GREY = (90, 90, 90)  # darker than course.GREY: the bound is a loose ceiling, the floor the real bottom


def record(runs: dict) -> bytes:
    """The .rrd bytes for runs {system: shadow.measure(system)}: the caller writes them atomically."""

    def fill(stream):
        views = [log_system(stream, name, run) for name, run in runs.items()]
        import rerun.blueprint as rrb

        return course.opening(rrb.Horizontal(*views), STEPS)

    return course.recorded(APPLICATION_ID, fill)


def log_system(stream, name: str, run: dict):
    """One system's plot: E's and E~'s worst change so far, log10, over the round-off floor, and the most
    that rounding alone could have moved E~ in this run (the exercise's round-off bound)."""
    steps = np.arange(len(run["energy"]))
    last = int(steps[-1])
    course.log_series(stream, f"{name}/energy", steps, worst_so_far(run["energy"]), LOOKS["energy"])
    course.log_series(stream, f"{name}/energy_shadow", steps, worst_so_far(run["shadow"]), LOOKS["shadow"])
    # Two grey levels across the whole run (entities named to sort after the curves, as the legend does):
    # E~ under the upper one has moved no more than rounding can move it; a line on the lower one, not at all.
    bound = np.log10(run["roundoff"])
    course.log_series(stream, f"{name}/roundoff_bound", [0, last], [bound, bound],
                      course.Look(BOUND_GREY, "the most rounding could move E~"), width=1.0)
    floor = np.log10(FLOOR)
    course.log_series(stream, f"{name}/roundoff_floor", [0, last], [floor, floor],
                      course.Look(course.GREY, f"round-off (1e{floor:.0f} and below)"))
    # y from 0 (an error as large as the quantity) down past the floor, leaving the legend room underneath
    return course.time_series(name, f"{name}: log10 of the worst |X - X0| / |X0| so far", last,
                              legend="RightBottom", y_range=(floor - LEGEND_ROOM, TOP))
