"""Hostile: prints without a newline, forever, while it is imported (once drove the checker to 8.4 GB)."""

import sys

while True:
    sys.stdout.write("x" * 4096)
