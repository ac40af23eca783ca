r"""Batch analysis of many recordings: one table of fitted noise coefficients and pass/fail.

A production lot of gyros or a benchmark suite of logs goes through the same steps per
record: read, overlapping Allan variance, noise-model fit, comparison with a datasheet.
:func:`batch` runs them locally (one record after another, each using the compiled kernel's
threads) or, when given a ``dask.distributed`` client, as one task per record on the cluster
(the ``dask`` extra); the table is the same either way because every record is computed by
the same deterministic function.

Coefficients. Each channel's Allan variance is fitted with :func:`allanite.fit` (GLS with the
estimates' own covariance; ``terms="auto"`` selects among Q, N, B, K, R by a penalized
likelihood, so a term the data show no sign of is left out and its cells stay empty). Every
coefficient is reported as its estimate and its two-sided ``level`` confidence interval
(``<name>``, ``<name>_low``, ``<name>_high``), in the record's rate unit times seconds to
the term's power (``N`` in unit*sqrt(s), ``B`` in unit, ``K`` in unit/sqrt(s)), together
with the fit's goodness-of-fit ``p_value`` (generalized chi-square; below ``0.001`` the
model misses the curve and the intervals include a model discrepancy) and ``rejected``
(True when that test rejects the model: do not use its coefficients without looking at it).

Datasheet. Either form of :mod:`allanite.datasheet`: the compact ``{"N": 0.01, "B":
{"max": 0.003}}`` in the record's units, or the full ``{"limits": [{"quantity": "N", "max":
0.3, "unit": "deg/sqrt(h)"}, {"quantity": "adev", "tau": 1, "max": 0.01, "unit":
"deg/s"}]}``. Each limit is judged with the interval (:func:`allanite.datasheet.check_limits`):
*pass* when the whole interval meets it, *marginal* when only the interval crosses it, *fail*
when the estimate violates it; a term the fit left out is judged by its upper limit
(``<name>_upper``): *pass* when that is within the limit, *undetermined* when it is not (the
record cannot tell); *missing* when not measured at all. A row passes unless a check fails or
the record could not be analysed (*marginal* and *undetermined* are undecided, not failed).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from allanite._deprecation import keyword_only_fs
from allanite.confidence import DEFAULT_LEVEL
from allanite.datasheet import (
    Check,
    Datasheet,
    Limit,
    Measured,
    check_limits,
    undetected_measured,
    verdict,
)
from allanite.errors import InputError
from allanite.extras import require
from allanite.plausibility import constant_channels, refuse_constant
from allanite.units import record_rate_unit

if TYPE_CHECKING:
    from allanite.io.record import Record

__all__ = ["BatchResult", "batch"]

Terms = str | Sequence[Any]
#: the coefficients ``terms="auto"`` chooses from, in table order
AUTO_COEFFICIENTS: tuple[str, ...] = ("Q", "N", "B", "K", "R")


@dataclass(frozen=True)
class BatchResult:
    """One row per record and channel: coefficients, checks against the datasheet, errors.

    Attributes
    ----------
    columns : tuple of str
        ``record, channel, n_samples, fs, units, p_value, rejected`` (the goodness-of-fit
        test rejects the fitted model); per coefficient ``<name>,
        <name>_low, <name>_high`` (estimate and ``level`` interval) and, with
        ``terms="auto"``, ``<name>_upper`` for Q, N, B, K, R (the ``level`` upper limit when
        the fit left the term out, :attr:`allanite.fit.FitResult.undetected`; empty when it
        was fitted); ``check_<quantity>`` per datasheet limit
        (``pass``/``marginal``/``fail``/``undetermined``/``missing``, see
        :mod:`allanite.datasheet`); ``status`` (the worst check, ``pass`` without a
        datasheet, ``error`` when the record or channel could not be analysed), ``pass``
        (status is pass, marginal or undetermined: nothing failed) and ``error`` (the
        message).
    rows : tuple of tuple
        The table (None where a value does not exist).
    datasheet : Datasheet or None
        The limits used.
    """

    columns: tuple[str, ...]
    rows: tuple[tuple[Any, ...], ...]
    datasheet: Datasheet | None = None

    def __len__(self) -> int:
        return len(self.rows)

    def column(self, name: str) -> list[Any]:
        """All values of one column."""
        if name not in self.columns:
            raise KeyError(f"no column {name!r}; columns are {', '.join(self.columns)}")
        i = self.columns.index(name)
        return [row[i] for row in self.rows]

    @property
    def passed(self) -> bool:
        """Whether every row passed every check (and no record failed to analyse)."""
        return all(self.column("pass"))

    @property
    def failures(self) -> list[tuple[str, Any]]:
        """``(record, channel)`` of the rows that failed."""
        rec, ch, ok = self.column("record"), self.column("channel"), self.column("pass")
        return [(r, c) for r, c, p in zip(rec, ch, ok, strict=True) if not p]

    def to_dict(self) -> dict[str, Any]:
        """``{"columns": [...], "rows": [[...], ...], "datasheet": {...}}`` (JSON-ready)."""
        return {
            "columns": list(self.columns),
            "rows": [list(r) for r in self.rows],
            "datasheet": None
            if self.datasheet is None
            else {
                "device": self.datasheet.device,
                "limits": [_limit_dict(limit) for limit in self.datasheet.limits],
            },
        }

    def to_json(self, **kwargs: Any) -> str:
        """JSON text of :meth:`to_dict`."""
        return json.dumps(self.to_dict(), **kwargs)

    def to_frame(self) -> Any:
        """Return a :class:`pandas.DataFrame` of the table (needs the ``pandas`` extra)."""
        pd = require("pandas", extra="pandas", purpose="to_frame()")
        return pd.DataFrame(list(self.rows), columns=list(self.columns))

    def to_csv(self, path: str | os.PathLike[str]) -> None:
        """Write the table as CSV (17 significant digits, empty cells for None)."""
        import csv

        def cell(v: Any) -> Any:
            if v is None:
                return ""
            if isinstance(v, float):
                return format(v, ".17g")
            return v

        with open(path, "w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(self.columns)
            writer.writerows([cell(v) for v in row] for row in self.rows)


def _limit_dict(limit: Limit) -> dict[str, Any]:
    """A limit in the full datasheet form (JSON-ready; unit "" means record units)."""
    return {k: v for k, v in vars(limit).items() if v is not None}


@dataclass(frozen=True)
class _Task:
    """Everything one record needs, picklable (sent to Dask workers)."""

    name: str
    source: Any
    fs: float | None
    avar_options: dict[str, Any]
    read_options: dict[str, Any]
    terms: Terms
    level: float
    sheet: Datasheet | None


def _load(task: _Task) -> tuple[NDArray[Any], float, str, str | None, tuple[str, ...]]:
    """Read a task's source: samples, fs, input kind, units and channel names."""
    from allanite.io.record import Record

    source = task.source
    if isinstance(source, (str, os.PathLike)):
        from allanite.io.readers import read_record

        options = dict(task.read_options)
        if task.fs is not None:
            options.setdefault("fs", task.fs)
        source = read_record(source, **options)
    if isinstance(source, Record):
        fs = source.require_fs()  # names the record and how to give fs
        _one_sensor(source)
        names = tuple(source.channels) or tuple(str(i) for i in range(source.samples.shape[-1]))
        return source.samples, fs, source.input, source.units, names
    if task.fs is None:
        raise ValueError(f"{task.name}: arrays need fs= (sampling frequency in Hz)")
    arr = np.asarray(source)
    n_channels = 1 if arr.ndim == 1 else arr.shape[1]
    units = task.read_options.get("units")
    return (
        arr,
        float(task.fs),
        task.read_options.get("input", "rate"),
        units,
        tuple(str(i) for i in range(n_channels)),
    )


