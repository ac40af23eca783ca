r"""Batch analysis of many recordings: one table of noise coefficients and pass/fail.

A production lot of gyros or a benchmark suite of logs goes through the same steps per
record: read, Allan variance, coefficients, comparison with a datasheet. :func:`batch` runs
them locally (one record after another, each using the compiled kernel's threads) or, when
given a ``dask.distributed`` client, as one task per record on the cluster (the ``dask``
extra); the table is the same either way because every record is computed by the same
deterministic function.

Coefficients. By default each channel's Allan curve is read with the ``guess`` of the IEEE
power-law terms (:data:`allanite.terms.POWER_LAW_TERMS`): ``Q``, ``N``, ``B``, ``K``, ``R`` are
the tightest values the curve allows for each term alone (e.g. :math:`N^2 = \min_\tau
\sigma^2(\tau)\,\tau`, :math:`B = \min_\tau \sigma(\tau)/0.664`), the usual datasheet
reading of an Allan plot (IEEE Std 952-1997, annex C). Units: the record's rate unit times
seconds to the power of the term's ``ParamSpec.time`` (``N`` in unit*sqrt(s), ``B`` in unit,
``K`` in unit/sqrt(s)). Pass ``coefficients=callable`` to use a model fit instead: it gets a
single-channel :class:`~allanite.variance.AllanResult` and returns ``{name: value}``.

Datasheet. ``{"N": 0.01, "B": {"max": 0.003}, "K": {"min": 0, "max": 1e-4}}``: a number is
an upper limit; a check fails when the coefficient is missing (no sign of the term) only if a
``min`` is given.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.errors import InputError
from allanite.variance import AllanResult

__all__ = ["BatchResult", "batch", "curve_coefficients", "load_datasheet"]

Coefficients = Callable[[AllanResult], Mapping[str, float | None]]
Limit = tuple[float | None, float | None]


def curve_coefficients(result: AllanResult) -> dict[str, float | None]:
    """Coefficients ``Q, N, B, K, R`` read from a single-channel Allan curve (term guesses).

    Parameters
    ----------
    result : AllanResult
        Single-channel result (``result.channel(c)``).

    Returns
    -------
    dict
        Symbol -> value in the record's units, None where the curve shows no sign of the term.
    """
    from allanite.terms import POWER_LAW_TERMS

    out: dict[str, float | None] = {}
    for cls in POWER_LAW_TERMS:
        term = cls.guess(result)
        value = None if term is None else getattr(term, cls.symbol)
        out[cls.symbol] = None if value is None or not math.isfinite(value) else float(value)
    return out


def _limits(datasheet: Mapping[str, Any] | None) -> dict[str, Limit]:
    limits: dict[str, Limit] = {}
    for name, spec in (datasheet or {}).items():
        if isinstance(spec, Mapping):
            unknown = set(spec) - {"min", "max"}
            if unknown:
                raise ValueError(
                    f"datasheet entry {name!r} has keys {sorted(unknown)}; use min/max"
                )
            lo, hi = spec.get("min"), spec.get("max")
        else:
            lo, hi = None, spec
        for bound in (lo, hi):
            if bound is not None and (
                isinstance(bound, bool) or not isinstance(bound, (int, float))
            ):
                raise TypeError(f"datasheet limit of {name!r} must be a number, got {bound!r}")
        if lo is None and hi is None:
            raise ValueError(f"datasheet entry {name!r} gives neither min nor max")
        limits[str(name)] = (
            None if lo is None else float(lo),
            None if hi is None else float(hi),
        )
    return limits


def load_datasheet(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a datasheet from JSON (``.json``) or YAML (``.yaml``/``.yml``, the ``yaml`` extra)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError as exc:
        raise InputError("datasheet not found; check the path", path=str(p)) from exc
    if p.suffix.lower() in (".yaml", ".yml"):
        try:
            import yaml
        except ImportError as exc:  # pragma: no cover - yaml is installed in the dev env
            raise ImportError("YAML datasheets need pyyaml: pip install 'allanite[yaml]'") from exc
        data = yaml.safe_load(text)
    else:
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"not valid JSON ({exc.msg})", path=str(p), line=exc.lineno) from exc
    if not isinstance(data, dict):
        raise InputError("a datasheet is a mapping like {'N': 0.01, 'B': 0.003}", path=str(p))
    _limits(data)  # validate now, with the file name in the message
    return data


@dataclass(frozen=True)
class BatchResult:
    """One row per record and channel: coefficients, checks against the datasheet, errors.

    Attributes
    ----------
    columns : tuple of str
        Column names: ``record, channel, n_samples, fs, units``, the coefficient names,
        ``pass_<name>`` per datasheet entry, ``pass`` and ``error``.
    rows : tuple of tuple
        The table (None where a value does not exist).
    datasheet : dict
        The limits used, ``{name: (min, max)}``.
    """

    columns: tuple[str, ...]
    rows: tuple[tuple[Any, ...], ...]
    datasheet: dict[str, Limit] = field(default_factory=dict)

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
            "datasheet": {k: list(v) for k, v in self.datasheet.items()},
        }

    def to_json(self, **kwargs: Any) -> str:
        """JSON text of :meth:`to_dict`."""
        return json.dumps(self.to_dict(), **kwargs)

    def to_frame(self) -> Any:
        """Return a :class:`pandas.DataFrame` of the table (needs the ``pandas`` extra)."""
        try:
            import pandas as pd
        except ImportError as exc:  # pragma: no cover - pandas is in the dev env
            raise ImportError("to_frame() needs pandas: pip install 'allanite[pandas]'") from exc
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


@dataclass(frozen=True)
class _Task:
    """Everything one record needs, picklable (sent to Dask workers)."""

    name: str
    source: Any
    fs: float | None
    avar_options: dict[str, Any]
    read_options: dict[str, Any]
    coefficients: Coefficients | None


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
        if source.fs is None:
            raise ValueError(f"{task.name}: sampling frequency unknown; pass fs=")
        names = tuple(source.channels) or tuple(str(i) for i in range(source.samples.shape[-1]))
        return source.samples, float(source.fs), source.input, source.units, names
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


def _analyse(task: _Task) -> list[dict[str, Any]]:
    """Rows of one record (module-level so that Dask can pickle it)."""
    from allanite.large import avar_large

    try:
        samples, fs, input_kind, units, names = _load(task)
        result = avar_large(samples, fs, input=input_kind, units=units, **task.avar_options)
    except (InputError, ValueError, TypeError, OSError) as exc:
        return [{"record": task.name, "channel": None, "error": " ".join(str(exc).split())}]
    reader = task.coefficients or curve_coefficients
    rows = []
    for c in range(result.n_channels):
        single = result.channel(c)
        values = {k: (None if v is None else float(v)) for k, v in reader(single).items()}
        rows.append(
            {
                "record": task.name,
                "channel": names[c] if c < len(names) else str(c),
                "n_samples": result.n_samples,
                "fs": result.fs,
                "units": units,
                "coefficients": values,
                "error": None,
            }
        )
    return rows


def _check(value: float | None, limit: Limit) -> bool:
    lo, hi = limit
    if value is None:
        return lo is None  # no sign of the term passes an upper limit
    return (lo is None or value >= lo) and (hi is None or value <= hi)


def _table(per_record: Sequence[list[dict[str, Any]]], limits: dict[str, Limit]) -> BatchResult:
    names: list[str] = []
    for rows in per_record:
        for row in rows:
            for key in row.get("coefficients", {}):
                if key not in names:
                    names.append(key)
    analysed = any("coefficients" in row for rows in per_record for row in rows)
    missing = [k for k in limits if k not in names]
    if analysed and missing:
        raise ValueError(
            f"datasheet names {missing} are not coefficients of the analysis ({', '.join(names)})"
        )
    columns = ["record", "channel", "n_samples", "fs", "units", *names]
    columns += [f"pass_{k}" for k in limits] + ["pass", "error"]
    table = []
    for rows in per_record:
        for row in rows:
            coeffs = row.get("coefficients", {})
            checks = [
                None if row["error"] else _check(coeffs.get(k), lim) for k, lim in limits.items()
            ]
            ok = row["error"] is None and all(bool(c) for c in checks)
            table.append(
                (
                    row["record"],
                    row["channel"],
                    row.get("n_samples"),
                    row.get("fs"),
                    row.get("units"),
                    *[coeffs.get(k) for k in names],
                    *checks,
                    ok,
                    row["error"],
                )
            )
    return BatchResult(tuple(columns), tuple(table), dict(limits))


def _name(item: Any, index: int) -> tuple[str, Any]:
    if isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str):
        return item[0], item[1]
    if isinstance(item, (str, os.PathLike)):
        return str(item), item
    source = getattr(item, "source", None)
    if isinstance(source, str) and source != "array":
        return source, item
    return f"record{index}", item


def batch(
    records: Iterable[Any],
    fs: float | None = None,
    *,
    datasheet: Mapping[str, Any] | str | os.PathLike[str] | None = None,
    coefficients: Coefficients | None = None,
    client: Any = None,
    kind: str = "overlapping",
    taus: Any = "log",
    points: int = 100,
    threads: int | None = None,
    memory_limit: int | float | str | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    **read_options: Any,
) -> BatchResult:
    """Analyse many records into one table of coefficients with pass/fail.

    Parameters
    ----------
    records : iterable
        File paths (read with :func:`allanite.io.readers.read_record` and ``read_options``),
        :class:`~allanite.io.record.Record` objects, arrays (``fs`` required), or
        ``(name, array_or_path)`` pairs.
    fs : float, optional
        Sampling frequency in Hz for arrays (and files without a time column).
    datasheet : mapping or path, optional
        Limits per coefficient (see the module docstring) or a JSON/YAML file of them.
    coefficients : callable, optional
        ``f(single_channel_result) -> {name: value}``; default :func:`curve_coefficients`.
    client : dask.distributed.Client, optional
        Run one task per record on this cluster (``pip install 'allanite[dask]'``); default:
        locally, in order.
    kind, taus, points, threads, memory_limit
        Passed to :func:`allanite.large.avar_large` for every record (``alpha`` is not
        identified: coefficients do not need the EDF, so ``alpha=0`` keeps a batch fast).
    progress : callable, optional
        ``progress("records", done, total)`` after each record (on the calling thread; the
        same signature as the ``progress`` of :func:`allanite.large.avar_large`).
    **read_options
        Reader options for paths (``input``, ``units``, ``columns``, ``scale``, ``dtype``,
        ...); ``input`` and ``units`` also describe arrays.

    Returns
    -------
    BatchResult
        The table; ``passed`` tells whether the whole lot passed.
    """
    limits = _limits(
        load_datasheet(datasheet) if isinstance(datasheet, (str, os.PathLike)) else datasheet
    )
    avar_options = {
        "kind": kind,
        "taus": taus,
        "points": points,
        "threads": threads,
        "memory_limit": memory_limit,
        "alpha": 0,
    }
    tasks = [
        _Task(name, source, fs, avar_options, dict(read_options), coefficients)
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
    return _table(results, limits)


def _run_dask(
    client: Any, tasks: list[_Task], progress: Callable[[str, int, int], None] | None
) -> list[list[dict[str, Any]]]:
    try:
        from distributed import as_completed
    except ImportError as exc:  # pragma: no cover - dask is in the dev env
        raise ImportError("batch(client=...) needs dask: pip install 'allanite[dask]'") from exc
    futures = client.map(_analyse, tasks, pure=False)
    index = {f.key: i for i, f in enumerate(futures)}
    out: list[list[dict[str, Any]] | None] = [None] * len(tasks)
    for done, fut in enumerate(as_completed(futures), start=1):
        out[index[fut.key]] = fut.result()
        if progress is not None:
            progress("records", done, len(tasks))
    return [rows for rows in out if rows is not None]
