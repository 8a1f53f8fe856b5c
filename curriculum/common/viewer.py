"""Whether Rerun loads, asked before a run that records: a broken install is one line, not a late traceback."""

from curriculum.common.cli import recording_wanted
from curriculum.common.outputs import recording_problem


def rerun_problem() -> str | None:
    """Why the recording cannot be made (rerun-sdk missing or broken), or None. Imports it: needed anyway."""
    try:
        import rerun  # noqa: F401
    except Exception as error:  # noqa: BLE001 (a broken install fails in many ways)
        if isinstance(error, ImportError) and error.name == "rerun":
            return "the recording needs rerun-sdk: run `pip install -e .` first, or pass --no-rerun"
        why = f"{type(error).__name__}: {error}".splitlines()[0]
        return f"rerun-sdk is installed but does not import ({why}); reinstall it (`pip install -e .`) or pass" \
               " --no-rerun"
    return None


def recording_refused(prog: str, args) -> str | None:
    """An exercise's check of --no-rerun and --rrd before any work (RERUN=off turns args.rerun False): the one line
    a bad path or a rerun-sdk that does not load is refused with, or None."""
    args.rerun = recording_wanted(prog, args.rerun)
    problem = args.rerun and recording_problem(args.rrd)
    if problem:
        return f"--rrd: {problem} (or pass --no-rerun)"
    return (args.rerun and rerun_problem()) or None