def _one_sensor(record: Record) -> None:
    """Refuse a record whose file states several units and none was given (a six-axis log).

    A ROS bag or PX4 log states rad/s for its gyro axes and m/s^2 for its accelerometer's
    (``meta["channel_units"]``); one table of coefficients in one unit cannot hold both.
    """
    meta = record.meta if isinstance(record.meta, dict) else {}
    stated = meta.get("channel_units")
    if record.units is not None or not isinstance(stated, dict):
        return
    groups: dict[str, list[str]] = {}
    for name in record.channels:
        unit = stated.get(name)
        if unit is not None:
            groups.setdefault(str(unit), []).append(name)
    if len(groups) < 2:
        return
    held = "; ".join(f"{', '.join(names)} in {unit}" for unit, names in groups.items())
    first = ",".join(next(iter(groups.values())))
    raise InputError(
        f"the file holds channels in {len(groups)} units ({held}): a batch table is one "
        f"sensor at a time; choose its channels with channels= (CLI: --channels {first}), or "
        "fit the whole log with allanite fit, which takes each sensor in its unit",
        path=record.source,
    )


def _finite(value: float) -> float | None:
    """Return a float, None for NaN/inf (so that tables compare equal and serialise to JSON)."""
    return float(value) if math.isfinite(value) else None


