"""``allanite analyze``: the Allan deviation of a record with confidence intervals."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from allanite.cli.record_options import (
    add_grid_arguments,
    add_record_arguments,
    avar_from_args,
    dump_json,
    read_from_args,
)
from allanite.io.atomic import atomic_output
from allanite.io.record import Record
from allanite.variance import AllanResult

__all__ = ["register", "run"]

EXAMPLES = """examples:
  allanite analyze --example
  allanite analyze run1.csv --fs 100 --input angle --units deg --points 50
  allanite analyze log.csv --time-column t --channels gx,gy,gz --units deg/s --gaps split
  allanite analyze run1.npz --key gyro_counts --fs 100 --scale 0.05 --units deg/s --json
  allanite analyze imu.bin --dtype int16 --n-channels 3 --byte-order big --fs 2000 \\
      --scale 0.01 --units deg/s --plot adev.png -o adev.csv
"""

_DEV_NAMES = {
    "overlapping": "overlapping Allan deviation",
    "standard": "Allan deviation",
    "modified": "modified Allan deviation",
    "hadamard": "overlapping Hadamard deviation",
    "standard_hadamard": "Hadamard deviation",
    "total": "total deviation",
    "time": "time deviation",
}


def register(subparsers: Any) -> None:
    """Add the ``analyze`` subcommand."""
    parser = subparsers.add_parser(
        "analyze",
        help="Allan deviation of a record with confidence intervals",
        description="Compute the Allan deviation (or another Allan-family deviation) of a "
        "record with chi-square confidence intervals, print it as a table or JSON, and "
        "optionally write it to CSV/JSON and plot it.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", nargs="?", help="record file (text, .npy, .npz, raw, HDF5, ...)")
    parser.add_argument(
        "--example",
        action="store_true",
        help="analyse the built-in example record (simulated 30-minute angle record at 100 Hz)",
    )
    add_record_arguments(parser)
    add_grid_arguments(parser)
    out = parser.add_argument_group("output")
    out.add_argument("--json", action="store_true", help="print machine-readable JSON")
    out.add_argument("-o", "--output", help="write the table to FILE.csv or FILE.json")
    out.add_argument("--plot", help="save a plot to FILE.png, .svg or .pdf (needs matplotlib)")
    parser.set_defaults(func=run)


def analysis_dict(record: Record, result: AllanResult, level: float) -> dict[str, Any]:
    """JSON-ready analysis: the record summary and the result with intervals at ``level``."""
    lo, hi = result.ci(level)
    allan = result.to_dict()
    allan.update(
        {
            "channels": list(record.channels),
            "level": level,
            "dev_low": lo.tolist(),
            "dev_high": hi.tolist(),
        }
    )
    return {"record": record.summary(), "allan": allan}


def format_table(record: Record, result: AllanResult, level: float) -> str:
    """Human-readable table: one block per channel of tau, deviation, interval and EDF."""
    unit = f" [{result.units}]" if result.units else ""
    dur = record.duration
    lines = [
        f"record: {record.source}",
        f"  {record.n_channels} channel(s), {record.n_samples} samples at {record.fs:g} Hz"
        + (f" ({dur / 60:.4g} min)" if dur is not None else "")
        + f", input {record.input}"
        + (f", units {record.units}" if record.units else ""),
    ]
    if len(record.segments) > 1:
        longest = max(record.segments, key=lambda s: s.n_samples)
        lines.append(
            f"  {len(record.segments)} segments; analysed the longest "
            f"({longest.n_samples} samples from t = {longest.t0:g} s)"
        )
    lines.extend(f"  warning: {w}" for w in record.warnings)
    lo, hi = result.ci(level)
    name = _DEV_NAMES.get(result.kind, result.kind)
    lines.append(f"{name}{unit}, {100 * level:.3g} % confidence intervals")
    dev = result.dev.reshape(result.tau.size, -1)
    lo2 = lo.reshape(dev.shape)
    hi2 = hi.reshape(dev.shape)
    edf = result.edf.reshape(dev.shape)
    for c in range(dev.shape[1]):
        lines.append(f"channel {record.channels[c]}:")
        lines.append(f"{'tau [s]':>12} {'deviation':>12} {'low':>12} {'high':>12} {'edf':>9}")
        for k in range(result.tau.size):
            lines.append(
                f"{result.tau[k]:12.6g} {dev[k, c]:12.6g} {lo2[k, c]:12.6g} {hi2[k, c]:12.6g} "
                f"{edf[k, c]:9.4g}"
            )
    return "\n".join(lines)


def write_output(path: str, record: Record, result: AllanResult, level: float) -> None:
    """Write the table as CSV or the analysis as JSON, atomically."""
    suffix = Path(path).suffix.lower()
    if suffix not in (".csv", ".json"):
        raise ValueError(f"output {path}: use a .csv or .json file name")
    with atomic_output(path) as tmp:
        if suffix == ".csv":
            result.to_csv(tmp)
        else:
            tmp.write_text(dump_json(analysis_dict(record, result, level)), encoding="utf-8")


def save_plot(path: str, record: Record, result: AllanResult, level: float) -> None:
    """Save the Allan deviation plot (format from the suffix), atomically."""
    from allanite.plot import allan_figure, save_figure

    fig = allan_figure(result, labels=list(record.channels), level=level, title=record.source)
    save_figure(fig, path)


def run(args: argparse.Namespace) -> int:
    """Run ``allanite analyze``."""
    record = read_from_args(args.file, args)
    result = avar_from_args(record, args)
    if not np.all(np.isfinite(result.var)):
        raise ValueError(f"{record.source}: the variance is not finite; check the samples")
    if args.plot:
        save_plot(args.plot, record, result, args.level)
    if args.output:
        write_output(args.output, record, result, args.level)
    if args.json:
        print(dump_json(analysis_dict(record, result, args.level)))
    else:
        print(format_table(record, result, args.level))
    sys.stdout.flush()
    return 0
