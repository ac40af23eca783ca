"""Read records from text, .npy/.npz, raw binary, HDF5, Parquet and pandas DataFrames.

Every reader ends in the same place, :func:`make_record`: column selection by index or name,
an optional time column (sampling frequency inferred, gaps and jitter detected and handled by
a policy, see :mod:`allanite.io.timebase`), a scale factor from counts to units, and a
:class:`~allanite.io.record.Record` with the units attached. Problems with the file raise
:class:`~allanite.errors.InputError` naming the file, the line or field, and the fix.
"""

from __future__ import annotations

import math
import os
import re
import shlex
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from allanite.errors import InputError, choose_one
from allanite.extras import require
from allanite.io.atomic import note_input
from allanite.io.options import Column, ReadOptions
from allanite.io.record import Record, time_like
from allanite.io.text import read_text_table
from allanite.io.timebase import resolve_time

__all__ = [
    "FORMATS",
    "detect_format",
    "from_frame",
    "make_record",
    "read_record",
]

#: format name -> file suffixes
FORMATS: dict[str, tuple[str, ...]] = {
    "text": (".txt", ".csv", ".tsv", ".dat", ".asc", ".log", ".gz"),
    "npy": (".npy",),
    "npz": (".npz",),
    "raw": (".bin", ".raw", ".imu"),
    "hdf5": (".h5", ".hdf5", ".hdf"),
    "netcdf": (".nc", ".nc4", ".cdf", ".netcdf"),
    "parquet": (".parquet", ".pq"),
    "rosbag": (".bag", ".db3", ".mcap"),  # ROS 1 and ROS 2 (a ROS 2 bag directory too)
    "ulog": (".ulg", ".ulog"),  # PX4 flight logs
}

Where = Callable[[int], str]


def detect_format(path: str | os.PathLike[str]) -> str:
    """Format name from the file's first bytes, else from its suffix (unknown: text).

    Binary formats are recognised by their signature whatever the suffix (a netCDF file
    named ``.dat``, an HDF5 file named ``.nc``: netCDF-4); a binary file of no known format
    is never parsed as text (:func:`read_record` refuses it, naming ``--format raw``).
    """
    suffix = Path(path).suffix.lower()
    by_suffix = next((n for n, sfx in FORMATS.items() if suffix in sfx), "text")
    sniffed = _sniff(Path(path))
    if sniffed == "hdf5" and by_suffix == "netcdf":
        return "netcdf"  # netCDF-4 is HDF5
    if sniffed in (None, "binary"):
        return by_suffix
    return sniffed


#: file signatures -> format (netCDF-4 files start with the HDF5 one)
_MAGIC: tuple[tuple[bytes, str], ...] = (
    (b"CDF\x01", "netcdf"),
    (b"CDF\x02", "netcdf"),
    (b"\x89HDF\r\n\x1a\n", "hdf5"),
    (b"\x93NUMPY", "npy"),
    (b"PK\x03\x04", "npz"),
    (b"PAR1", "parquet"),
    (b"ULog\x01\x12\x35", "ulog"),
    (b"#ROSBAG V2.0", "rosbag"),
)
#: compressed text (read by the text reader when the suffix says so)
_GZIP = b"\x1f\x8b"


def _sniff(path: Path) -> str | None:
    """The format a file's first bytes name, ``"binary"`` for unknown binary, None for text."""
    if not path.is_file():
        return None
    with path.open("rb") as handle:
        head = handle.read(4096)
    for magic, name in _MAGIC:
        if head.startswith(magic):
            return name
    if head.startswith(_GZIP) or head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return None
    if b"\x00" in head or head.startswith(b"CDF\x05"):  # CDF-5: refused by name
        return "binary"
    return None


_RAW_OPTIONS = {
    "dtype": "--dtype",
    "n_channels": "--n-channels",
    "byteorder": "--byte-order",
    "offset": "--offset",
}


def _format_of(path: Path, format: str | None, raw_options: list[str]) -> str:
    """The format to read ``path`` in.

    ``format`` when given; else raw binary when a raw-layout option is given (unless the
    suffix names a self-describing format, or the file is plainly text); else the suffix.
    """
    if format is not None and format not in FORMATS:
        raise ValueError(f"unknown format {format!r}; use one of {', '.join(FORMATS)}")
    fmt = format or detect_format(path)
    if fmt == "text" and not raw_options and _sniff(path) == "binary":
        from allanite.io.netcdf import CDF5_MAGIC, CDF5_REFUSED

        with path.open("rb") as handle:
            cdf5 = handle.read(4) == CDF5_MAGIC
        raise InputError(
            CDF5_REFUSED
            if cdf5
            else "a binary file of no format known here, not text: it is not parsed as "
            "text; give its format (--format), or its layout for raw samples (--dtype, "
            "--n-channels)",
            path=str(path),
        )
    if not raw_options or fmt == "raw":
        return fmt
    given = ", ".join(_RAW_OPTIONS[name] for name in raw_options)
    if format is not None or fmt != "text":
        raise InputError(
            f"{given} describe raw binary, but the file is {fmt}"
            + ("" if format is not None else " (from its suffix), which carries its own layout")
            + "; drop the raw options, or give --format raw to read it as raw binary",
            path=str(path),
        )
    with path.open("rb") as handle:
        head = handle.read(4096)
    if head and all(32 <= b < 127 or b in b"\t\r\n" for b in head):
        raise InputError(
            f"{given} describe raw binary, but the file is plain text; drop the raw options "
            "(or give --format raw if it really is binary)",
            path=str(path),
        )
    return "raw"