def _rate_unit(input_kind: str, units: str | None) -> str | None:
    """Rate unit of the Allan variance: the record's unit, per second for angle/increment."""
    return record_rate_unit(units, input_kind, strict=True)


def _unit_free(sheet: Datasheet | None, rate: str | None) -> None:
    """Refuse limits in physical units when the record's units are unknown."""
    if sheet is None or rate is not None:
        return
    for limit in sheet.limits:
        if limit.unit and limit.quantity != "adev":
            raise ValueError(
                f"the limit on {limit.quantity} is in {limit.unit} but the record's units are "
                "unknown; give units= (--units), or write the limit in record units (compact "
                "form)"
            )


def _fit_row(single: Any, task: _Task, rate: str | None) -> dict[str, Any]:
    """Fit one channel and check it: coefficients with intervals, p-value, check statuses."""
    from allanite.fit import fit

    result = fit(single, task.terms)
    coefficients: dict[str, tuple[float | None, float | None, float | None]] = {}
    measured: dict[str, Measured] = {}
    for name, coef in result.coefficients.items():
        low, high = coef.ci(task.level)
        coefficients[name] = (_finite(coef.value), _finite(low), _finite(high))
        measured[name] = Measured(coef.value, low, high, coef.unit, coef.unit)
    checks: list[Check] = []
    bounds = undetected_measured(result, task.level)
    if task.sheet is not None:
        low_dev, high_dev = single.ci(task.level)
        curve = (single.tau, single.dev, low_dev, high_dev, rate)
        checks = check_limits(task.sheet, "", measured, curve, bounds)
    upper = {name: _finite(bound.high) for name, bound in bounds.items()}
    return {
        "coefficients": coefficients,
        "upper": upper,
        "p_value": _finite(result.p_value),
        "rejected": bool(result.rejected),
        # one status per limit, None where a limit is for another sensor (left out)
        "checks": [
            next((c.status for c in checks if c.limit is limit), None)
            for limit in (task.sheet.limits if task.sheet is not None else ())
        ],
    }


def _analyse(task: _Task) -> list[dict[str, Any]]:
    """Rows of one record (module-level so that Dask can pickle it)."""
    from allanite.variance.outofcore import avar_large

    try:
        samples, fs, input_kind, units, names = _load(task)
        rate = _rate_unit(input_kind, units)
        _unit_free(task.sheet, rate)
        result = avar_large(samples, fs=fs, input=input_kind, units=rate, **task.avar_options)
    except (InputError, ValueError, TypeError, OSError) as exc:
        return [{"record": task.name, "channel": None, "error": " ".join(str(exc).split())}]
    if len(names) == result.n_channels:  # the fit's findings name the channel as the table does
        result = dataclasses.replace(result, meta={**result.meta, "channels": list(names)})
    dead = set(constant_channels(samples)) if np.ndim(samples) <= 2 else set()
    rows = []
    for c in range(result.n_channels):
        row: dict[str, Any] = {
            "record": task.name,
            "channel": names[c] if c < len(names) else str(c),
            "n_samples": result.n_samples,
            "fs": result.fs,
            "units": rate,
            "error": None,
        }
        try:
            if c in dead:  # a dead channel: say so, not "too short for an automatic fit"
                column = samples[:, c] if np.ndim(samples) == 2 else samples
                refuse_constant(column, [row["channel"]], source=task.name)
            row.update(_fit_row(result.channel(c), task, rate))
        except (ValueError, TypeError) as exc:
            row["error"] = " ".join(str(exc).split())
        rows.append(row)
    return rows


