"""Command-line options shared by the subcommands that read a record from a file.

``add_record_arguments(parser)`` adds the reader options (format, columns, time column, gap
policy, scale, units, raw layout) and ``read_from_args(path, args)`` turns them into a
:class:`allanite.io.Record`. ``add_grid_arguments`` adds the Allan-grid options and
``avar_from_args`` computes the variance of a record with them.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.cli.progress import progress_bars
from allanite.confidence import DEFAULT_LEVEL
from allanite.io.options import ReadOptions
from allanite.io.readers import FORMATS, read_record, stated_unit_conflict
from allanite.io.record import INPUT_KINDS, Record
from allanite.io.timebase import FS_SOURCES, GAP_POLICIES
from allanite.memory import available_memory
from allanite.plausibility import (
    Finding,
    check_allan,
    check_channel_units,
    check_coefficients,
    check_means,
    check_samples,
    constant_channels,
    is_triad,
    refuse_constant,
)
from allanite.stillness import STILL_MODES, still_record
from allanite.variance import KINDS, AllanResult, avar

__all__ = [
    "add_grid_arguments",
    "add_record_arguments",
    "add_still_argument",
    "avar_from_args",
    "example_record",
    "print_reader_notes",
    "rate_unit",
    "read_from_args",
    "read_sensors",
    "record_command",
    "unit_list",
    "warn_coefficients",
    "warn_implausible",
]


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options that say how to read a record file."""
    group = parser.add_argument_group("reading the record")
    group.add_argument("--fs", type=float, help="sampling frequency in Hz (or use --time-column)")
    group.add_argument(
        "--fs-source",
        choices=FS_SOURCES,
        default=None,
        help="which rate wins when --fs contradicts the time column by more than 10 %% "
        "(such a record is refused without it): 'time' (the time stamps) or 'fs'",
    )
    group.add_argument(
        "--input",
        choices=INPUT_KINDS,
        default=None,
        help="what the samples are: rate, angle increments per sample, or angle "
        "(default: rate; the example record is angle)",
    )
    group.add_argument(
        "--units",
        help="unit of the samples after --scale: a rate (deg/s, deg/h, dph, rad/s) or an "
        "acceleration (m/s^2, g, mg, ug, ft/s^2) for rate samples, an angle (deg) or a "
        "velocity (m/s) for angle/increment samples. fit and report take one unit per channel "
        "(gx,gy,gz,ax,ay,az: deg/s,deg/s,deg/s,m/s^2,m/s^2,m/s^2) or one per group of "
        "consecutive channels (deg/s,m/s^2: first half gyro, second half accelerometer). "
        "Without it coefficients are printed in record units",
    )
    group.add_argument(
        "--display-units",
        metavar="ANGLE",
        help="angle a gyro's coefficients are shown in: N in ANGLE/sqrt(h), B in ANGLE/h "
        "(deg, rad, arcsec, ...). Default: deg, as datasheets quote them, whatever the record's "
        "angle (rad/s, arcsec increments); the model JSON keeps the record's unit",
    )
    group.add_argument(
        "--scale", type=float, help="factor from counts to units: samples = counts * SCALE"
    )
    group.add_argument(
        "--channels",
        help="columns to analyse, by 0-based index (no negative indices) or header name, comma "
        "separated (e.g. 1,2 or gx,gy)",
    )
    group.add_argument(
        "--time-column", help="column of time stamps (index or name); fs is inferred from it"
    )
    group.add_argument(
        "--temperature",
        metavar="NAME",
        help="the sensor temperature (deg C): a column (index or name), an HDF5 dataset or "
        "netCDF variable, a ROS sensor_msgs/Temperature topic, or a ULog field "
        "(temperature of sensor_gyro/sensor_accel); resampled onto the sample times. "
        "fit then fits the bias against it (see allanite.thermal)",
    )
    group.add_argument(
        "--time-scale",
        type=float,
        default=1.0,
        help="seconds per time-stamp unit (0.001 for ms, 1e-6 for us; default 1)",
    )
    group.add_argument(
        "--gaps",
        choices=GAP_POLICIES,
        default="error",
        help="what to do about gaps in the time column: refuse (error), analyse the longest "
        "contiguous segment (split) or interpolate the missing samples (fill)",
    )
    group.add_argument("--format", choices=tuple(FORMATS), help="file format (default: suffix)")
    group.add_argument("--delimiter", help="text field separator (default: detected)")
    group.add_argument(
        "--header",
        choices=("auto", "yes", "no"),
        default="auto",
        help="whether a text file starts with column names (default: detected)",
    )
    group.add_argument("--key", help="array name in an .npz file or dataset path in HDF5")
    group.add_argument(
        "--topic",
        help="ROS bag IMU topic (sensor_msgs/Imu), or ULog topic: sensor_combined (default), "
        "sensor_gyro[:instance], sensor_accel",
    )
    group.add_argument(
        "--dtype",
        help="raw binary sample type, e.g. int16, <f4, float64 (this and the next three "
        "options mean raw binary whatever the file suffix)",
    )
    group.add_argument(
        "--n-channels", type=int, help="raw binary: interleaved channels (default 1)"
    )
    group.add_argument(
        "--byte-order",
        choices=("little", "big", "native"),
        help="raw binary byte order (default little)",
    )
    group.add_argument("--offset", type=int, help="raw binary: bytes to skip at the start")


