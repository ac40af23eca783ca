r"""netCDF files read directly: classic (``CDF\x01``, ``CDF\x02``) and netCDF-4 (HDF5).

Classic files are read with :class:`scipy.io.netcdf_file` (scipy is a core dependency),
netCDF-4 files, which are HDF5 files, with ``h5py`` (extra ``[hdf5]``). A netCDF record is a
set of variables along one record dimension (``time``): the table has one column per 1-D
variable along it and ``name[i]`` columns for a 2-D ``(time, k)`` variable, like a CSV file,
so ``--channels``, ``--time-column`` and ``--temperature`` name variables. ``key`` (CLI
``--key``) picks one variable as the samples. The coordinate variable of the record dimension
(``time(time)``) becomes the time column when its units are a time (``s``, ``hours since
...``), unless a time column or ``fs`` is given. A temperature variable on a dimension of its
own (a slower logger with its own time coordinate) is resampled onto the sample times.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.errors import InputError
from allanite.extras import require

__all__ = ["CDF5_REFUSED", "CLASSIC_MAGIC", "NetcdfTable", "load_netcdf", "netcdf_kind"]

#: the first bytes of a classic (CDF-1) and 64-bit offset (CDF-2) netCDF file
CLASSIC_MAGIC = (b"CDF\x01", b"CDF\x02")
#: the first bytes of a CDF-5 (64-bit data) file, and why it is refused
CDF5_MAGIC = b"CDF\x05"
CDF5_REFUSED = (
    "a netCDF CDF-5 (64-bit data) file, which is not read here; convert it to netCDF-4 "
    "(nccopy -k nc4 IN OUT) or classic (nccopy -k classic IN OUT)"
)
#: the first bytes of an HDF5 file (netCDF-4)
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
#: netCDF-4 (HDF5) bookkeeping datasets that are dimensions, not variables
_DIMENSION_ONLY = b"This is a netCDF dimension but not a netCDF variable"
#: seconds per unit of a time coordinate (``units = "hours since 2020-01-01"``)
_TIME_UNITS = {
    "s": 1.0,
    "sec": 1.0,
    "secs": 1.0,
    "second": 1.0,
    "seconds": 1.0,
    "ms": 1e-3,
    "milliseconds": 1e-3,
    "us": 1e-6,
    "microseconds": 1e-6,
    "ns": 1e-9,
    "nanoseconds": 1e-9,
    "min": 60.0,
    "minute": 60.0,
    "minutes": 60.0,
    "h": 3600.0,
    "hour": 3600.0,
    "hours": 3600.0,
    "day": 86400.0,
    "days": 86400.0,
}


@dataclass(frozen=True)
class _Variable:
    name: str
    dims: tuple[str, ...]
    shape: tuple[int, ...]
    units: str | None
    read: Callable[[], NDArray[Any]]


@dataclass(frozen=True)
class NetcdfTable:
    """The table of a netCDF file and the time column its coordinate variable offers."""

    data: NDArray[np.float64]
    names: tuple[str, ...]
    time: tuple[str, float] | None  # (column, seconds per unit) of the time coordinate
    notes: tuple[str, ...] = ()


def netcdf_kind(path: Path) -> bool:
    """True for a classic netCDF file, False for netCDF-4 (HDF5); else an InputError."""
    with path.open("rb") as handle:
        head = handle.read(8)
    if head.startswith(CLASSIC_MAGIC):
        return True
    if head.startswith(HDF5_MAGIC):
        return False
    if head.startswith(CDF5_MAGIC):
        raise InputError(CDF5_REFUSED, path=str(path))
    raise InputError(
        f"not a netCDF file: it starts with {head[:4]!r}, not CDF\\x01, CDF\\x02 or the HDF5 "
        "signature of netCDF-4; give its format (--format)",
        path=str(path),
    )


def time_scale(units: str | None) -> float | None:
    """Seconds per unit of a time coordinate's ``units`` attribute, or None if not a time."""
    if not units:
        return None
    word = re.split(r"\s+since\s+", units.strip(), maxsplit=1)[0].strip().lower()
    return _TIME_UNITS.get(word)


