"""``allanite simulate``: noise samples from a model JSON, streamed to a file.

Example: ``allanite simulate model.json --fs 2000 --duration 24h -o out.npy --output angle``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from allanite.cli.commands import SUMMARIES

__all__ = ["register", "run"]

EXAMPLES = """examples:
  allanite fit --example -o model.json                       # a model to simulate from
  allanite simulate model.json --fs 100 --duration 2h --seed 1 -o sim.npy
  allanite simulate model.json --fs 400 -n 3.6e5 --output angle --n-channels 3 -o sim.csv
  allanite analyze sim.npy --fs 100 --units deg/s            # the simulated Allan deviation
"""


def register(subparsers: Any) -> None:
    """Add the ``simulate`` subcommand."""
    parser = subparsers.add_parser(
        "simulate",
        help=SUMMARIES["simulate"],
        description="Simulate rate, angle-increment or angle samples from a noise model (JSON, "
        "as written by 'allanite fit'), streamed in bounded memory to .npy, .csv or raw float64 "
        "(.bin/.raw/.f64). The same seed gives the same samples.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("model", help="noise model JSON file")
    parser.add_argument("--fs", type=float, required=True, help="sampling frequency in Hz")
    length = parser.add_mutually_exclusive_group(required=True)
    length.add_argument("--duration", help="record length with unit s, min, h or d (e.g. 24h)")
    length.add_argument(
        "-n", "--samples", type=_count, help="record length in samples (e.g. 360000 or 3.6e5)"
    )
    parser.add_argument("-o", "--out", required=True, help="output file (.npy, .csv, .bin)")
    parser.add_argument(
        "--output",
        choices=("rate", "angle", "increment"),
        default="rate",
        help="rate (model units, default), angle increments or accumulated angle (in the "
        "model's angle unit: deg for deg/s and deg/h, m/s for an accelerometer)",
    )
    parser.add_argument("--seed", type=int, default=None, help="random seed (non-negative)")
    parser.add_argument(
        "--n-channels",
        "--channels",
        dest="n_channels",
        type=int,
        default=1,
        help="number of independent channels (axes); --channels is its old name",
    )
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
        "else the streaming AR(1) bank + FIR generator, exact too), spectral, kasdin (Kasdin's "
        "fractional filter) "
        "or bank",
    )
    parser.add_argument(
        "--quiet", action="store_true", help="no progress bar and no line saying what was written"
    )
    parser.set_defaults(func=run)


def _count(text: str) -> int:
    """A whole number of samples, also written as 1e6 (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of samples: {text!r}") from None
    if not value.is_integer():
        raise argparse.ArgumentTypeError(f"not a whole number of samples: {text!r}")
    return int(value)


def _refuse_config(path: str) -> None:
    """A simulator/estimator config given as the model: name it and the conversion."""
    from allanite.errors import InputError
    from allanite.formats import CONFIG_TEXT, FORMATS, detect_format
    from allanite.model import read_text_file

    try:
        fmt = detect_format(Path(path), read_text_file(Path(path), CONFIG_TEXT))
    except (InputError, ValueError, OSError):
        return  # NoiseModel.load says what is wrong with it
    if fmt != "allanite":
        raise ValueError(
            f"{path} is a {FORMATS[fmt].TITLE} config, not a noise-model JSON; convert it "
            f"first: allanite model convert {path} model.json [--rate HZ] (its gyro model), "
            "then simulate model.json"
        )


def _duration(seconds: float) -> str:
    for unit, size in (("d", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.4g} {unit}"
    return f"{seconds:.4g} s"


def run(args: argparse.Namespace) -> int:
    """Load the model, simulate and write the record; returns the exit code."""
    from allanite.cli.progress import progress_bars
    from allanite.model import NoiseModel
    from allanite.simulation import record_length
    from allanite.simulation.writers import (
        check_free_space,
        format_of,
        format_size,
        output_size,
        write_record,
    )
    from allanite.units import integrated_unit

    format_of(args.out)  # fail on a bad suffix before any work
    _refuse_config(args.model)
    model = NoiseModel.load(args.model)
    n = record_length(args.samples, args.duration, fs=args.fs)
    if args.n_channels < 1:
        raise ValueError(f"--n-channels must be at least 1, got {args.n_channels}")
    check_free_space(args.out, output_size(args.out, n, args.n_channels))
    what = model.units["rate"]
    if args.output != "rate":  # angles in an angle unit (deg), not deg/s*s or deg/h*s
        per_second, what = integrated_unit(what)
        if per_second != model.units["rate"]:
            model = model.in_units(per_second)
    big = n * args.n_channels >= 10_000_000
    with progress_bars(None if big and not args.quiet else False) as update:
        write_record(
            args.out,
            model,
            n,
            fs=args.fs,
            output=args.output,
            n_channels=args.n_channels,
            seed=args.seed,
            allow_aliasing=args.allow_aliasing,
            flicker_method=args.flicker_method,
            units=what,
            progress=update,
        )
    if not args.quiet:
        size = Path(args.out).stat().st_size
        axes = f" x {args.n_channels} channels" if args.n_channels > 1 else ""
        print(
            f"wrote {args.out}: {n} samples{axes} of {args.output} [{what}] at {args.fs:g} Hz "
            f"({_duration(n / args.fs)}, seed {args.seed if args.seed is not None else 'random'}"
            f"), {format_size(size)}"
        )
    return 0
