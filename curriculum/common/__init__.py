"""What every chapter script shares: flags (cli), safe output files (outputs), the signal guard a script installs
first (interrupts), predict-then-run (predict), the checker's runner (student_code), recordings (recording), and
the course flow of `python -m exercises` (course, journal, exercise). Importing the package loads nothing heavy, so
a script's first line can import the guard; `write_atomic` loads outputs on first use."""


def __getattr__(name):
    if name == "write_atomic":
        from curriculum.common.outputs import write_atomic

        return write_atomic
    raise AttributeError(f"module 'curriculum.common' has no attribute {name!r}")
