"""The measured convergence orders docs/DEVELOPING.md quotes ("Closed-form truth"), from the tests' own ladder.

    python tools/closed_form_orders.py
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # engine, and the ladder tests/test_closed_form.py measures
import engine  # noqa: E402
from test_closed_form import ladder, measured_orders  # noqa: E402

if __name__ == "__main__":
    # the orders docs/DEVELOPING.md quotes
    for system_name in ("spring", "orbit"):
        for integrator in engine.CHAPTER_INTEGRATORS:
            orders = ", ".join(f"{order:.3f}" for order in measured_orders(system_name, integrator))
            print(f"{system_name:<7}{integrator:<15}dt {ladder(integrator)[0]:g} halved 5 times: orders {orders}")
