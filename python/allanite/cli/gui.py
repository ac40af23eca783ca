"""``allanite gui``: the desktop GUI (needs the ``gui`` extra, PySide6)."""

from __future__ import annotations

import argparse
from typing import Any

from allanite.cli.commands import SUMMARIES

__all__ = ["register", "run"]

EXAMPLES = """examples:
  allanite gui
  allanite gui run1.txt --fs 100 --input angle --units deg --points 100
  allanite gui --example
"""


def register(subparsers: Any) -> None:
    """Add the ``gui`` subcommand."""
    parser = subparsers.add_parser(
        "gui",
        help=SUMMARIES["gui"],
        description="Open the desktop GUI. It does what the original program did (open a "
        "file, set the sampling frequency and the number of grid points, switch between the "
        "Allan deviation and its fit, show the coefficients) plus channel selection, display "
        "units, the diagnosis against a model file and the report export.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", nargs="?", help="record file to open at start")
    parser.add_argument("--example", action="store_true", help="open the example record")
    parser.add_argument("--fs", type=float, help="sampling frequency in Hz")
    parser.add_argument("--input", choices=("rate", "increment", "angle"), help="sample kind")
    parser.add_argument("--units", help="unit of the samples, e.g. deg/s or deg")
    parser.add_argument("--points", type=int, help="number of log-grid points (default 100)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``allanite gui``."""
    from allanite.gui import launch

    record = None
    if args.example and args.file is None:
        from allanite.cli.record_options import example_record

        record = example_record()
    return launch(
        args.file,
        record=record,
        fs=args.fs,
        input=args.input,
        units=args.units,
        points=args.points,
    )
