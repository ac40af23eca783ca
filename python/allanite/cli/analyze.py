"""``allanite analyze``: the Allan deviation of a record with confidence intervals."""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.cli.commands import SUMMARIES
from allanite.cli.fit import fit_impossible_reason, fit_possible
from allanite.cli.record_options import (
    add_grid_arguments,
    add_record_arguments,
    add_still_argument,
    avar_from_args,
    dump_json,
    read_from_args,
    record_command,
    stated_units,
    warn_implausible,
)
from allanite.fit.classic import ClassicReadout, classic_readout
from allanite.io.atomic import atomic_output
from allanite.io.record import Record
from allanite.slopes import MIN_EDF, SlopeRow, slope_table
from allanite.terms.flicker import PLATEAU
from allanite.units import coefficient_text, customary_value, sensor_kind
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
        help=SUMMARIES["analyze"],
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
    add_still_argument(parser)
    add_grid_arguments(parser)
    out = parser.add_argument_group("output")
    out.add_argument("--json", action="store_true", help="print machine-readable JSON")
    shown = out.add_mutually_exclusive_group()
    shown.add_argument(
        "--summary",
        action="store_true",
        help="print only the summary (slope regions, slope-method readouts), not the table",
    )
    shown.add_argument(
        "--table",
        action="store_true",
        help="print only the table of tau, deviation, interval and EDF (no summary)",
    )
    out.add_argument("-o", "--output", help="write the table to FILE.csv or FILE.json")
    out.add_argument("--plot", help="save a plot to FILE.png, .svg or .pdf (needs matplotlib)")
    parser.set_defaults(func=run)


def analysis_dict(record: Record, result: AllanResult, level: float) -> dict[str, Any]:
    """JSON-ready analysis of a record.

    The record summary (with its warnings), the result with intervals at ``level`` and, per
    channel, the slope regions and slope-method readouts (:func:`summary_dict`).
    """
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
    summary = [
        {"channel": name, **(summary_dict(result.channel(c)) or {})}
        for c, name in enumerate(record.channels)
    ]
    return {"record": record.summary(), "allan": allan, "summary": summary}


_READOUT_UNITS = {"N": "*sqrt(s)", "B": "", "K": "/sqrt(s)"}


def _readout_value(result: AllanResult, symbol: str, value: float) -> str:
    """A slope-method readout in customary units (deg/sqrt(h), m/s/sqrt(h), ...) when known.

    :func:`allanite.units.customary_value`, the one conversion ``fit`` and ``report`` use
    (a gyro's N in deg/sqrt(h), an accelerometer's in m/s/sqrt(h), B in deg/h or ug).
    """
    powers = {"N": 0.5, "B": 0.0, "K": -0.5}
    if result.units:
        try:
            base = coefficient_text(result.units, 1.0, powers[symbol])
            shown, unit = customary_value(symbol, value, base, result.units)
            return f"{shown:.4g} {unit}"
        except ValueError:
            pass
        return f"{value:.4g} ({result.units}){_READOUT_UNITS[symbol]}"
    return f"{value:.4g} (rate unit){_READOUT_UNITS[symbol]}"


def _sensor(result: AllanResult) -> str:
    """``gyro`` or ``accelerometer`` (the slope table's wording) from the record's unit."""
    try:
        return sensor_kind(result.units) if result.units else "gyro"
    except ValueError:
        return "gyro"


#: estimators whose curve the slope table and the slope-method readouts are defined on
_SUMMARY_KINDS = ("overlapping", "standard", "total")


def summary_parts(result: AllanResult) -> tuple[list[SlopeRow], ClassicReadout] | None:
    """Slope regions and slope-method readouts of one channel (None for other estimators).

    Only points with at least ``MIN_EDF`` equivalent degrees of freedom are read, as in the
    report's slope table, so the scatter of the last taus does not invent a segment.
    """
    if result.kind not in _SUMMARY_KINDS:
        return None
    dev = np.asarray(result.dev, dtype=np.float64)
    reliable = np.asarray(result.edf) >= MIN_EDF
    rows = slope_table(result.tau, dev, result.edf, sensor=_sensor(result))
    readout = classic_readout(result.tau[reliable], dev[reliable])
    return rows, _bias_from_regions(readout, rows, result.tau[reliable], dev[reliable])


def _bias_from_regions(
    readout: ClassicReadout, rows: list[SlopeRow], tau: NDArray[Any], dev: NDArray[Any]
) -> ClassicReadout:
    """The B readout read where the region table shows bias instability: one rule for both.

    B is read at the lowest deviation within the regions of slope 0 (divided by the flicker
    plateau 0.664; every noise adds to the deviation, so it is an upper bound wherever it is
    read), and only there: a region table showing "bias instability" always comes with a B
    readout, and a B readout always with such a region.
    """
    flat = np.zeros(tau.size, dtype=bool)
    for row in rows:
        if row.symbol == "B":
            flat |= (tau >= row.tau_min) & (tau <= row.tau_max)
    values, where, slope = dict(readout.values), dict(readout.tau), dict(readout.slope)
    if not flat.any():
        values["B"] = where["B"] = slope["B"] = None
    else:
        i = int(np.flatnonzero(flat)[np.argmin(dev[flat])])
        row = next(r for r in rows if r.symbol == "B" and r.tau_min <= tau[i] <= r.tau_max)
        values["B"] = float(dev[i] / math.sqrt(PLATEAU))
        where["B"], slope["B"] = float(tau[i]), row.slope
    return dataclasses.replace(readout, values=values, tau=where, slope=slope)


