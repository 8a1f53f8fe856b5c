"""Pieces every chapter script uses: the start-of-run banner."""

from curriculum.common.device import banner

__all__ = ["banner"]
