"""Validation shared by the in-memory and out-of-core variance paths.

Records become 2-D ``(N, C)`` views of a dtype the compiled kernels read; the sampling frequency,
thread count and caller-given noise exponents are checked with errors that name the fix.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.errors import check_fs_range
from allanite.io.record import Record
from allanite.variance.taus import KERNEL_KIND

__all__ = [
    "INPUTS",
    "KINDS",
    "InputKind",
    "Kind",
    "check_fs",
    "check_threads",
    "given_alpha",
    "prepare_record",
    "resolve_source",
]

InputKind = Literal["rate", "increment", "angle"]
Kind = Literal[
    "overlapping", "standard", "modified", "hadamard", "standard_hadamard", "total", "time"
]
KINDS: tuple[str, ...] = tuple(KERNEL_KIND)
INPUTS: tuple[str, ...] = ("rate", "increment", "angle")

_ACCEPTED = (np.float64, np.float32, np.int16, np.int32, np.int64)


def prepare_record(x: ArrayLike, *, name: str = "x") -> tuple[NDArray[Any], bool]:
    """Validate a record and return it as a 2-D ``(N, C)`` view (no copy when possible).

    Parameters
    ----------
    x : array_like
        Record of shape ``(N,)`` or ``(N, C)``.
    name : str
        Name used in error messages.

    Returns
    -------
    tuple
        The 2-D array (dtype one of float64, float32, int16, int32, int64) and whether the
        input was 1-D.
    """
    arr = np.asarray(x)
    if arr.dtype == np.bool_ or not (
        np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)
    ):
        raise TypeError(
            f"{name} has dtype {arr.dtype}; give real numbers (float64, float32, int16, int32, "
            "int64)"
        )
    if arr.dtype.type not in _ACCEPTED:
        if np.issubdtype(arr.dtype, np.unsignedinteger) and arr.dtype.itemsize == 8:
            raise TypeError(
                f"{name} has dtype uint64, which may overflow; convert to int64 or float64"
            )
        arr = arr.astype(np.float64 if arr.dtype.kind == "f" else np.int64)
    if not arr.dtype.isnative:
        arr = arr.astype(arr.dtype.newbyteorder("="))
    if arr.ndim == 1:
        return arr.reshape(-1, 1), True
    if arr.ndim != 2:
        raise ValueError(
            f"{name} must be 1-D (samples) or 2-D (samples, channels), got shape {arr.shape}"
        )
    if arr.shape[0] < 3:
        raise ValueError(f"{name} is too short: {arr.shape[0]} samples; need at least 3")
    if arr.shape[0] < arr.shape[1]:
        raise ValueError(
            f"{name} has shape {arr.shape}: fewer samples than channels. Records are (samples, "
            "channels); pass x.T if your channels are rows"
        )
    return arr, False


def check_fs(fs: float) -> float:
    """Sampling frequency in Hz as a positive finite float, or a TypeError/ValueError."""
    try:
        value = float(fs)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"fs must be a number in Hz, got {fs!r}") from exc
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"fs must be a positive, finite sampling frequency in Hz, got {fs!r}")
    return check_fs_range(value)


def check_threads(threads: int | None) -> int:
    """Thread count for the compiled kernels: None is 0 (all cores), else a positive int."""
    if threads is None:
        return 0
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ValueError(f"threads must be a positive integer or None, got {threads!r}")
    return int(threads)


def given_alpha(alpha: int | ArrayLike | str | None, shape: tuple[int, ...]) -> NDArray[np.int64]:
    """Caller's noise exponents broadcast to ``(T, C)``: a scalar, one per tau, or per channel."""
    given = np.asarray(alpha)
    if given.dtype.kind not in "iuf" or not np.all(np.isfinite(given)):
        raise TypeError(f"alpha must be integers between -4 and 2, got {alpha!r}")
    if np.any(given != np.round(given)) or np.any(given < -4) or np.any(given > 2):
        raise ValueError(
            f"alpha must hold integer power-law exponents in [-4, 2] (2 white PM ... -2 random "
            f"walk FM), got {alpha!r}"
        )
    values = given.astype(np.int64)
    if values.ndim == 1:
        values = values.reshape(-1, 1)
    try:
        return np.asarray(np.broadcast_to(values, shape).copy(), dtype=np.int64)
    except ValueError:
        raise ValueError(
            f"alpha has shape {given.shape}; give a scalar, one value per tau ({shape[0]}) or a "
            f"(taus, channels) array {shape}"
        ) from None


def resolve_source(
    x: Any, fs: float | None, input: str | None, units: str | None
) -> tuple[Any, float, str, str | None, dict[str, Any]]:
    """Samples, sampling frequency, input kind, unit and metadata of a record or raw array.

    A :class:`~allanite.io.Record` carries its own ``fs``, ``input`` and unit: they are taken
    from it (its longest segment when a time column split it; one channel gives a 1-D record).
    Giving ``fs``, ``input`` or ``units`` as well is allowed only when it agrees with the
    record (or fills in an ``fs`` the record lacks). Anything else is a raw record, for which
    ``fs`` is required and ``input`` defaults to ``"rate"``.

    Raises
    ------
    TypeError
        Without ``fs`` for a raw record.
    ValueError
        When ``fs``, ``input`` or ``units`` contradict the record's own.
    """
    if isinstance(x, Record):
        part = x.longest_segment()
        meta: dict[str, Any] = {"source": x.source, "channels": list(x.channels)}
        if len(x.segments) > 1:
            meta["segment"] = x.segments.index(max(x.segments, key=lambda s: s.n_samples))
        if fs is not None and part.fs is not None and not np.isclose(fs, part.fs, rtol=1e-12):
            raise ValueError(
                f"fs={fs!r} contradicts the record's own fs={part.fs!r} Hz; leave fs out (it is "
                "taken from the Record) or build the Record with the right fs"
            )
        given = fs if fs is not None else part.require_fs()
        rate = check_fs(part.fs if part.fs is not None else given)
        if input is not None and input != part.input:
            raise ValueError(
                f"input={input!r} contradicts the record's input={part.input!r}; leave input out "
                "(it is taken from the Record)"
            )
        unit = part.rate_unit()
        if units is not None and unit is not None and units not in (part.units, unit):
            raise ValueError(
                f"units={units!r} contradicts the record's unit {part.units!r}; leave units out "
                "(it is taken from the Record)"
            )
        samples = part.samples if part.n_channels > 1 else part.samples[:, 0]
        return samples, rate, part.input, units if unit is None else unit, meta
    if fs is None:
        raise TypeError(
            "fs (the sampling frequency in Hz) is required for a raw array: e.g. "
            "avar(x, fs=100.0); a Record carries its own"
        )
    return x, check_fs(fs), "rate" if input is None else input, units, {}