def _as_list(columns: Column | Sequence[Column] | None) -> list[Column] | None:
    if columns is None:
        return None
    if isinstance(columns, (int, str, np.integer)):
        columns = [columns]
    out: list[Column] = []
    for c in columns:
        if isinstance(c, str) and "," in c:
            out.extend(p.strip() for p in c.split(",") if p.strip())
        else:
            out.append(c)
    return out


#: a column name stating its unit, ``gz[deg/s]``: the name and the unit
_HEADER_UNIT = re.compile(r"^(.*\S)\s*\[([^\[\]]+)\]$")
#: ... but an index in brackets is part of the name (``gyro_counts[0]``, a column of an array)
_INDEX = re.compile(r"^\s*\d+\s*$")


def _header_unit(name: str) -> re.Match[str] | None:
    """The match of a column name that states its unit (``gz[deg/s]``), or None.

    A bracketed whole number states no unit: it is an index, as in the names ``key[i]`` given
    to the columns of a 2-D array in an ``.npz`` or HDF5 file.
    """
    match = _HEADER_UNIT.match(name)
    return None if match is None or _INDEX.match(match.group(2)) else match


def _bare_name(name: str) -> str:
    """A column name without the unit in brackets a header may state (``gz[deg/s]`` -> ``gz``)."""
    match = _header_unit(name)
    return name.strip() if match is None else match.group(1)


def _resolve(names: tuple[str, ...], key: Column, source: str, what: str) -> int:
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        i = int(key)
        if i < 0:
            raise InputError(
                f"{what} {i}: columns are numbered from 0 to {len(names) - 1}; negative indices "
                f"are not accepted (the last column is {len(names) - 1}, named {names[-1]!r})",
                path=source,
            )
        if i >= len(names):
            raise InputError(
                f"{what} {i} does not exist: the data has {len(names)} column(s) "
                f"({', '.join(names)}); columns are numbered from 0",
                path=source,
            )
        return i
    if isinstance(key, str):
        if key in names:
            return names.index(key)
        bare = [i for i, name in enumerate(names) if _bare_name(name) == key.strip()]
        if len(bare) == 1:  # ``gz`` for a header ``gz[deg/s]`` (as allanite simulate writes)
            return bare[0]
        if key.lstrip("-").isdigit():
            return _resolve(names, int(key), source, what)
        raise InputError(f"no {what} named {key!r}; available: {', '.join(names)}", path=source)
    raise TypeError(f"a {what} is given by index or name, got {key!r}")


def _numeric_table(
    table: NDArray[Any], names: Sequence[str] | None, source: str
) -> tuple[NDArray[Any], tuple[str, ...]]:
    """The table as a 2-D real array and one name per column (``col0``, ... by default)."""
    arr = np.asarray(table)
    if arr.ndim == 1:
        arr = arr.reshape(-1, 1)
    if arr.ndim != 2:
        raise InputError(
            f"expected a table of samples (1-D or 2-D), got shape {arr.shape}; select a 2-D array",
            path=source,
        )
    if not (np.issubdtype(arr.dtype, np.number) and not np.iscomplexobj(arr)):
        raise InputError(f"data type {arr.dtype} is not a real number type", path=source)
    col_names = (
        tuple(str(n) for n in names)
        if names is not None
        else tuple(f"col{i}" for i in range(arr.shape[1]))
    )
    if len(col_names) != arr.shape[1]:
        raise InputError(f"{len(col_names)} column names for {arr.shape[1]} columns", path=source)
    return arr, col_names


def _sample_columns(
    col_names: tuple[str, ...],
    columns: Column | Sequence[Column] | None,
    time_column: Column | None,
    source: str,
    temperature: Column | None = None,
) -> tuple[int | None, list[int], int | None]:
    """Indices of the time column, the sample columns (default: all others), the temperature."""
    t_index = (
        None if time_column is None else _resolve(col_names, time_column, source, "time column")
    )
    k_index = (
        None
        if temperature is None
        else _resolve(col_names, temperature, source, "temperature column")
    )
    chosen = _as_list(columns)
    if chosen is None:
        idx = [i for i in range(len(col_names)) if i not in (t_index, k_index)]
    else:
        idx = [_resolve(col_names, c, source, "column") for c in chosen]
    if not idx:
        raise InputError("no sample columns left after taking the time column", path=source)
    for index, what in ((t_index, "time column"), (k_index, "temperature column")):
        if index is not None and index in idx:
            raise InputError(
                f"column {col_names[index]!r} is both the {what} and a sample column; "
                "leave it out of the columns",
                path=source,
            )
    if t_index is not None and t_index == k_index:
        raise InputError(
            f"column {col_names[t_index]!r} is both the time column and the temperature "
            "column; name the temperature column (--temperature NAME)",
            path=source,
        )
    return t_index, idx, k_index


def _temperature_values(
    arr: NDArray[Any], index: int | None, t_index: int | None, name: str, source: str
) -> NDArray[np.float64] | None:
    """The temperature column with missing values (nan) interpolated over time (or row).

    A temperature logged more slowly than the samples (a 1 Hz sensor in a 100 Hz table, nan
    in the rows between) is resampled onto every sample time by linear interpolation; the
    ends take the nearest logged value.
    """
    if index is None:
        return None
    values = np.asarray(arr[:, index], dtype=np.float64)
    known = np.isfinite(values)
    if np.all(known):
        return values
    if np.count_nonzero(known) < 1:
        raise InputError(
            f"the temperature column {name!r} holds no finite value; name the column that "
            "holds the temperature (--temperature NAME)",
            path=source,
        )
    x = (
        np.arange(values.size, dtype=np.float64)
        if t_index is None
        else np.asarray(arr[:, t_index], dtype=np.float64)
    )
    return np.interp(x, x[known], values[known])


