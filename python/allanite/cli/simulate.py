"""``allanite simulate``: noise samples from a model JSON, streamed to a file.

Example: ``allanite simulate model.json --fs 2000 --duration 24h -o out.npy --output angle``.
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    """Add the ``simulate`` subcommand."""
    parser = subparsers.add_parser(
        "simulate",
        help="simulate sensor noise from a model JSON",
        description="Simulate rate, angle-increment or angle samples from a noise model (JSON, "
        "as written by 'allanite fit'), streamed in bounded memory to .npy, .csv or raw float64 "
        "(.bin/.raw/.f64). The same seed gives the same samples.",
    )
    parser.add_argument("model", help="noise model JSON file")
    parser.add_argument("--fs", type=float, required=True, help="sampling frequency in Hz")
    length = parser.add_mutually_exclusive_group(required=True)
    length.add_argument("--duration", help="record length with unit s, min, h or d (e.g. 24h)")
    length.add_argument("-n", "--samples", type=int, help="record length in samples")
    parser.add_argument("-o", "--out", required=True, help="output file (.npy, .csv, .bin)")
    parser.add_argument(
        "--output",
        choices=("rate", "angle", "increment"),
        default="rate",
        help="rate (model units, default), angle increments or accumulated angle",
    )
    parser.add_argument("--seed", type=int, default=None, help="random seed (non-negative)")
    parser.add_argument("--channels", type=int, default=1, help="independent channels (axes)")
    parser.add_argument(
        "--allow-aliasing",
        action="store_true",
        help="allow tones above the Nyquist frequency (simulated as aliased samples)",
    )
    parser.add_argument(
        "--flicker-method",
        choices=("auto", "spectral", "kasdin", "bank"),
        default="auto",
        help="how flicker is simulated: auto (exact spectral synthesis up to 2^21 samples, "
        "else a streaming Gauss-Markov bank), spectral, kasdin (Kasdin's fractional filter) "
        "or bank",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Load the model, simulate and write the record; returns the exit code."""
    from allanite.cli.progress import progress_bars
    from allanite.model import NoiseModel
    from allanite.simulation import record_length
    from allanite.simulation.writers import format_of, write_record

    format_of(args.out)  # fail on a bad suffix before any work
    model = NoiseModel.load(args.model)
    n = record_length(args.fs, args.samples, args.duration)
    unit = model.units["rate"]
    what = unit if args.output == "rate" else f"{unit}*s"
    big = n * args.channels >= 10_000_000
    with progress_bars(None if big and not args.quiet else False) as update:
        write_record(
            args.out,
            model,
            args.fs,
            n,
            output=args.output,
            channels=args.channels,
            seed=args.seed,
            allow_aliasing=args.allow_aliasing,
            flicker_method=args.flicker_method,
            units=what,
            progress=update,
        )
    return 0
