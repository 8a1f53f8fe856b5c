"""Whether an exercise's recording can be made, asked before a run that records: a bad --rrd or a broken install is
one line, not a late traceback."""

from curriculum.common.cli import recording_wanted, shown
from curriculum.common.outputs import folder_problem


def rerun_problem() -> str | None:
    """Why the recording cannot be made (rerun-sdk missing or broken), or None. Imports it: needed anyway."""
    try:
        import rerun  # noqa: F401
    except Exception as error:  # noqa: BLE001 (a broken install fails in many ways)
        why = f"{type(error).__name__}: {error}".splitlines()[0]  # ModuleNotFoundError: No module named 'rerun'
        return f"the recording needs rerun-sdk, which does not import ({why}): `pip install -e .`, or pass --no-rerun"
    return None


def recording_refused(prog: str, args) -> str | None:
    """An exercise's check of --no-rerun and --rrd before any work (RERUN=off turns args.rerun False): the one line
    a bad path or a rerun-sdk that does not load is refused with, or None."""
    args.rerun = recording_wanted(prog, args.rerun)
    if not args.rerun:
        return None
    if args.rrd.suffix != ".rrd":
        problem = f"{shown(args.rrd, 100)} does not end in .rrd"
    else:
        problem = folder_problem(args.rrd.parent, [args.rrd.name])
    return f"--rrd: {problem} (or pass --no-rerun)" if problem else rerun_problem()