def _decoded(data: NDArray[Any], attrs: dict[str, Any]) -> NDArray[np.float64]:
    """Values with ``_FillValue`` as nan and ``scale_factor``/``add_offset`` applied (CF)."""
    values = np.asarray(data, dtype=np.float64)
    fill = attrs.get("_FillValue", attrs.get("missing_value"))
    if fill is not None:
        values = np.where(
            values == np.asarray(fill, dtype=np.float64).reshape(-1)[0], np.nan, values
        )
    scale = attrs.get("scale_factor")
    offset = attrs.get("add_offset")
    if scale is not None:
        values = values * float(np.asarray(scale).reshape(-1)[0])
    if offset is not None:
        values = values + float(np.asarray(offset).reshape(-1)[0])
    return values


def _text(value: Any) -> str | None:
    if value is None:
        return None
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.dtype.kind in "SU":
        return str(value.reshape(-1)[0])
    return str(value)


def _classic_variables(path: Path) -> tuple[list[_Variable], set[str]]:
    from scipy.io import netcdf_file

    handle = netcdf_file(path, "r", mmap=False)
    out = []
    with handle:
        unlimited = {n for n, size in handle.dimensions.items() if size is None}
        for name, var in handle.variables.items():
            attrs = dict(var._attributes)
            data = _decoded(var.data, attrs) if var.data.dtype.kind in "iuf" else None
            out.append(
                _Variable(
                    name=name,
                    dims=tuple(var.dimensions),
                    shape=tuple(var.shape),
                    units=_text(attrs.get("units")),
                    read=_not_numeric(name) if data is None else _constant(data),
                )
            )
    return out, unlimited


def _constant(data: NDArray[np.float64]) -> Callable[[], NDArray[np.float64]]:
    return lambda: data


def _not_numeric(name: str) -> Callable[[], NDArray[Any]]:
    def fail() -> NDArray[Any]:
        raise InputError(f"netCDF variable {name!r} is not numeric; choose numeric variables")

    return fail


def _hdf5_variables(path: Path) -> tuple[list[_Variable], set[str]]:
    h5py = require("h5py", extra="hdf5", purpose="reading netCDF-4 (HDF5) files")
    out: list[_Variable] = []
    unlimited: set[str] = set()
    with h5py.File(path, "r") as handle:

        def visit(name: str, obj: Any) -> None:
            if not isinstance(obj, h5py.Dataset) or obj.dtype.names:
                return
            attrs = {k: obj.attrs[k] for k in obj.attrs}
            label = attrs.get("NAME")
            if isinstance(label, bytes) and label.startswith(_DIMENSION_ONLY):
                if obj.maxshape and obj.maxshape[0] is None:
                    unlimited.add(name)
                return
            dims = []
            for i, dim in enumerate(obj.dims):
                scale_name = dim[0].name.lstrip("/") if len(dim) else ""
                dims.append(scale_name or dim.label or f"{name}_dim{i}")
            if obj.maxshape and obj.maxshape[0] is None and dims:
                unlimited.add(dims[0])
            numeric = obj.dtype.kind in "iuf"
            data = _decoded(obj[()], attrs) if numeric else None
            out.append(
                _Variable(
                    name=name,
                    dims=tuple(dims),
                    shape=tuple(obj.shape),
                    units=_text(attrs.get("units")),
                    read=_not_numeric(name) if data is None else _constant(data),
                )
            )

        handle.visititems(visit)
    return out, unlimited


def _record_dim(variables: list[_Variable], key: str | None, unlimited: set[str]) -> str:
    """The record dimension: the key variable's first, the unlimited one, or the longest."""
    by_name = {v.name: v for v in variables}
    if key is not None:
        return by_name[key].dims[0]
    firsts = [v for v in variables if 1 <= len(v.shape) <= 2 and v.dims]
    if not firsts:
        raise InputError("the netCDF file has no 1-D or 2-D variable to read as samples")
    for v in firsts:
        if v.dims[0] in unlimited:
            return v.dims[0]
    return max(firsts, key=lambda v: v.shape[0]).dims[0]


def _columns(var: _Variable) -> tuple[list[NDArray[np.float64]], list[str]]:
    data = var.read()
    if data.ndim == 1:
        return [data], [var.name]
    if data.ndim != 2:
        raise InputError(
            f"netCDF variable {var.name!r} has {data.ndim} dimensions {var.dims}; choose a 1-D "
            "or a (time, k) variable with --key"
        )
    return [data[:, i] for i in range(data.shape[1])], [
        f"{var.name}[{i}]" for i in range(data.shape[1])
    ]