def _scaled_samples(samples: NDArray[Any], scale: float | None) -> NDArray[Any]:
    """``samples * scale`` in float64 (the samples unchanged without a scale)."""
    if scale is None:
        return samples
    if not np.isfinite(scale) or scale == 0:
        raise ValueError(f"scale must be a finite, non-zero factor, got {scale!r}")
    return samples.astype(np.float64) * float(scale)


#: values checked for NaN/inf at a time (a 1e8-sample record is not doubled in memory)
_FINITE_BLOCK = 1 << 22


def _require_finite(samples: NDArray[Any], names: list[str], locate: Where, source: str) -> None:
    """Raise an InputError naming the first NaN/inf sample (row and column)."""
    if samples.dtype.kind != "f":
        return
    step = max(1, _FINITE_BLOCK // max(1, samples.shape[1]))
    for start in range(0, samples.shape[0], step):  # in blocks: no full-size temporaries
        bad = np.argwhere(~np.isfinite(samples[start : start + step]))
        if not bad.size:
            continue
        row, col = start + int(bad[0][0]), int(bad[0][1])
        raise InputError(
            f"{locate(row)}, column {names[col]!r}: sample is "
            f"{samples[row, col]}; the Allan variance needs every sample: remove or "
            "repair the row (or drop the column)",
            path=source,
        )


def make_record(
    table: NDArray[Any],
    names: Sequence[str] | None,
    *,
    source: str,
    fs: float | None = None,
    input: str = "rate",
    units: str | None = None,
    columns: Column | Sequence[Column] | None = None,
    time_column: Column | None = None,
    time_scale: float = 1.0,
    gaps: str = "error",
    scale: float | None = None,
    where: Where | None = None,
    fs_source: str | None = None,
    temperature: Column | None = None,
) -> Record:
    """Build a :class:`Record` from a 2-D table of numbers.

    Parameters
    ----------
    table : numpy.ndarray
        ``(rows, columns)`` numbers (a 1-D array is one column).
    names : sequence of str, optional
        Column names (``col0``, ``col1``, ... when omitted).
    source : str
        File name or description, for messages and :attr:`Record.source`.
    fs : float, optional
        Sampling frequency in Hz; inferred from ``time_column`` when omitted.
    input : {"rate", "increment", "angle"}
        What the samples are.
    units : str, optional
        Unit of the samples after scaling.
    columns : int, str or sequence, optional
        Channels to keep, by 0-based index or name (default: every column but the time
        column). A string with commas is split.
    time_column : int or str, optional
        Column of time stamps.
    time_scale : float
        Seconds per time-stamp unit (1e-3 for milliseconds, 1e-6 for microseconds).
    gaps : {"error", "split", "fill"}
        Policy for gaps in the time column.
    scale : float, optional
        Factor from counts to units: ``samples = counts * scale``.
    where : callable, optional
        Maps a row index to a location for messages (default ``"row i"``).
    fs_source : {"time", "fs"}, optional
        Which rate wins when ``fs`` contradicts the time column (see
        :func:`allanite.io.timebase.resolve_time`).
    temperature : int or str, optional
        Column of the sensor temperature in °C (:attr:`Record.temperature`); nan rows are
        interpolated over time, and it follows the samples through the gap policy.

    Returns
    -------
    Record
    """
    arr, col_names = _numeric_table(table, names, source)
    locate: Where = where if where is not None else (lambda row: f"row {row + 1}")
    t_index, idx, k_index = _sample_columns(col_names, columns, time_column, source, temperature)
    celsius = _temperature_values(arr, k_index, t_index, str(temperature), source)
    consecutive = idx == list(range(idx[0], idx[0] + len(idx))) if idx else False
    # a slice keeps a memory-mapped .npy/raw file mapped (a list of columns would copy it all)
    picked = arr[:, idx[0] : idx[0] + len(idx)] if consecutive else arr[:, idx]
    samples = _scaled_samples(picked, scale)
    _require_finite(samples, [col_names[i] for i in idx], locate, source)
    if arr.shape[0] < 3:
        raise InputError(f"only {arr.shape[0]} sample(s); need at least 3", path=source)
    channels = tuple(col_names[i] for i in idx)
    if t_index is None:
        record = Record(
            samples=samples,
            fs=fs,
            input=input,
            units=units,
            channels=channels,
            source=source,
            scale=scale,
            warnings=_time_channels(channels, samples) if fs is not None else (),
            temperature=celsius,
        )
        return _with_header(record, scale)
    if not np.isfinite(time_scale) or time_scale <= 0:
        raise ValueError(f"time_scale must be a positive number of seconds, got {time_scale!r}")
    t, t_notes = _stamps_in_seconds(col_names[t_index], arr[:, t_index], time_scale, fs, source)
    values = np.asarray(samples, dtype=np.float64)
    base = resolve_time(
        t,
        values if celsius is None else np.column_stack([values, celsius]),
        source=source,
        policy=gaps,
        fs=fs,
        where=locate,
        fs_source=fs_source,
    )
    record = Record(
        samples=base.samples if celsius is None else base.samples[:, :-1],
        temperature=None if celsius is None else base.samples[:, -1],
        fs=base.fs,
        input=input,
        units=units,
        channels=channels,
        source=source,
        segments=base.segments,
        warnings=(*t_notes, *base.warnings),
        timing=base.timing,
        scale=scale,
    )
    return _with_header(record, scale)


#: a time column named for its unit: ``t_ms``, ``time[us]``, ``stamp (ns)``, ``timestamp_usec``
_TIME_UNIT_NAME = re.compile(r"(?:^|[_\s\-\[(])(ms|msec|us|usec|µs|ns|nsec)[\])]?$", re.IGNORECASE)
_TIME_UNIT_SCALE = {"ms": 1e-3, "msec": 1e-3, "us": 1e-6, "usec": 1e-6, "µs": 1e-6}
_TIME_UNIT_SCALE |= {"ns": 1e-9, "nsec": 1e-9}


#: sampling rates (Hz) an IMU record can plausibly have; a time column implying one outside
#: them is in another unit than the reader assumed
PLAUSIBLE_FS = (1e-3, 1e6)
_NS_STAMP_NAME = re.compile(r"stamp|nsec|nanosec", re.IGNORECASE)


def _stamps_in_seconds(
    name: str, column: NDArray[np.float64], time_scale: float, fs: float | None, source: str
) -> tuple[NDArray[np.float64], tuple[str, ...]]:
    """Time stamps in seconds, with a note when the column's name said another unit.

    A ``time_scale`` other than 1 is the user's word. Otherwise a name stating a unit
    (``t_ms``, ``time[us]``, ``nsec``, ``stamp`` with stamps beyond 1e17 (ROS nanoseconds))
    is converted with a note. A column whose implied rate is outside :data:`PLAUSIBLE_FS`
    and whose name says no unit is refused (unless ``fs`` is given), naming the fix.
    """
    t = np.asarray(column, dtype=np.float64)
    if time_scale != 1.0 or t.size < 2:
        return t * time_scale, ()
    named = _TIME_UNIT_NAME.search(name.strip())
    scale = _TIME_UNIT_SCALE[named.group(1).lower()] if named is not None else None
    if scale is None and _NS_STAMP_NAME.search(name) and abs(float(t[0])) >= 1e17:
        scale = 1e-9
    if scale is not None:
        unit = {1e-3: "milliseconds", 1e-6: "microseconds", 1e-9: "nanoseconds"}[scale]
        note = (
            f"time column {name!r} read as {unit} (its name says so), converted to seconds; "
            "give --time-scale to override"
        )
        return t * scale, (note,)
    step = float(np.median(np.diff(t)))
    rate = 1.0 / step if step > 0 else float("inf")
    low, high = PLAUSIBLE_FS
    if fs is None and step > 0 and not low <= rate <= high:
        guess = 1e-9 if abs(float(t[0])) >= 1e17 else 1e-6 if rate < 1e-4 * low else 1e-3
        raise InputError(
            f"time column {name!r} read in seconds implies fs = {rate:.4g} Hz, no IMU rate "
            f"({low:g} to {high:g} Hz); give its unit with --time-scale (e.g. --time-scale "
            f"{guess:g} for {'ns' if guess == 1e-9 else 'us' if guess == 1e-6 else 'ms'}) "
            "or the rate with --fs",
            path=source,
        )
    return t, ()


def _with_header(record: Record, scale: float | None) -> Record:
    """The record with what its header states: units when none were given, else a check."""
    if record.units is not None:
        return _units_against_file(record)
    return _header_units(record) if scale is None else record


def _stated_units(channels: tuple[str, ...]) -> list[str] | None:
    """The unit each channel's header name states (``gz[deg/s]``), or None unless all do."""
    from allanite.units import parse_unit

    found = []
    for name in channels:
        match = _header_unit(name)
        if match is None:
            return None
        try:
            parse_unit(match.group(2))
        except ValueError:
            return None
        found.append(match.group(2).strip())
    return found


def stated_unit_conflict(record: Record, units: Sequence[str]) -> str | None:
    """The note for units given against the ones the file states, or None when they agree.

    A file states units in a header (``gz[deg/h]``) or by its message definition (a ROS
    ``sensor_msgs/Imu`` or PX4 ``sensor_combined``: rad/s and m/s^2, ``meta["channel_units"]``).
    ``--units`` wins when it names the same quantity (it may correct a wrong header), but
    ``gz[deg/h]`` read with ``--units deg/s`` changes every coefficient by 3600, so the record
    says so. A unit of another quantity (a gyro channel, rad/s, read as ``m/s^2``; an angle
    header read as a rate) is refused: the record would be analysed, and a simulator config
    corrected, as the wrong sensor. ``units`` has one unit per channel; channels whose file
    states no unit are not compared.

    Raises
    ------
    InputError
        If a given unit measures another quantity than the one the file states.
    """
    from allanite.units import _article, parse_unit, quantity

    def parsed(a: str, b: str) -> tuple[Any, Any] | None:
        try:
            return parse_unit(a), parse_unit(b)
        except ValueError:
            return None  # an unreadable stated unit states nothing

    meta = record.meta if isinstance(record.meta, dict) else {}
    found = meta.get("channel_units")
    per: dict[str, Any] = found if isinstance(found, dict) else {}
    differ = []
    other: dict[tuple[str, str], list[str]] = {}
    for name, unit in zip(record.channels, units, strict=True):
        match = _header_unit(name)
        stated = per.get(name) or (match.group(2).strip() if match is not None else None)
        both = None if stated is None else parsed(stated, unit)
        if both is None:
            continue
        if not both[0].same_dimension(both[1]):
            other.setdefault((str(stated), unit), []).append(name)
        elif not math.isclose(both[0].scale, both[1].scale, rel_tol=1e-12):
            shown = name if match is not None else f"{name} in {stated}"
            differ.append(f"{shown} read as {unit}")
    if other:
        (stated, unit), names = next(iter(other.items()))
        kind = quantity(stated)
        fix = (
            f"give --input angle (or increment) --units {stated} if the samples are {kind}s"
            if kind in ("angle", "velocity")
            else "leave --units out to read every channel in the unit the file states, or pick "
            "that sensor's channels with --channels (fit and report take one unit per sensor, "
            "e.g. --units rad/s,m/s^2)"
        )
        raise InputError(
            f"--units {unit} is {_article(quantity(unit))}, but the file states {stated} "
            f"({_article(kind)}) for {', '.join(names)}: {fix}",
            path=record.source,
        )
    if not differ:
        return None
    return (
        f"--units differs from the unit the file states ({', '.join(differ)}): the given "
        "unit is used; leave --units out to use the file's, or check the file"
    )


def _units_against_file(record: Record) -> Record:
    """A record read with a unit its file contradicts: the note added to its warnings."""
    import dataclasses

    if record.units is None:
        return record
    note = stated_unit_conflict(record, [record.units] * record.n_channels)
    if note is None:
        return record
    return dataclasses.replace(record, warnings=(*record.warnings, note))


def _header_units(record: Record) -> Record:
    """The units a header states for every channel, when no unit was given.

    ``gz[deg/s]``, as ``allanite simulate`` writes them: the record's unit when they agree,
    else one per channel (``meta["channel_units"]``, as for robot logs). A header that does
    not state a readable unit for every channel leaves the record as it is.
    """
    import dataclasses

    found = _stated_units(record.channels)
    if found is None:
        return record
    stated = ", ".join(dict.fromkeys(found))

    def usable(units: list[str]) -> bool:
        try:
            for unit in set(units):
                dataclasses.replace(record, units=unit).rate_unit()
        except ValueError:
            return False
        return True

    if not usable(found):
        timed = [c for c in record.channels if time_like(c)]
        others = [u for c, u in zip(record.channels, found, strict=True) if not time_like(c)]
        if timed and others and usable(others):  # a time column read as a channel
            note = (
                f"the header states units, but {', '.join(timed)} is a time column read as a "
                f"channel: units from the header not used; give --time-column "
                f"{shlex.quote(timed[0])} to read it as the time stamps"
            )
        else:
            other = "--input angle or increment" if record.input == "rate" else "--input rate"
            note = (
                f"the header states {stated}, not a unit of {record.input} samples: not used; "
                f"give {other} if that is what the samples are, or --units"
            )
        return dataclasses.replace(record, warnings=(*record.warnings, note))
    meta = {**record.meta, "channel_units": dict(zip(record.channels, found, strict=True))}
    units = found[0] if len(set(found)) == 1 else None
    note = f"units from the header: {stated}"
    return dataclasses.replace(record, units=units, meta=meta, warnings=(*record.warnings, note))


def _time_channels(channels: tuple[str, ...], samples: NDArray[Any]) -> tuple[str, ...]:
    """Warnings for channels that are named like time stamps and increase: a missed time column."""
    out = []
    for c, name in enumerate(channels):
        if time_like(name) and bool(np.all(np.diff(samples[:, c]) > 0)):
            out.append(
                f"channel {name} is named like time stamps and always increases: if it is the "
                f"time, give --time-column {shlex.quote(name)} (time_column={name!r}); it is "
                "analysed as a sensor channel"
            )
    return tuple(out)


# --- per-format loaders: return (table, names, where) ----------------------------------------
Loaded = tuple[NDArray[Any], tuple[str, ...] | None, Where | None]


def _load_text(path: Path, *, delimiter: str | None, header: bool | None) -> Loaded:
    table = read_text_table(path, delimiter=delimiter, header=header)
    return table.data, table.names, lambda row: f"line {table.line_of(row)}"


def _npy_truncated(path: Path) -> str | None:
    """Explain a truncated or corrupt .npy file, or None if its size matches its header."""
    with open(path, "rb") as handle:
        try:
            version = np.lib.format.read_magic(handle)
            if version == (1, 0):
                shape, _, dtype = np.lib.format.read_array_header_1_0(handle)
            else:
                shape, _, dtype = np.lib.format.read_array_header_2_0(handle)
        except (ValueError, OSError) as exc:
            return f"not a valid .npy file ({exc})"
        offset = handle.tell()
    if dtype.hasobject:
        return None
    expected = int(np.prod(shape)) * dtype.itemsize
    found = path.stat().st_size - offset
    if found < expected:
        return (
            f"truncated: the header announces shape {shape} ({expected} bytes of data) but only "
            f"{found} bytes follow; the copy is incomplete, copy or export it again"
        )
    return None


def _load_npy(path: Path) -> Loaded:
    problem = _npy_truncated(path)
    if problem is not None:
        raise InputError(problem, path=str(path))
    try:
        arr = np.load(path, mmap_mode="r", allow_pickle=False)
    except ValueError as exc:
        raise InputError(
            f"cannot read the array ({exc}); save plain numeric arrays with numpy.save",
            path=str(path),
        ) from exc
    return arr, None, None


def _load_npz(path: Path, key: str | None) -> Loaded:
    with open(path, "rb") as handle:  # closed even when numpy gives up on a broken archive
        try:
            archive = np.load(handle, allow_pickle=False)
        except (ValueError, zipfile.BadZipFile, EOFError) as exc:
            raise InputError(
                f"not a readable .npz archive ({exc}); the file may be truncated, copy it again",
                path=str(path),
            ) from exc
        return _from_archive(path, archive, key)


def _from_archive(path: Path, archive: Any, key: str | None) -> Loaded:
    with archive:
        keys = list(archive.files)
        if not keys:
            raise InputError("the archive holds no arrays", path=str(path))
        key = choose_one(key, keys, what="array", option="key= (CLI: --key NAME)", path=str(path))
        try:
            arr = archive[key]
        except ValueError as exc:
            if "allow_pickle" not in str(exc):
                raise InputError(
                    f"array {key!r} cannot be read ({exc}); the file may be truncated",
                    path=str(path),
                ) from exc
            raise InputError(
                f"array {key!r} holds Python objects (dtype object), not numbers: such arrays "
                "are never loaded (unpickling can run code); save plain numeric arrays, e.g. "
                "numpy.savez(path, gyro=np.asarray(data, dtype=float))",
                path=str(path),
            ) from exc
        except (zipfile.BadZipFile, EOFError, OSError) as exc:
            raise InputError(
                f"array {key!r} cannot be read ({exc}); the file may be truncated",
                path=str(path),
            ) from exc
    names = None
    if arr.ndim == 2 and arr.shape[1] > 1:
        names = tuple(f"{key}[{i}]" for i in range(arr.shape[1]))
    elif arr.ndim == 1:
        names = (key,)
    return arr, names, None


def _load_raw(
    path: Path, *, dtype: str | None, n_channels: int, byteorder: str, offset: int
) -> Loaded:
    if dtype is None:
        raise InputError(
            "raw binary needs the sample type; give dtype= (CLI: --dtype int16, float32, ...)",
            path=str(path),
        )
    try:
        dt = np.dtype(dtype)
    except TypeError as exc:
        raise ValueError(
            f"unknown dtype {dtype!r}; use e.g. int16, int32, float32, float64"
        ) from exc
    orders: dict[str, Literal["<", ">", "="]] = {
        "little": "<",
        "big": ">",
        "native": "=",
        "<": "<",
        ">": ">",
        "=": "=",
    }
    if byteorder not in orders:
        raise ValueError(f"byte order {byteorder!r}; use 'little', 'big' or 'native'")
    dt = dt.newbyteorder(orders[byteorder])
    if n_channels < 1:
        raise ValueError(f"channels must be at least 1, got {n_channels}")
    if offset < 0:
        raise ValueError(f"offset must be a non-negative number of bytes, got {offset}")
    size = path.stat().st_size - offset
    frame = dt.itemsize * n_channels
    if size <= 0:
        raise InputError(f"no data after the {offset}-byte offset; check --offset", path=str(path))
    if size % frame:
        raise InputError(
            f"{size} bytes after the offset are not a whole number of {n_channels}-channel "
            f"{dt.name} frames ({frame} bytes each; {size % frame} bytes left over); check "
            "--dtype, --n-channels and --offset, or the file is truncated",
            path=str(path),
        )
    arr = np.memmap(path, dtype=dt, mode="r", offset=offset, shape=(size // frame, n_channels))
    return np.asarray(arr), None, None


def _load_hdf5(path: Path, key: str | None, extra: Sequence[Column | None] = ()) -> Loaded:
    h5py = require("h5py", extra="hdf5", purpose="reading HDF5")
    try:
        handle = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"not a readable HDF5 file ({exc})", path=str(path)) from exc
    with handle:
        datasets = _datasets(handle)
        if key is None:
            if len(datasets) != 1:
                raise InputError(
                    f"the file holds {len(datasets)} datasets ({', '.join(datasets) or 'none'}); "
                    "choose one with key= (CLI: --key PATH)",
                    path=str(path),
                )
            key = datasets[0]
        if key not in handle or not isinstance(handle[key], h5py.Dataset):
            raise InputError(
                f"no dataset {key!r}; available: {', '.join(datasets)}", path=str(path)
            )
        ds = handle[key]
        if ds.dtype.names:
            names = tuple(ds.dtype.names)
            arr = np.column_stack([np.asarray(ds[n], dtype=np.float64) for n in names])
        else:
            arr = ds[()]
            names = None
            col_attr = ds.attrs.get("columns")
            if col_attr is not None and arr.ndim == 2 and len(col_attr) == arr.shape[1]:
                names = tuple(c.decode() if isinstance(c, bytes) else str(c) for c in col_attr)
        return _with_datasets(path, handle, key, arr, names, extra)


def _datasets(handle: Any) -> list[str]:
    """The paths of every dataset in an open HDF5 file."""
    h5py = require("h5py", extra="hdf5", purpose="reading HDF5")
    found: list[str] = []
    handle.visititems(
        lambda name, obj: found.append(name) if isinstance(obj, h5py.Dataset) else None
    )
    return found


def _with_datasets(
    path: Path,
    handle: Any,
    key: str,
    arr: NDArray[Any],
    names: tuple[str, ...] | None,
    extra: Sequence[Column | None],
) -> Loaded:
    """The table with the other datasets the options name (temperature, time) as columns.

    A name that is neither a column of the table nor a dataset with one value per row is
    left to the column lookup, which lists the columns; a dataset of another length is
    refused here.
    """
    table, col_names = _numeric_table(arr, names, str(path))
    named = [e for e in extra if isinstance(e, str) and e not in col_names and not e.isdigit()]
    missing = [e for e in named if e not in handle]
    if missing:
        raise InputError(
            f"no dataset or column {missing[0]!r}; datasets: {', '.join(_datasets(handle))}; "
            f"columns of {key!r}: {', '.join(col_names)}",
            path=str(path),
        )
    wanted = [e for e in named if e in handle]
    if not wanted:
        return arr, names, None
    columns = [table]
    for name in wanted:
        values = np.asarray(handle[name][()], dtype=np.float64)
        if values.ndim != 1 or values.shape[0] != table.shape[0]:
            raise InputError(
                f"dataset {name!r} has shape {values.shape}, the samples ({key!r}) have "
                f"{table.shape[0]} rows; give a dataset with one value per sample",
                path=str(path),
            )
        columns.append(values.reshape(-1, 1))
    return np.column_stack(columns), (*col_names, *wanted), None


def _load_parquet(path: Path, columns: list[Column] | None, *named: Column | None) -> Loaded:
    pq = require("pyarrow.parquet", extra="parquet", purpose="reading Parquet")
    try:
        table = pq.read_table(path)
    except Exception as exc:  # pyarrow raises its own ArrowInvalid / OSError types
        raise InputError(f"not a readable Parquet file ({exc})", path=str(path)) from exc
    names = tuple(table.column_names)
    arrays = []
    for name in names:
        col = table.column(name)
        try:
            arrays.append(np.asarray(col.to_numpy(), dtype=np.float64))
        except (ValueError, TypeError) as exc:
            wanted = {*(columns or []), *named}  # the time and temperature columns
            if columns is None or name in wanted:
                raise InputError(
                    f"column {name!r} is not numeric ({col.type}); select numeric columns "
                    "with --channels",
                    path=str(path),
                ) from exc
            arrays.append(np.full(table.num_rows, np.nan))
    return np.column_stack(arrays), names, None


def from_frame(frame: Any, *, source: str = "DataFrame", **options: Any) -> Record:
    """Build a :class:`Record` from a pandas DataFrame (columns by name, time column optional).

    A ``DatetimeIndex`` or ``TimedeltaIndex`` becomes the time column when ``time_column`` is
    ``"index"``. Other options are those of :func:`make_record`.
    """
    pd = require("pandas", extra="pandas", purpose="reading a DataFrame")
    if not isinstance(frame, pd.DataFrame):
        raise TypeError(f"expected a pandas DataFrame, got {type(frame).__name__}")
    if options.get("time_column") == "index":
        index = frame.index
        if isinstance(index, pd.DatetimeIndex):
            seconds = (index - index[0]).total_seconds().to_numpy()
        elif isinstance(index, pd.TimedeltaIndex):
            seconds = index.total_seconds().to_numpy()
        else:
            seconds = np.asarray(index, dtype=np.float64)
        frame = frame.assign(__time__=seconds)
        options["time_column"] = "__time__"
    names = tuple(str(c) for c in frame.columns)
    numeric = [c for c in frame.columns if pd.api.types.is_numeric_dtype(frame[c])]
    columns = _as_list(options.get("columns"))
    wanted = set(columns or []) | {options.get("time_column"), options.get("temperature")}
    for c in frame.columns:
        if c not in numeric and (columns is None or str(c) in wanted):
            raise InputError(
                f"column {c!r} is not numeric ({frame[c].dtype}); choose numeric columns with "
                "columns=",
                path=source,
            )
    table = np.column_stack(
        [
            frame[c].to_numpy(dtype=np.float64) if c in numeric else np.full(len(frame), np.nan)
            for c in frame.columns
        ]
    )
    return make_record(table, names, source=source, **options)


def read_record(
    source: str | os.PathLike[str] | Record | Any,
    options: ReadOptions | None = None,
    **changes: Any,
) -> Record:
    """Read a record from a file or a pandas DataFrame (a Record is returned as it is).

    Parameters
    ----------
    source : path, pandas.DataFrame or Record
        The file (format from its suffix unless ``options.format`` is given; unknown suffixes
        are read as text) or a DataFrame. A :class:`~allanite.io.Record` is already read: it
        comes back unchanged, so code that takes "a path or a record" can call this on
        either (reader options do not apply to it: select channels with
        ``record.select([...])``).
    options : ReadOptions, optional
        How to read it (:class:`~allanite.io.options.ReadOptions`: sampling frequency, input
        kind, unit, columns, time column, gaps, scale, format and layout); default: all
        defaults.
    **changes
        Any field of :class:`~allanite.io.options.ReadOptions` by name, overriding
        ``options`` (e.g. ``read_record("gyro.csv", fs=100.0, units="deg/s")``).

    Returns
    -------
    Record

    Raises
    ------
    TypeError
        For a keyword that is not a reader option (the message lists them), or reader
        options given with a Record.
    """
    opts = (options if options is not None else ReadOptions()).replace(**changes)
    if isinstance(source, Record):
        if options is not None or changes:
            raise TypeError(
                "read_record(record, ...): the Record is read already, reader options do not "
                "apply to it; leave them out (select channels with record.select([...]))"
            )
        return source
    if not isinstance(source, (str, os.PathLike)):
        return from_frame(source, **opts.table())
    if str(source) == STDIN:
        return _read_stdin(opts)
    path = Path(source)
    if not path.exists():
        raise InputError("no such file; check the path", path=str(path))
    from allanite.io.robot_logs import is_ros2_bag_dir

    if path.is_dir() and not is_ros2_bag_dir(path):
        raise InputError("is a directory; give a file (or a ROS 2 bag directory)", path=str(path))
    if not path.is_dir() and not path.is_file():
        raise InputError(
            f"is not a regular file but {_special_kind(path)}: a record is read more than once "
            "(format, header, rows), which a stream cannot be; save it to a file first "
            "(e.g. cat > rec.csv), or give - to read a text record from standard input",
            path=str(path),
        )
    fmt = "rosbag" if path.is_dir() else _format_of(path, opts.format, list(opts.raw_layout()))
    note_input(path)  # an output of this command must not replace it
    try:
        if fmt in ("rosbag", "ulog"):
            return _read_robot_log(path, fmt, opts.topic, opts.table())
        if fmt == "netcdf":
            return _read_netcdf(path, opts)
        if path.stat().st_size == 0:
            raise InputError(
                "the file is empty; check that the recording was written", path=str(path)
            )
        table, names, where = _load(path, fmt, opts)
    except (ValueError, TypeError, OSError, ImportError, MemoryError, RecursionError):
        raise  # already a message (InputError is a ValueError) or a missing extra
    except Exception as exc:  # a library's own error on a damaged file: name the file
        raise InputError(
            f"cannot read it as {fmt} ({type(exc).__name__}: {str(exc)[:200]}); the file is "
            "damaged or not in that format",
            path=str(path),
        ) from exc
    return make_record(table, names, source=str(path), where=where, **opts.table())


#: the record name that reads standard input (text records)
STDIN = "-"


def _read_stdin(opts: ReadOptions) -> Record:
    """A text record from standard input, spooled to a temporary file (read more than once)."""
    import dataclasses
    import shutil
    import sys
    import tempfile

    if (opts.format or "text") != "text" or opts.raw_layout():
        raise InputError(
            "standard input is read as a text table only; save a binary record to a file "
            "and give that file",
            path="<stdin>",
        )
    with tempfile.TemporaryDirectory(prefix="allanite-stdin-") as tmp:
        spool = Path(tmp) / "stdin.txt"
        with spool.open("wb") as handle:
            shutil.copyfileobj(sys.stdin.buffer, handle)
        try:
            record = read_record(spool, opts)
        except InputError as exc:
            raise InputError(str(exc).replace(str(spool), "<stdin>")) from None
    return dataclasses.replace(record, source="<stdin>")


def _special_kind(path: Path) -> str:
    """What a path that is neither a file nor a directory is, for a message."""
    import stat

    mode = path.stat().st_mode
    if stat.S_ISFIFO(mode):
        return "a pipe (FIFO)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "a special file"


def _load(path: Path, fmt: str, opts: ReadOptions) -> Loaded:
    """The table, column names and row locator of a file in format ``fmt``."""
    if fmt == "text":
        return _load_text(path, delimiter=opts.delimiter, header=opts.header)
    if fmt == "npy":
        return _load_npy(path)
    if fmt == "npz":
        return _load_npz(path, opts.key)
    if fmt == "raw":
        return _load_raw(
            path,
            dtype=opts.dtype,
            n_channels=1 if opts.n_channels is None else opts.n_channels,
            byteorder=opts.byteorder or "little",
            offset=opts.offset or 0,
        )
    if fmt == "hdf5":
        return _load_hdf5(path, opts.key, [opts.temperature, opts.time_column])
    return _load_parquet(path, _as_list(opts.columns), opts.time_column, opts.temperature)


def _read_netcdf(path: Path, opts: ReadOptions) -> Record:
    """A netCDF record: its time coordinate is the time column unless fs or one is given."""
    import dataclasses

    from allanite.io.netcdf import load_netcdf, netcdf_kind

    classic = netcdf_kind(path)
    loaded = load_netcdf(
        path, key=opts.key, wanted=[opts.temperature, opts.time_column], classic=classic
    )
    options = opts.table()
    notes: tuple[str, ...] = ()
    if loaded.time is not None and opts.time_column is None and opts.fs is None:
        name, scale = loaded.time
        options |= {"time_column": name, "time_scale": scale}
        notes = (f"time from the netCDF coordinate variable {name!r} ({scale:g} s per unit)",)
    elif loaded.time is not None and opts.time_column is None and opts.columns is None:
        options |= {
            "columns": [n for n in loaded.names if n not in (loaded.time[0], opts.temperature)]
        }
    record = make_record(loaded.data, loaded.names, source=str(path), **options)
    return dataclasses.replace(record, warnings=(*notes, *record.warnings))


def _read_robot_log(path: Path, fmt: str, topic: str | None, options: dict[str, Any]) -> Record:
    """A ROS bag or ULog as a record: time stamps from the messages, units per axis."""
    import dataclasses

    from allanite.io.robot_logs import CHANNEL_UNITS, TEMPERATURE, load_rosbag, load_ulog

    loader = load_rosbag if fmt == "rosbag" else load_ulog
    given = options.get("temperature")
    table, names, warnings = loader(path, topic, None if given is None else str(given))
    if given is not None:
        options = {**options, "temperature": TEMPERATURE}
    if table.shape[0] < 3:
        raise InputError(f"only {table.shape[0]} IMU message(s); need at least 3", path=str(path))
    if options.get("time_column") is None:
        options = {**options, "time_column": "t", "time_scale": 1.0}
    record = make_record(table, names, source=str(path), **options)
    units = {CHANNEL_UNITS.get(c) for c in record.channels}
    meta = {"channel_units": {c: CHANNEL_UNITS.get(c) for c in record.channels}}
    changes: dict[str, Any] = {"warnings": (*warnings, *record.warnings), "meta": meta}
    if options.get("units") is None and len(units) == 1:
        changes["units"] = units.pop()
    return _units_against_file(dataclasses.replace(record, **changes))
