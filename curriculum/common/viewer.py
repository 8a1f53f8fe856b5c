"""Whether Rerun, the course's viewer and recording format, loads: asked before a run that records spends any
time, so that a broken install is one line and not a traceback at the end."""

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
        if isinstance(error, MemoryError) or "map segment" in why or "allocate memory" in why:  # ulimit -v
            return f"not enough memory to load rerun-sdk ({why}); raise the memory limit or pass --no-rerun"
        return f"rerun-sdk is installed but does not import ({why}); reinstall it (`pip install -e .`) or pass" \
               " --no-rerun"
    return None


def recording_refused(prog: str, args) -> str | None:
    """An exercise's check of --no-rerun and --rrd before any work: under RERUN=off it records nothing (said in one
    line; args.rerun turns False); a path the recording cannot go to, or a rerun-sdk that does not load, is the
    one line it is refused with."""
    args.rerun = recording_wanted(prog, args.rerun)
    problem = args.rerun and recording_problem(args.rrd)
    if problem:
        return f"--rrd: {problem} (or pass --no-rerun)"
    return (args.rerun and rerun_problem()) or None