def _limit_columns(sheet: Datasheet | None) -> list[str]:
    """``check_<quantity>`` per limit (``check_adev@1s`` for an Allan deviation limit)."""
    columns: list[str] = []
    for limit in sheet.limits if sheet is not None else ():
        key = f"adev@{limit.tau:g}s" if limit.quantity == "adev" else limit.quantity
        column, k = f"check_{key}", 2
        while column in columns:
            column, k = f"check_{key}_{k}", k + 1
        columns.append(column)
    return columns


def _check_names(sheet: Datasheet | None, names: Sequence[str]) -> None:
    unknown = [q for q in (sheet.quantities if sheet else ()) if q != "adev" and q not in names]
    if unknown:
        raise ValueError(
            f"datasheet names {unknown} are not coefficients of the analysis "
            f"({', '.join(names)}, or adev at a tau); fix the datasheet or the terms"
        )


def _table(per_record: Sequence[list[dict[str, Any]]], task: _Task) -> BatchResult:
    names: list[str] = list(AUTO_COEFFICIENTS) if task.terms == "auto" else []
    for rows in per_record:
        for row in rows:
            names += [k for k in row.get("coefficients", {}) if k not in names]
    if any("coefficients" in row for rows in per_record for row in rows):
        _check_names(task.sheet, names)
    checks = _limit_columns(task.sheet)
    columns = ["record", "channel", "n_samples", "fs", "units", "p_value", "rejected"]
    # terms="auto": the upper limit of each candidate the fit left out (FitResult.undetected)
    bounded = [n for n in AUTO_COEFFICIENTS if n in names] if task.terms == "auto" else []
    for name in names:
        columns += [name, f"{name}_low", f"{name}_high"]
        columns += [f"{name}_upper"] if name in bounded else []
    columns += [*checks, "status", "pass", "error"]
    table = []
    for rows in per_record:
        for row in rows:
            values = row.get("coefficients", {})
            upper = row.get("upper", {})
            cells = []
            for name in names:
                cells += list(values.get(name, (None, None, None)))
                cells += [upper.get(name)] if name in bounded else []
            statuses = row.get("checks") or [None] * len(checks)
            status = "error" if row["error"] is not None else verdict(statuses)
            table.append(
                (
                    row["record"],
                    row["channel"],
                    row.get("n_samples"),
                    row.get("fs"),
                    row.get("units"),
                    row.get("p_value"),
                    row.get("rejected"),
                    *cells,
                    *statuses,
                    status,
                    status in ("pass", "marginal", "undetermined"),
                    row["error"],
                )
            )
    return BatchResult(tuple(columns), tuple(table), task.sheet)


def _name(item: Any, index: int) -> tuple[str, Any]:
    if isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str):
        return item[0], item[1]
    if isinstance(item, (str, os.PathLike)):
        return str(item), item
    source = getattr(item, "source", None)
    if isinstance(source, str) and source != "array":
        return source, item
    return f"record{index}", item


