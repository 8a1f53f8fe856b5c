"""Whether Rerun, the course's viewer and recording format, can be loaded on this machine: asked before a
run that records spends any time, so that a broken install is one line and not a traceback at the end."""


def rerun_problem() -> str | None:
    """Why the recording cannot be made (rerun-sdk missing or broken), or None. Imports it: needed anyway."""
    try:
        import rerun  # noqa: F401
    except ImportError as error:
        if error.name == "rerun":
            return "the recording needs rerun-sdk: run `pip install -e .` first, or pass --no-rerun"
        why = f"{type(error).__name__}: {error}".splitlines()[0]
    except Exception as error:  # a broken install fails in many ways
        why = f"{type(error).__name__}: {error}".splitlines()[0]
    else:
        return None
    if "failed to map segment" in why or "Cannot allocate memory" in why:  # a memory limit (ulimit -v)
        return f"not enough memory to load rerun-sdk ({why}); raise the memory limit or pass --no-rerun"
    return f"rerun-sdk is installed but does not import ({why}); reinstall it (`pip install -e .`) or pass --no-rerun"