def summary_dict(result: AllanResult) -> dict[str, Any] | None:
    """JSON-ready summary of one channel: slope regions and readouts (rate units, seconds)."""
    parts = summary_parts(result)
    if parts is None:
        return None
    rows, readout = parts
    return {
        "slopes": [
            {"tau_min": r.tau_min, "tau_max": r.tau_max, "slope": r.slope, "term": r.term}
            for r in rows
        ],
        "readouts": {
            "label": readout.label,
            **{k: readout.values.get(k) for k in ("N", "B", "K")},
            "tau": {k: readout.tau.get(k) for k in ("N", "B", "K")},
        },
    }


def summary_lines(result: AllanResult, fit_command: str | None = None) -> list[str]:
    """The first screen of one channel: slope regions and the classic readouts (N, B, K).

    The readouts are those of :func:`allanite.fit.classic.classic_readout` (IEEE slope
    method), labelled as readouts with no uncertainty; ``fit_command`` points to the fit.
    """
    lines = []
    parts = summary_parts(result)
    if parts is None:
        lines.append(
            f"  (slope regions and readouts are read off the Allan deviation; this is the "
            f"{_DEV_NAMES.get(result.kind, result.kind)})"
        )
    else:
        rows, readout = parts
        if rows:
            lines.append("  slope regions of the curve:")
            lines.extend(
                f"    {f'{r.tau_min:.3g} – {r.tau_max:.3g} s':<18} slope {r.slope:+.2f} "
                f"({r.label:>4}): {r.term}"
                for r in rows
            )
        else:
            lines.append("  slope regions: too few reliable points to classify")
        lines.append(
            "  slope-method readouts (IEEE 952 graphical reading, no uncertainty; not a fit):"
        )
        for symbol in ("N", "B", "K"):
            value = readout.values.get(symbol)
            at = readout.tau.get(symbol)
            if value is None or at is None:
                what = {
                    "N": "no -1/2 segment on the curve",
                    "B": "no region of slope 0 in the table above",
                    "K": "no +1/2 segment on the curve",
                }
                lines.append(f"    {symbol}: —  ({what[symbol]})")
                continue
            how = {
                "N": f"-1/2 segment near tau = {at:.3g} s, read at tau = 1 s",
                "B": (
                    f"upper bound: lowest point of the slope-0 region, tau = {at:.3g} s, "
                    "divided by 0.664; "
                    "white and random-walk noise there add to it"
                ),
                "K": f"+1/2 segment near tau = {at:.3g} s, read at tau = 3 s",
            }
            relation = "<=" if symbol == "B" else "="
            text = _readout_value(result, symbol, value)
            lines.append(f"    {symbol} {relation} {text}  ({how[symbol]})")
    if fit_command and fit_possible(result):
        lines.append(f"  fitted coefficients with intervals: {fit_command}")
    elif fit_command:
        lines.append(f"  fitted coefficients: {fit_impossible_reason(result)}")
    return lines


def format_table(
    record: Record,
    result: AllanResult,
    level: float,
    *,
    summary: bool = False,
    table: bool = True,
    fit_command: str | None = None,
) -> str:
    """Human-readable output: the record, then per channel the summary and/or the table.

    Parameters
    ----------
    record, result, level
        The record, its analysis and the confidence level of the intervals.
    summary : bool
        Print each channel's slope regions and slope-method readouts (:func:`summary_lines`).
    table : bool
        Print each channel's table of tau, deviation, interval and EDF.
    fit_command : str, optional
        The ``allanite fit`` command the summary points to.
    """
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
    if record.temperature is not None:
        lines.append(
            f"  temperature {record.temperature.min():.4g} to {record.temperature.max():.4g} °C "
            "(the noise is analysed as recorded; allanite fit --temperature fits the bias "
            "against it)"
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
        if summary:
            lines.extend(summary_lines(result.channel(c), fit_command))
        if not table:
            continue
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
            result.to_csv(tmp, level=level)
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
    stated = stated_units(record)
    if stated is not None:
        groups = {
            u: [c for c, v in zip(record.channels, stated, strict=True) if v == u] for u in stated
        }
        picks = "; ".join(f"--channels {','.join(cs)} ({u})" for u, cs in groups.items())
        print(
            f"allanite analyze: note: {record.source} holds channels in {' and '.join(groups)} "
            f"(shown in record units); analyse one sensor with {picks}, or use allanite fit or "
            "report, which take each sensor in its unit",
            file=sys.stderr,
        )
    result = avar_from_args(record, args)
    if not np.all(np.isfinite(result.var)):
        raise ValueError(f"{record.source}: the variance is not finite; check the samples")
    checked = warn_implausible(record, args, result)
    if args.plot:
        save_plot(args.plot, record, result, args.level)
    if args.output:
        write_output(args.output, checked, result, args.level)
    if args.json:
        print(dump_json(analysis_dict(checked, result, args.level)))
    else:
        fit_command = record_command("fit", args.file, args)
        print(
            format_table(
                record,
                result,
                args.level,
                summary=not args.table,
                table=not args.summary,
                fit_command=fit_command,
            )
        )
    sys.stdout.flush()
    return 0
