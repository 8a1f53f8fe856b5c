"""E and E~ from MuJoCo 3.10.0's own mjINT_EULER state: the figures exercises/solutions/ANSWERS.md quotes.

    python tools/mujoco_shadow.py     # needs the 'mujoco' extra
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # the exercise, and the MuJoCo runs tests/test_ex7.py checks
from exercises.support import shadow  # noqa: E402
from test_ex7 import mujoco_bands  # noqa: E402

if __name__ == "__main__":
    for k, m in [(4.0, 1.0), (3.0, 2.5)]:
        energy_band, shadow_band, roundoff = mujoco_bands(k, m)
        print(f"MuJoCo mjINT_EULER, slide joint k {k:g}, m {m:g}, dt {shadow.DT}, {shadow.STEPS:,} steps:"
              f" E band {energy_band:.2e}, E~ band {shadow_band:.0e} (round-off bound {roundoff:.0e})")
    _, shadow_band, roundoff = mujoco_bands(4.0, 1.0, damping=0.5)
    print(f"the same with damping 0.5: E~ band {shadow_band:.2e} (round-off bound {roundoff:.0e})")
