"""What every chapter script shares. Importing the package loads nothing heavy (a script's first line imports the
guard); `write_atomic` loads outputs on first use."""


def __getattr__(name):
    if name == "write_atomic":
        from curriculum.common.outputs import write_atomic

        return write_atomic
    raise AttributeError(f"module 'curriculum.common' has no attribute {name!r}")
