"""The integrators' palette under simulated colour deficiencies, in CAM02-UCS (colorspacious: about 1 is a
just-noticeable difference), at full severity (Machado et al. 2009): deuteranopia and protanopia (red-green, about
1 in 12 men between them), tritanopia (blue-yellow); against the viewer's own background too.
"""

import itertools

import numpy as np
import pytest

from curriculum.common import recording as course

colorspacious = pytest.importorskip("colorspacious", reason="the test extra installs it: pip install -e '.[test]'")

VISION = {"normal vision": None, "deuteranopia": "deuteranomaly", "protanopia": "protanomaly",
          "tritanopia": "tritanomaly"}
APART = 20.0  # CAM02-UCS units: far beyond noticeable, two lines read as two colours at a glance


def seen(rgb, deficiency):
    """Where an sRGB colour lands in CAM02-UCS for a viewer with this deficiency (None: normal vision)."""
    colour = np.array(rgb, dtype=float) / 255.0
    if deficiency:
        simulated = colorspacious.cspace_convert(colour, {"name": "sRGB1+CVD", "cvd_type": deficiency,
                                                          "severity": 100}, "sRGB1")
        colour = np.clip(simulated, 0.0, 1.0)
    return colorspacious.cspace_convert(colour, "sRGB1", "CAM02-UCS")


def distance(a, b, deficiency):  # in CAM02-UCS, as this viewer sees them
    return float(np.linalg.norm(seen(a, deficiency) - seen(b, deficiency)))


@pytest.mark.parametrize("vision", VISION)
def test_every_two_integrators_stay_apart_and_stand_out_from_the_viewers_background(vision):
    colours, deficiency = course.COLOURS, VISION[vision]
    gap, a, b = min((distance(colours[a], colours[b], deficiency), a, b) for a, b in itertools.combinations(colours, 2))
    assert gap > APART, f"under {vision} {a} and {b} are only {gap:.1f} apart: pick colours further apart"
    for name, colour in colours.items():
        gap = distance(colour, course.BACKGROUND, deficiency)
        assert gap > APART, f"under {vision} {name} is only {gap:.1f} from the background"


def test_the_chapters_key_pair_is_not_red_against_green_as_the_issue_measured():
    """The old red and green, 6.8 apart under deuteranopia (issue 18): the measure itself is trusted. Explicit
    against semi-implicit Euler, the pair the chapter needs told apart: hues on the same side of the red-green
    axis cannot collapse into one another when that axis is lost."""
    old_red, old_green = (217, 76, 64), (76, 175, 80)
    assert distance(old_red, old_green, "deuteranomaly") == pytest.approx(6.8, abs=0.05)
    assert distance(old_red, old_green, None) > APART, "apart to normal vision: only the simulation catches it"

    def hue(rgb):
        _, a, b = seen(rgb, None)
        return np.degrees(np.arctan2(b, a)) % 360

    greenish = [name for name in ("euler", "semi_implicit") if 100 < hue(course.COLOURS[name]) < 180]
    assert not greenish, f"{greenish} is green"
    for deficiency in ("deuteranomaly", "protanomaly"):
        gap = distance(course.COLOURS["euler"], course.COLOURS["semi_implicit"], deficiency)
        assert gap > 2 * APART, f"explicit and semi-implicit Euler only {gap:.1f} apart under {deficiency}"


def test_a_name_without_a_colour_takes_the_next_spare_one_and_its_own_label():
    looks = course.looks(["euler", "verlet", "semi_implicit", "leapfrog", "rk4"])
    assert looks["euler"] == (course.COLOURS["euler"], course.LABELS["euler"])
    assert looks["verlet"] == (course.SPARE_COLOURS[0], "verlet")
    assert looks["leapfrog"] == (course.SPARE_COLOURS[1], "leapfrog")
    assert list(looks) == ["euler", "verlet", "semi_implicit", "leapfrog", "rk4"]
    many = course.looks([f"new{i}" for i in range(2 * len(course.SPARE_COLOURS))])
    assert len({look.colour for look in many.values()}) == len(course.SPARE_COLOURS), "round again, no KeyError"
    assert not set(course.SPARE_COLOURS) & set(course.COLOURS.values())
