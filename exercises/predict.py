"""Predict-then-run: no figure is shown until the student has committed to an answer."""

import argparse
import sys
import textwrap


def ask(parser: argparse.ArgumentParser, question: str, choices: str, argv=None) -> argparse.Namespace:
    """Parse argv; without --predict, print the question and the choices and exit 2, showing no figure."""
    parser.add_argument("--predict", help="your prediction, committed before anything is measured")
    args = parser.parse_args(argv)
    if args.predict is None:
        print(question)
        print(choices)
        print(f"\nCommit first, then run again with your answer, e.g.:  python -m {parser.prog} --predict ...")
        sys.exit(2)
    return args


def explain(*lines: str, width: int = 100) -> None:
    """Print each line wrapped for a terminal; a line starting with '- ' is a bullet."""
    for line in lines:
        indent = "  " if line.startswith("- ") else ""
        print(textwrap.fill(line, width=width, subsequent_indent=indent))