def _resampled(
    var: _Variable, by_name: dict[str, _Variable], dim: str, source: str
) -> NDArray[np.float64]:
    """A 1-D variable on another dimension, interpolated onto the record dimension's times."""
    here, there = by_name.get(dim), by_name.get(var.dims[0]) if var.dims else None
    if (
        var.dims
        and len(var.shape) == 1
        and here is not None
        and there is not None
        and time_scale(here.units) is not None
        and time_scale(there.units) is not None
        and _epoch(here.units) == _epoch(there.units)
    ):
        t_here = here.read() * (time_scale(here.units) or 1.0)
        t_there = there.read() * (time_scale(there.units) or 1.0)
        values = var.read()
        ok = np.isfinite(values) & np.isfinite(t_there)
        return np.asarray(np.interp(t_here, t_there[ok], values[ok]), dtype=np.float64)
    raise InputError(
        f"netCDF variable {var.name!r} lies along {var.dims or 'no dimension'}, not along the "
        f"record dimension {dim!r}, and no pair of time coordinates with the same epoch relates "
        "them; give a variable along the record dimension",
        path=source,
    )


def _epoch(units: str | None) -> str:
    parts = re.split(r"\s+since\s+", (units or "").strip(), maxsplit=1)
    return parts[1].strip() if len(parts) == 2 else ""


def load_netcdf(
    path: Path, *, key: str | None = None, wanted: Sequence[Any] = (), classic: bool = True
) -> NetcdfTable:
    """The table of a netCDF file along its record dimension.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    key : str, optional
        The variable that holds the samples (default: every variable along the record
        dimension is a column).
    wanted : sequence
        Other variables the reader options name (time column, temperature): added as columns
        when ``key`` is given, resampled onto the record's times when they lie along a
        dimension of their own.
    classic : bool
        A classic file (scipy) or a netCDF-4 one (h5py).

    Returns
    -------
    NetcdfTable
    """
    source = str(path)
    variables, unlimited = _classic_variables(path) if classic else _hdf5_variables(path)
    by_name = {v.name: v for v in variables}
    listing = ", ".join(f"{v.name}{v.dims}" for v in variables) or "none"
    for name in [key, *wanted]:
        if isinstance(name, str) and name not in by_name and not _is_column(name, by_name):
            raise InputError(f"no netCDF variable {name!r}; variables: {listing}", path=source)
    dim = _record_dim(variables, key, unlimited)
    n = next(v.shape[0] for v in variables if v.dims and v.dims[0] == dim)
    chosen = (
        [by_name[key]]
        if key is not None
        else [
            v
            for v in variables
            if v.dims and v.dims[0] == dim and v.name != dim and len(v.shape) <= 2
        ]
    )
    coordinate = by_name.get(dim)
    extra = [by_name[w] for w in wanted if isinstance(w, str) and w in by_name]
    columns: list[NDArray[np.float64]] = []
    names: list[str] = []
    for var in [*chosen, *(e for e in extra if e not in chosen)]:
        if var.dims and var.dims[0] == dim:
            cols, col_names = _columns(var)
        else:
            cols, col_names = [_resampled(var, by_name, dim, source)], [var.name]
        columns += cols
        names += col_names
    time = None
    if coordinate is not None and len(coordinate.shape) == 1:
        scale = time_scale(coordinate.units)
        if scale is not None:
            time = (coordinate.name, scale)
            if coordinate.name not in names:
                columns.append(coordinate.read())
                names.append(coordinate.name)
    if not columns:
        raise InputError(
            f"no variable along the record dimension {dim!r} ({n} records); variables: {listing}",
            path=source,
        )
    return NetcdfTable(np.column_stack(columns), tuple(names), time)


def _is_column(name: str, by_name: dict[str, _Variable]) -> bool:
    """Whether ``name`` is a column of a 2-D variable (``angular_velocity[2]``)."""
    match = re.fullmatch(r"(.+)\[(\d+)\]", name)
    return match is not None and match.group(1) in by_name
