"""What a chapter's run reports: metrics.json, whose bytes the course's CI diffs (the same run gives the same
bytes), and the cells of the table it prints.

    from curriculum.common.report import rounded, metrics_text, cell, sim_time
"""

import json
import math


def rounded(value):
    """Every float in `value` (through dicts and lists) to 12 decimals, the chapter's format: RK4's drift
    at the chapter's dt, ~5e-11, keeps two digits. From dt 0.004 down it is below 1e-12 and rounds to 0.0
    in the file; the printed table keeps five significant digits of every drift."""
    if isinstance(value, dict):
        return {key: rounded(item) for key, item in value.items()}
    if isinstance(value, list):
        return [rounded(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None  # strict JSON has no NaN or inf: a figure that overflowed is null, as a diverged one is
    if isinstance(value, float):  # float(): numpy's round of a float64 overflows from 1.8e296 (x 1e12)
        return round(float(value), 12) + 0.0  # + 0.0: a tiny negative drift rounds to -0.0, and the file says 0.0
    return value


def metrics_text(metrics: dict) -> str:
    """Strict JSON (no NaN or Infinity), keys sorted, so the same run gives the same bytes."""
    return json.dumps(metrics, indent=2, sort_keys=True, allow_nan=False) + "\n"


def cell(value: float, width: int, signed: bool = False) -> str:
    """A table cell: 4 decimals where they fit, scientific notation where they would not."""
    sign = "+" if signed else ""
    text = f"{value:{sign}.4f}"
    return f"{text:>{width}}" if len(text) < width - 1 else f"{value:>{sign}{width}.4e}"


def sim_time(seconds: float) -> str:
    """Simulated seconds as the reports print them: 20.00, or 1e-08 and 1e+12 where two decimals do not fit."""
    return f"{seconds:.2f}" if 0.01 <= seconds < 1e9 else f"{seconds:.3g}"