def add_still_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--still``: what to do about motion in a record that should be still."""
    parser.add_argument(
        "--still",
        choices=STILL_MODES,
        default="warn",
        help="motion in the record (handling, a robot driving): warn naming the still "
        "segments' times (default), analyse the longest still segment (auto; the output says "
        "which), or do not look (off). See allanite.stillness",
    )


def add_grid_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of the Allan-variance computation."""
    group = parser.add_argument_group("Allan variance")
    group.add_argument(
        "--kind", choices=KINDS, default="overlapping", help="estimator (default overlapping)"
    )
    group.add_argument(
        "--taus",
        choices=("log", "octave", "decade", "all"),
        default="log",
        help="tau grid (default log: the original program's log-spaced grid)",
    )
    group.add_argument(
        "--points",
        type=int,
        default=100,
        help="number of points of the log grid before duplicates are removed (default 100)",
    )
    group.add_argument(
        "--level",
        type=float,
        default=DEFAULT_LEVEL,
        help="confidence level of the intervals (default 0.95; 0.683 for 1-sigma error bars)",
    )
    group.add_argument("--threads", type=int, help="worker threads (default: all cores)")
    group.add_argument(
        "--memory-limit",
        help="working-memory budget for big records, e.g. 1GB: a larger phase array goes to a "
        "temporary file (default: half of the available memory when the phase array would "
        "need more than that, else all in memory)",
    )
    group.add_argument(
        "--fast",
        action="store_true",
        help="fast mode for huge records: strided sums at long taus, deviation < 0.075 of the "
        "estimate's own 1-sigma error for white rate noise (see allanite.variance.fast)",
    )


def _columns(text: str | None) -> list[int | str] | None:
    if text is None:
        return None
    out: list[int | str] = []
    for part in text.split(","):
        part = part.strip()
        if part:
            out.append(int(part) if part.lstrip("-").isdigit() else part)
    return out or None


def _time_column(text: str | None) -> int | str | None:
    if text is None:
        return None
    return int(text) if text.lstrip("-").isdigit() else text


def example_record(args: argparse.Namespace | None = None) -> Record:
    """Return the built-in example: a simulated 30-minute angle record at 100 Hz."""
    try:
        from allanite.examples import example_as_record
    except ImportError as exc:
        raise ValueError(
            "the example record is not available in this installation; give a FILE"
        ) from exc
    return example_as_record()


def unit_list(text: str | None) -> list[str]:
    """The units of ``--units``: one, or several separated by commas (empty: none)."""
    if text is None:
        return []
    return [u.strip() for u in text.split(",") if u.strip()]


