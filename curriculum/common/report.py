"""What a chapter's run reports: metrics.json (the same run gives the same bytes), its table's cells, where its
files went."""

import json
import math

from curriculum.common.outputs import content_id, write_run


def rounded(value):
    """Every float in `value` (through dicts and lists) to 12 decimals, the chapter's format (RK4's ~5e-11 drift keeps
    two digits; the printed table keeps five significant digits of every drift)."""
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


def write_outputs(out, metrics: dict, metrics_file: str, recording=None) -> str | None:
    """Write a run's metrics.json, and its recording if asked for (None, or (file name, record) where record(run_id)
    returns (the .rrd's bytes, a note or None)), together. "run_id" is the content_id of metrics.json written
    without it, and the recording's id too. Returns the recording's note."""
    metrics["run_id"] = content_id(metrics_text(metrics))
    files, note = {}, None
    if recording:
        recording_file, record = recording
        files[recording_file], note = record(run_id=metrics["run_id"])
    files[metrics_file] = metrics_text(metrics)
    write_run(out, files)  # all on disk before any replaces its old file; metrics.json last
    return note


def where_written(out, metrics_file: str, recording_file: str, recorded: bool, note: str | None) -> None:
    """The lines after a run's report: where its files are, and how to open the recording."""
    metrics_path, recording_path = out / metrics_file, out / recording_file
    print(f"metrics: {metrics_path}")
    if recorded:
        print(f"recording: {recording_path} (open it with: rerun {recording_path})")
        if note:
            print(note)
    elif recording_path.exists():
        print(f"note: {recording_path} is from an earlier run (this one wrote no recording)")
