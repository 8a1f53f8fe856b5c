"""Writing a run's files so that a reader never sees half of one."""

import os
from pathlib import Path


def write_atomic(path: Path, data: bytes | str) -> None:
    """Write `data` to a temporary file beside `path`, then rename it into place.

    A rename within one folder is atomic: whoever opens `path` sees the old file or the new
    one, never a mix, and an interrupted write leaves the old file as it was.
    """
    partial = path.with_name(path.name + ".partial")
    try:
        partial.write_bytes(data.encode() if isinstance(data, str) else data)
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