@keyword_only_fs
def batch(
    records: Iterable[Any],
    *,
    fs: float | None = None,
    datasheet: Datasheet | Mapping[str, Any] | str | os.PathLike[str] | None = None,
    terms: Terms = "auto",
    level: float = DEFAULT_LEVEL,
    client: Any = None,
    taus: Any = "log",
    points: int = 100,
    threads: int | None = None,
    memory_limit: int | float | str | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    **read_options: Any,
) -> BatchResult:
    """Analyse many records into one table of fitted coefficients with pass/fail.

    Parameters
    ----------
    records : iterable
        File paths (read with :func:`allanite.io.readers.read_record` and ``read_options``),
        :class:`~allanite.io.record.Record` objects, arrays (``fs`` required), or
        ``(name, array_or_path)`` pairs.
    fs : float, optional
        Sampling frequency in Hz, keyword only: required for arrays (and files without a time
        column); Records and files with a time column bring their own.
    datasheet : Datasheet, mapping or path, optional
        Limits in either form of :mod:`allanite.datasheet`, or a JSON/YAML file of them.
    terms : "auto" or list
        Terms fitted to every channel (see :func:`allanite.fit`); default ``"auto"``.
    level : float
        Confidence level of the intervals and of the datasheet checks (default
        :data:`allanite.confidence.DEFAULT_LEVEL`, 0.95).
    client : dask.distributed.Client, optional
        Run one task per record on this cluster (``pip install 'allanite[dask]'``); default:
        locally, in order.
    taus, points, threads, memory_limit
        Passed to :func:`allanite.variance.outofcore.avar_large` for every record (overlapping Allan
        variance; the EDF assumes white FM, ``alpha=0``, which keeps a batch fast: the fit
        computes its own covariance and the Allan deviation intervals of ``adev`` limits are
        those of white noise).
    progress : callable, optional
        ``progress("records", done, total)`` after each record (on the calling thread; the
        same signature as the ``progress`` of :func:`allanite.variance.outofcore.avar_large`).
    **read_options
        Reader options for paths (``input``, ``units``, ``columns``, ``scale``, ``dtype``,
        ...); ``input`` and ``units`` also describe arrays.

    Returns
    -------
    BatchResult
        One row per record and channel; ``passed`` tells whether the whole lot passed.

    References
    ----------
    IEEE Std 952-1997 annex C; IEEE Std 1431-2004 (noise coefficients of gyros).
    """
    if not (isinstance(level, float | int) and 0.0 < level < 1.0):
        raise ValueError(f"level must lie between 0 and 1 (e.g. 0.95), got {level!r}")
    sheet = Datasheet.coerce(
        Path(datasheet)
        if isinstance(datasheet, os.PathLike)
        else dict(datasheet)
        if isinstance(datasheet, Mapping)
        else datasheet
    )
    if terms == "auto":
        _check_names(sheet, AUTO_COEFFICIENTS)
    avar_options = {
        "kind": "overlapping",
        "taus": taus,
        "points": points,
        "threads": threads,
        "memory_limit": memory_limit,
        "alpha": 0,
    }
    tasks = [
        _Task(name, source, fs, avar_options, dict(read_options), terms, float(level), sheet)
        for name, source in (_name(item, i) for i, item in enumerate(records))
    ]
    if not tasks:
        raise ValueError("no records to analyse; give paths, arrays or (name, array) pairs")
    results: list[list[dict[str, Any]]]
    if client is None:
        results = []
        for i, task in enumerate(tasks, start=1):
            results.append(_analyse(task))
            if progress is not None:
                progress("records", i, len(tasks))
    else:
        results = _run_dask(client, tasks, progress)
    return _table(results, tasks[0])


def _run_dask(
    client: Any, tasks: list[_Task], progress: Callable[[str, int, int], None] | None
) -> list[list[dict[str, Any]]]:
    as_completed = require("distributed", extra="dask", purpose="batch(client=...)").as_completed
    futures = client.map(_analyse, tasks, pure=False)
    index = {f.key: i for i, f in enumerate(futures)}
    out: list[list[dict[str, Any]] | None] = [None] * len(tasks)
    for done, fut in enumerate(as_completed(futures), start=1):
        out[index[fut.key]] = fut.result()
        if progress is not None:
            progress("records", done, len(tasks))
    return [rows for rows in out if rows is not None]
