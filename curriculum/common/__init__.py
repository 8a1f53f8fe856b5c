"""What every chapter script shares: the banner, flag parsing, progress lines, safe output files."""

from curriculum.common.cli import OneLineParser, int_in, name_arg, positive_finite, progress_printer
from curriculum.common.device import banner, wall_clock
from curriculum.common.outputs import write_atomic

__all__ = ["OneLineParser", "banner", "int_in", "name_arg", "positive_finite", "progress_printer",
           "wall_clock", "write_atomic"]
