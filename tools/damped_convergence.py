"""The damped spring's convergence figures docs/damping.md quotes, from the tests' own runs.

    python tools/damped_convergence.py
"""

import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # engine, and the helpers tests/test_damping.py uses
import engine  # noqa: E402
import engine_damping  # noqa: E402
from test_damping import damped, run_all  # noqa: E402

if __name__ == "__main__":
    # the figures docs/damping.md quotes
    system, seconds = damped(), 5.0
    ladders = {}
    for dt in (0.02, 0.01, 0.005, 0.0025):
        steps = round(seconds / dt)
        for name, (p, v, e) in run_all(system, dt, steps).items():
            audits = [engine_damping.against_exact(system, p[:n + 1], v[:n + 1], e[:n + 1], engine.kept_steps(n), dt)
                      for n in (round(t / dt) for t in (1.0, 2.0, 3.0, 4.0, 5.0))]
            ladders.setdefault(name, []).append((max(abs(a["work_mismatch"]) for a in audits),
                                                 max(a["err_max"] for a in audits)))
    print(f"damped_spring b {engine_damping.DAMPING}, 5 s, dt 0.02 halved 3 times; the worst energy audit at"
          " t = 1..5 s, and the worst |q - q_exact| over the whole run:")
    for column, what in ((0, "|E lost - damper work| / E0"), (1, "|q - q_exact|")):
        print(f"  {what}:")
        for name, ladder in ladders.items():
            values = [rung[column] for rung in ladder]
            orders = [math.log2(a / b) for a, b in zip(values[:-1], values[1:], strict=True)]
            print(f"    {name:<14}" + "  ".join(f"{x:.3e}" for x in values)
                  + "   orders " + ", ".join(f"{o:.3f}" for o in orders))