def read_from_args(path: str | None, args: argparse.Namespace) -> Record:
    """Read ``path`` (or the example record with ``--example``) with the reader options.

    Raises
    ------
    ValueError
        If ``--units`` names several units (only :func:`read_sensors` splits a record by
        unit) or a unit of the wrong kind for ``--input``.
    """
    units = unit_list(getattr(args, "units", None))
    if len(units) > 1:
        raise ValueError(
            f"--units {args.units}: this command analyses one sensor at a time; give one unit "
            "and pick the sensor's columns with --channels (allanite fit and report take one "
            "unit per channel)"
        )
    record = _read(path, args)
    rate_unit(record)  # the unit must suit the input kind
    return _against_file(record, units * record.n_channels) if units else record


def read_sensors(path: str | None, args: argparse.Namespace) -> list[Record]:
    """Read a record and split its channels by unit: one Record per sensor unit.

    ``--units`` gives one unit for every channel, one per channel, or one per group of
    consecutive channels (6 channels and 2 units: 3 and 3). A six-axis IMU file read with
    ``--channels gx,gy,gz,ax,ay,az --units deg/s,m/s^2`` gives a gyro record (gx, gy, gz in
    deg/s) and an accelerometer record (ax, ay, az in m/s^2).

    Raises
    ------
    ValueError
        If the number of units does not divide the number of channels, or a unit is of the
        wrong kind (the message names the channel and the unit).
    """
    units = unit_list(getattr(args, "units", None))
    if len(units) <= 1:
        record = read_from_args(path, args)
        print_reader_notes([record], args)
        stated = stated_units(record) if not units else None
        if stated is None:
            return [record]
        return _split_by_unit(record, stated, args)
    record = _read(path, args, units=None)
    n = record.n_channels
    if n % len(units):
        raise ValueError(
            f"--units gives {len(units)} units for {n} channels ({', '.join(record.channels)}); "
            "give one unit, one per channel or one per equal group of consecutive channels"
        )
    per_channel = [units[c // (n // len(units))] for c in range(n)]
    record = _against_file(record, per_channel)
    print_reader_notes([record], args)
    return _split_by_unit(record, per_channel, args)


def _against_file(record: Record, per_channel: list[str]) -> Record:
    """The record with a note on units given against the file's (see ``stated_unit_conflict``)."""
    note = stated_unit_conflict(record, per_channel)
    if note is None or note in record.warnings:  # the reader notes it for one unit
        return record
    return dataclasses.replace(record, warnings=(*record.warnings, note))


def print_reader_notes(records: Sequence[Record], args: argparse.Namespace) -> None:
    """Print what the reader noticed (``Record.warnings``) on stderr, each note once.

    For the commands whose output has no record summary (``fit``, ``diagnose``): time base
    gaps and jitter, units from or against the file, a channel named like time stamps,
    time stamps that are not seconds.
    """
    command = getattr(args, "command", None) or "allanite"
    for note in dict.fromkeys(w for record in records for w in record.warnings):
        print(f"allanite {command}: note: {note}", file=sys.stderr)


def stated_units(record: Record) -> list[str] | None:
    """Per-channel units the file format itself states when they differ, else None.

    A ROS ``sensor_msgs/Imu`` message or a PX4 ``sensor_combined`` topic defines its units
    (rad/s for the gyro axes, m/s^2 for the accelerometer's): a six-axis log is then two
    sensors without ``--units`` (not a guess: the message definition says so).
    """
    meta = record.meta if isinstance(record.meta, dict) else {}
    per = meta.get("channel_units")
    if record.units is not None or not isinstance(per, dict):
        return None
    found = [per.get(c) for c in record.channels]
    if any(u is None for u in found) or len(set(found)) < 2:
        return None
    return [str(u) for u in found]


def _split_by_unit(
    record: Record, per_channel: list[str], args: argparse.Namespace
) -> list[Record]:
    """One record per unit of ``per_channel`` (a unit per channel), in order of appearance."""
    groups: dict[str, list[int | str]] = {}
    for c, unit in enumerate(per_channel):
        groups.setdefault(unit, []).append(c)
    out = []
    for unit, columns in groups.items():
        part = dataclasses.replace(record.select(columns), units=unit)
        try:
            rate_unit(part)
        except ValueError as exc:
            names = ", ".join(part.channels)
            raise ValueError(f"channel(s) {names}: {exc}") from None
        findings = check_channel_units(part.channels, unit)
        command = getattr(args, "command", None) or "allanite"
        for finding in findings:
            print(f"allanite {command}: warning: {finding.message}", file=sys.stderr)
        if findings:
            messages = tuple(f.message for f in findings)
            part = dataclasses.replace(part, warnings=part.warnings + messages)
        out.append(part)
    return out


def _read(path: str | None, args: argparse.Namespace, **override: Any) -> Record:
    if path is None:
        if getattr(args, "example", False):
            record = example_record(args)
            chosen = _columns(args.channels)
            record = record.select(chosen) if chosen else record
            return dataclasses.replace(record, units=override["units"]) if override else record
        raise ValueError("give a FILE to analyse, or --example for the built-in example record")
    record = read_record(path, read_options(args), **override)
    record = _without_constant(record, args)
    record, _ = still_record(record, getattr(args, "still", "warn"))
    return record


def _without_constant(record: Record, args: argparse.Namespace) -> Record:
    """The record without its constant channels, named in a warning; all constant is refused.

    A simulator's bag often has noise on some axes only: the channels that vary are analysed.
    """
    dead = constant_channels(record.samples)
    if not dead or len(dead) == len(record.channels):
        refuse_constant(record.samples, record.channels, source=record.source)
        return record
    names = [record.channels[c] for c in dead]
    values = ", ".join(f"{record.channels[c]} = {record.samples[0, c]:.6g}" for c in dead)
    message = (
        f"{record.source}: channel(s) {', '.join(names)} constant ({values}): no noise to "
        "analyse, left out; analysing "
        + ", ".join(c for i, c in enumerate(record.channels) if i not in dead)
    )
    command = getattr(args, "command", None) or "allanite"
    print(f"allanite {command}: warning: {message}", file=sys.stderr)
    keep = [c for c in range(len(record.channels)) if c not in dead]
    kept = record.select(tuple(keep))
    return dataclasses.replace(kept, warnings=(*kept.warnings, message))


def read_options(args: argparse.Namespace) -> ReadOptions:
    """The :class:`~allanite.io.options.ReadOptions` of the reader flags in ``args``."""
    return ReadOptions(
        fs=args.fs,
        input=args.input or "rate",
        units=args.units,
        columns=_columns(args.channels),
        time_column=_time_column(args.time_column),
        time_scale=args.time_scale,
        gaps=args.gaps,
        scale=args.scale,
        fs_source=getattr(args, "fs_source", None),
        format=args.format,
        delimiter=args.delimiter,
        header={"auto": None, "yes": True, "no": False}[args.header],
        key=args.key,
        dtype=args.dtype,
        n_channels=args.n_channels,
        byteorder=args.byte_order,
        offset=args.offset,
        topic=getattr(args, "topic", None),
        temperature=_time_column(getattr(args, "temperature", None)),
    )


#: reader option -> (its flag, its default): what :func:`record_command` writes back
_READER_FLAGS: dict[str, tuple[str, Any]] = {
    "fs": ("--fs", None),
    "fs_source": ("--fs-source", None),
    "input": ("--input", None),
    "units": ("--units", None),
    "scale": ("--scale", None),
    "channels": ("--channels", None),
    "time_column": ("--time-column", None),
    "time_scale": ("--time-scale", 1.0),
    "gaps": ("--gaps", "error"),
    "format": ("--format", None),
    "delimiter": ("--delimiter", None),
    "header": ("--header", "auto"),
    "key": ("--key", None),
    "dtype": ("--dtype", None),
    "n_channels": ("--n-channels", None),
    "byte_order": ("--byte-order", None),
    "offset": ("--offset", None),
    "topic": ("--topic", None),
    "temperature": ("--temperature", None),
    "still": ("--still", "warn"),
}


def record_command(command: str, path: str | None, args: argparse.Namespace) -> str:
    """The command line ``allanite COMMAND`` that reads the same record with the same options.

    Used to point from one subcommand to the next (e.g. from ``analyze`` to ``fit``).
    """
    import shlex

    words = ["allanite", command]
    words += [path] if path is not None else ["--example"]
    for name, (flag, default) in _READER_FLAGS.items():
        value = getattr(args, name, default)
        if value is not None and value != default:
            words += [flag, f"{value:g}" if isinstance(value, float) else str(value)]
    return " ".join(shlex.quote(w) for w in words)


def rate_unit(record: Record) -> str | None:
    """Rate unit of a record: its unit for rate samples, unit per second for angle/increment.

    Raises
    ------
    ValueError
        If the unit is not a rate or acceleration for rate samples, or not an angle or a
        velocity for angle/increment samples (e.g. ``--input angle --units deg/s``).
    """
    return record.rate_unit()


#: kinds whose phase array may live in a temporary file (allanite.variance.outofcore)
OUT_OF_CORE_KINDS = ("overlapping", "standard", "hadamard", "standard_hadamard")


def automatic_memory_limit(part: Record, kind: str) -> int | None:
    """A memory budget for a record whose phase array would not fit in memory, else None.

    The in-memory path keeps a float64 phase array of the record's size (8 bytes per sample
    and channel) next to the samples; when that needs more than half of the available memory,
    the out-of-core path is taken with half of it as the budget (the phase goes to a
    temporary file), as ``--memory-limit`` would, and the command says so.
    """
    free = available_memory()
    phase = 8 * part.n_samples * part.n_channels
    if free is None or kind not in OUT_OF_CORE_KINDS or phase <= free // 2:
        return None
    return max(free // 2, 64 << 20)


def avar_from_args(record: Record, args: argparse.Namespace) -> AllanResult:
    """Allan-family variance of a record (its longest segment when split) with the grid options.

    Without ``--memory-limit`` and ``--fast``, a record whose phase array would take more than
    half of the available memory is analysed out of core (:func:`automatic_memory_limit`).
    """
    if args.points < 2:
        raise ValueError(f"--points must be at least 2, got {args.points}")
    if not 0.0 < args.level < 1.0:
        raise ValueError(f"--level must lie between 0 and 1, got {args.level}")
    part = record.longest_segment()
    large: dict[str, Any] = {}
    memory_limit = getattr(args, "memory_limit", None)
    if memory_limit is None and not getattr(args, "fast", False):
        memory_limit = automatic_memory_limit(part, getattr(args, "kind", "overlapping"))
        if memory_limit is not None:
            command = getattr(args, "command", None) or "allanite"
            print(
                f"allanite {command}: note: the record's phase array "
                f"({8 * part.n_samples * part.n_channels / 1e9:.3g} GB) would take more than "
                f"half of the available memory: working out of core with --memory-limit "
                f"{memory_limit / 1e9:.3g}GB (the phase goes to a temporary file)",
                file=sys.stderr,
            )
    if memory_limit is not None or getattr(args, "fast", False):
        large = {"memory_limit": memory_limit, "fast": bool(getattr(args, "fast", False))}
    with progress_bars() as bar:  # on a terminal: a 6 h, 2 kHz, 3-axis record takes ~20 s
        return avar(
            part.samples if part.n_channels > 1 else part.samples[:, 0],
            fs=part.require_fs(),
            input=part.input,  # type: ignore[arg-type]
            kind=args.kind,
            taus=args.taus,
            points=args.points,
            threads=args.threads,
            units=rate_unit(part),
            progress=bar,
            **large,
        )


#: nominal Allan-deviation slope of the readouts the units check trusts
READOUT_SLOPES = {"N": -0.5, "B": 0.0}
#: ... within this much (white noise reads -0.5 +- 0.02 on a clean record; a -1/2 line laid
#: on the last, noisy taus of a record without white noise touches at -0.43)
READOUT_TOLERANCE = 0.05


def _unit_findings(
    part: Record, result: AllanResult, dev: NDArray[np.float64], *, readouts: bool
) -> list[Finding]:
    """The wrong-unit checks: means, noise floor and (``readouts``) slope readouts N, B.

    Means are judged per channel and across an accelerometer triad; the noise floor is the
    deviation at the shortest tau; the readouts are those of an Allan deviation.
    """
    from allanite.fit.classic import classic_readout

    means = [float(np.mean(part.samples[:, c], dtype=np.float64)) for c in range(part.n_channels)]
    findings = check_means(means, part.units, input=part.input, channels=part.channels)
    per_channel_mean = not is_triad(part.units, part.n_channels, part.input)
    allan = result.kind in ("overlapping", "standard")
    for c, name in enumerate(part.channels):
        clean: dict[str, float | None] = {}
        if readouts and allan:
            readout = classic_readout(result.tau, dev[:, c])
            # only lines that touch the curve where it has their slope (a -1/2 line laid on
            # the noisy last taus of a record without white noise is not an N)
            clean = {
                s: v
                for s, v in readout.values.items()
                if s in READOUT_SLOPES
                and readout.slope.get(s) is not None
                and abs(float(readout.slope[s] or 0.0) - READOUT_SLOPES[s]) <= READOUT_TOLERANCE
            }
        findings += check_coefficients(
            clean,
            part.units,
            input=part.input,
            channel=name,
            mean=means[c] if per_channel_mean else None,
            n_ceiling=float(dev[0, c]) * math.sqrt(float(result.tau[0])) if allan else None,
        )
    return findings


def warn_implausible(
    record: Record,
    args: argparse.Namespace,
    result: AllanResult | None = None,
    *,
    readouts: bool = True,
) -> Record:
    """Run the plausibility checks, print each finding on stderr, return the record with them.

    The findings (:mod:`allanite.plausibility`: angle given as rate, rate given as angle,
    counts without a scale, stuck segments, noise coefficients (the slope readouts) outside
    any real sensor's range, i.e. a wrong ``--units``) are appended to ``record.warnings``,
    so the JSON summary and the report carry them too. ``result`` is the record's Allan
    analysis; without it a quick one (50-point log grid) is computed for the slope checks.
    ``readouts=False``
    leaves out the coefficient check on the slope readouts (``allanite fit`` checks its
    fitted coefficients instead, :func:`warn_coefficients`).
    """
    part = record.longest_segment()
    fs = part.require_fs()
    if result is None:
        samples = part.samples if part.n_channels > 1 else part.samples[:, 0]
        result = avar(samples, fs=fs, input=part.input, points=50)  # type: ignore[arg-type]
    dev = np.asarray(result.dev, dtype=np.float64).reshape(result.tau.size, -1)
    findings = check_samples(
        part.samples,
        fs=fs,
        input=part.input,
        channels=part.channels,
        scale=record.scale,
        short_dev=dev[0],
    ) + check_allan(result, part.channels)
    findings += _unit_findings(part, result, dev, readouts=readouts)
    command = getattr(args, "command", None) or "allanite"
    for finding in findings:
        print(f"allanite {command}: warning: {finding.message}", file=sys.stderr)
    if not findings:
        return record
    return dataclasses.replace(
        record, warnings=record.warnings + tuple(f.message for f in findings)
    )


def warn_coefficients(
    values: dict[str, float | None], record: Record, args: argparse.Namespace, channel: str
) -> list[str]:
    """Check noise coefficients against real sensors' ranges; print and return the warnings.

    :func:`allanite.plausibility.check_coefficients` (a wrong ``--units``); the messages are
    printed on stderr as ``allanite COMMAND: warning: ...``.
    """
    command = getattr(args, "command", None) or "allanite"
    findings = check_coefficients(values, record.units, input=record.input, channel=channel)
    for finding in findings:
        print(f"allanite {command}: warning: {finding.message}", file=sys.stderr)
    return [f.message for f in findings]


def dump_json(data: Any) -> str:
    """JSON text with NaN written as null (strict JSON readers reject NaN)."""
    import json
    import math

    def clean(value: Any) -> Any:
        if isinstance(value, float) and not math.isfinite(value):
            return None
        if isinstance(value, dict):
            return {k: clean(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [clean(v) for v in value]
        return value

    return json.dumps(clean(data), indent=2)
