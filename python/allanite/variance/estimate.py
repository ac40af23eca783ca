"""Allan-family variances of a record: :func:`avar` and its named deviations.

The numeric work runs in :mod:`allanite._core` (compensated prefix sums, then one O(N) pass per
averaging factor, threaded over factors); this module validates the input, resolves the tau
grid, identifies the noise type and attaches equivalent degrees of freedom. Records larger than
memory (a ``memory_limit``, a file path or a chunked record) go to
:func:`allanite.variance.outofcore.avar_large`; everything else stays in memory.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from allanite import _core
from allanite._deprecation import keyword_only_fs
from allanite.io.record import Record
from allanite.units import record_rate_unit
from allanite.variance.checks import (
    INPUTS,
    KINDS,
    InputKind,
    Kind,
    check_threads,
    given_alpha,
    prepare_record,
    resolve_source,
)
from allanite.variance.chunked import ChunkedRecord
from allanite.variance.edf import identify_alpha, smooth_isolated_alpha, wants_identification
from allanite.variance.kernel import ProgressCallback, fast_q, variances
from allanite.variance.outofcore import avar_large
from allanite.variance.result import AllanResult, assemble_result
from allanite.variance.taus import KERNEL_KIND, TauSpec, averaging_factors

__all__ = ["adev", "avar", "hdev", "mdev", "oadev", "ohdev", "tdev", "totdev"]


@keyword_only_fs
def avar(
    x: ArrayLike | Record | ChunkedRecord | str | os.PathLike[str],
    *,
    fs: float | None = None,
    input: InputKind | None = None,
    kind: Kind = "overlapping",
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    progress: ProgressCallback | None = None,
    fast: bool | int = False,
) -> AllanResult:
    r"""Allan-family variance of a record for a grid of averaging times.

    For rate samples :math:`y_k` the phase is :math:`x_k = \sum_{i<k} y_i` (compensated, mean
    removed) and the overlapping Allan variance is

    .. math:: \sigma^2(\tau) = \frac{1}{2\tau^2(M-2m)}\sum_{k=0}^{M-2m-1}
              (x_{k+2m} - 2x_{k+m} + x_k)^2 \,\tau_0^2,\qquad \tau = m\tau_0,

    (NIST SP1065 eq. 11). Angle input uses the angle itself as the phase (the integrating-gyro
    case); increment input integrates the angle increments.

    Parameters
    ----------
    x : array_like, Record, ChunkedRecord or path
        Samples, shape ``(N,)`` or ``(N, C)`` (samples, channels); float64, float32, int16,
        int32 or int64 (strided views are read without a copy). Or a
        :class:`~allanite.io.Record` (from :func:`allanite.read_record`), which brings its own
        ``fs``, ``input`` and unit (its longest segment is analysed when a time column split
        it). A file path or chunked record goes to :func:`avar_large` (read in chunks).
    fs : float
        Sampling frequency in Hz, keyword only; required for raw samples, taken from a Record.
    input : {"rate", "increment", "angle"}
        Rate samples, angle increments per sample, or angle (default ``"rate"``; a Record's
        own for a Record).
    kind : {"overlapping", "standard", "modified", "hadamard", "standard_hadamard", "total", \
"time"}
        Estimator. ``time`` is the time variance :math:`\tau^2\,\mathrm{MVAR}/3`.
    taus : {"log", "octave", "decade", "all"} or array_like
        Tau grid, or explicit averaging times in seconds. ``"log"`` is the original program's
        grid ``unique(ceil(logspace(0, log10(2^floor(log2(N/2))), points)))``.
    m : array_like of int, optional
        Explicit averaging factors (overrides ``taus``).
    points : int
        Number of points of the ``"log"`` grid.
    alpha : int or array_like, optional
        Power-law noise exponent (2 white PM ... -2 random walk FM, down to -4 for the Hadamard
        kinds) for the EDF: a scalar, one per tau, or ``(taus, channels)``. When omitted it is
        identified from the data at every tau as Stable32 does (lag-1 autocorrelation with at
        least 30 decimated points, else the B1 ratio and R(n);
        :func:`~allanite.variance.edf.identify_alpha`),
        then an isolated flip between two agreeing neighbours is replaced by their exponent
        (:func:`~allanite.variance.edf.smooth_isolated_alpha`) so the intervals do not jump at one
        tau.
        ``alpha="stable32"`` keeps Stable32's per-tau identification, flips included.
        The EDF follows Greenhall & Riley (2003) for every kind but ``total``, which uses the
        SP1065 formulas (:mod:`allanite.variance.edf`).
    threads : int, optional
        Worker threads (default: all cores). Results are identical for any thread count.
    units : str, optional
        Unit of the record, carried into the result as its rate unit: an angular rate
        (``deg/s``, ``deg/h``, ``dph``, ``rad/s``, ...) or an acceleration (``m/s^2``, ``g``,
        ``mg``, ``ug``, ...); for angle/increment samples also their angle (``deg``) or
        velocity (``m/s``), read as that unit per second. Checked by
        :func:`allanite.units.record_rate_unit` (a unit that is not one of these raises).
    memory_limit, progress, fast
        Large records (:func:`allanite.variance.avar_large`, which also reads files in chunks):
        a working-memory budget like ``"1GB"`` beyond which the phase array goes to a
        temporary file; a ``progress(stage, done, total)`` callback; fast mode (strided sums
        at large m with a stated error bound, :mod:`~allanite.variance.fast`). Same results
        otherwise.

    Returns
    -------
    AllanResult
        Variances, EDF and confidence intervals.

    References
    ----------
    W. J. Riley, *Handbook of Frequency Stability Analysis*, NIST SP1065 (2008).
    """
    # an array is never a chunked record: skip the slow structural (Protocol) check for it
    large_source = not isinstance(x, np.ndarray) and isinstance(
        x, (str, os.PathLike, ChunkedRecord)
    )
    if memory_limit is not None or large_source:
        return avar_large(
            x,
            fs=fs,
            input=input,
            kind=kind,
            taus=taus,
            m=m,
            points=points,
            alpha=alpha,
            threads=threads,
            units=units,
            memory_limit=memory_limit,
            progress=progress,
            fast=fast,
        )
    samples, rate, what, units, meta = resolve_source(x, fs, input, units)
    units = record_rate_unit(units, what)  # one validation of the unit, for every caller
    if kind not in KERNEL_KIND:
        raise ValueError(f"unknown kind {kind!r}; use one of {', '.join(KINDS)}")
    if what not in INPUTS:
        raise ValueError(f"unknown input {what!r}; use 'rate', 'increment' or 'angle'")
    nthreads = check_threads(threads)
    q = fast_q(fast)
    arr, was_1d = prepare_record(samples)
    phase = _core.phase(arr, what, nthreads)
    n_phase = int(phase.shape[0])
    if progress is not None:
        progress("phase", arr.shape[0], arr.shape[0])
    factors = averaging_factors(
        taus, fs=rate, n_samples=arr.shape[0], n_phase=n_phase, kind=kind, m=m, points=points
    )
    kernel_kind = KERNEL_KIND[kind]
    var = variances(
        phase, factors, kernel_kind, threads=nthreads, progress=progress, q=q, meta=meta
    )
    if wants_identification(alpha):
        # Stable32 identifies phase data on the phase as recorded (its frequency offset makes
        # the lag-1 method difference at least once); frequency data on the averaged rates
        if what == "angle":
            alphas = identify_alpha(
                arr, factors, kernel_kind, data="phase", detrended=phase, threads=nthreads
            )
        else:
            alphas = identify_alpha(phase, factors, kernel_kind, data="frequency", threads=nthreads)
        if alpha is None:
            alphas = smooth_isolated_alpha(alphas, factors)
    else:
        alphas = given_alpha(alpha, var.shape)
    return assemble_result(
        var,
        factors,
        alphas,
        rate=rate,
        input=what,
        kind=kind,
        n_phase=n_phase,
        n_samples=int(arr.shape[0]),
        units=units,
        was_1d=was_1d,
        meta=meta,
    )


def _named(kind: Kind, arguments: dict[str, Any]) -> AllanResult:
    """:func:`avar` of ``kind`` with a named deviation's arguments (its ``locals()``)."""
    options = dict(arguments)
    return avar(options.pop("x"), kind=kind, **options)


@keyword_only_fs
def adev(
    x: ArrayLike | Record | ChunkedRecord | str | os.PathLike[str],
    *,
    fs: float | None = None,
    input: InputKind | None = None,
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    progress: ProgressCallback | None = None,
    fast: bool | int = False,
) -> AllanResult:
    """Non-overlapping Allan deviation of a record: :func:`avar` with ``kind="standard"``.

    NIST SP1065 eq. 7: adjacent, non-overlapping differences.

    Parameters
    ----------
    x, fs, input, taus, m, points, alpha, threads, units, memory_limit, progress, fast
        As for :func:`avar` (``fs`` keyword only, required for raw samples, taken from a
        :class:`~allanite.io.Record`).

    Returns
    -------
    AllanResult
        The variance in ``var``; the deviation is ``result.dev`` and its confidence interval
        ``result.ci(level)``.
    """
    return _named("standard", locals())


@keyword_only_fs
def oadev(
    x: ArrayLike | Record | ChunkedRecord | str | os.PathLike[str],
    *,
    fs: float | None = None,
    input: InputKind | None = None,
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    progress: ProgressCallback | None = None,
    fast: bool | int = False,
) -> AllanResult:
    """Overlapping Allan deviation of a record: :func:`avar` with ``kind="overlapping"``.

    NIST SP1065 eq. 11: all overlapping second differences.

    Parameters
    ----------
    x, fs, input, taus, m, points, alpha, threads, units, memory_limit, progress, fast
        As for :func:`avar` (``fs`` keyword only, required for raw samples, taken from a
        :class:`~allanite.io.Record`).

    Returns
    -------
    AllanResult
        The variance in ``var``; the deviation is ``result.dev`` and its confidence interval
        ``result.ci(level)``.
    """
    return _named("overlapping", locals())


@keyword_only_fs
def mdev(
    x: ArrayLike | Record | ChunkedRecord | str | os.PathLike[str],
    *,
    fs: float | None = None,
    input: InputKind | None = None,
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    progress: ProgressCallback | None = None,
    fast: bool | int = False,
) -> AllanResult:
    """Modified Allan deviation of a record: :func:`avar` with ``kind="modified"``.

    NIST SP1065 eq. 14: second differences of phase averages over m.

    Parameters
    ----------
    x, fs, input, taus, m, points, alpha, threads, units, memory_limit, progress, fast
        As for :func:`avar` (``fs`` keyword only, required for raw samples, taken from a
        :class:`~allanite.io.Record`).

    Returns
    -------
    AllanResult
        The variance in ``var``; the deviation is ``result.dev`` and its confidence interval
        ``result.ci(level)``.
    """
    return _named("modified", locals())


@keyword_only_fs
def hdev(
    x: ArrayLike | Record | ChunkedRecord | str | os.PathLike[str],
    *,
    fs: float | None = None,
    input: InputKind | None = None,
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    progress: ProgressCallback | None = None,
    fast: bool | int = False,
) -> AllanResult:
    """Non-overlapping Hadamard deviation: :func:`avar` with ``kind="standard_hadamard"``.

    NIST SP1065 eq. 17: third differences, insensitive to a linear drift of the rate.

    Parameters
    ----------
    x, fs, input, taus, m, points, alpha, threads, units, memory_limit, progress, fast
        As for :func:`avar` (``fs`` keyword only, required for raw samples, taken from a
        :class:`~allanite.io.Record`).

    Returns
    -------
    AllanResult
        The variance in ``var``; the deviation is ``result.dev`` and its confidence interval
        ``result.ci(level)``.
    """
    return _named("standard_hadamard", locals())


@keyword_only_fs
def ohdev(
    x: ArrayLike | Record | ChunkedRecord | str | os.PathLike[str],
    *,
    fs: float | None = None,
    input: InputKind | None = None,
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    progress: ProgressCallback | None = None,
    fast: bool | int = False,
) -> AllanResult:
    """Overlapping Hadamard deviation of a record: :func:`avar` with ``kind="hadamard"``.

    NIST SP1065 eq. 18: all overlapping third differences.

    Parameters
    ----------
    x, fs, input, taus, m, points, alpha, threads, units, memory_limit, progress, fast
        As for :func:`avar` (``fs`` keyword only, required for raw samples, taken from a
        :class:`~allanite.io.Record`).

    Returns
    -------
    AllanResult
        The variance in ``var``; the deviation is ``result.dev`` and its confidence interval
        ``result.ci(level)``.
    """
    return _named("hadamard", locals())


@keyword_only_fs
def tdev(
    x: ArrayLike | Record | ChunkedRecord | str | os.PathLike[str],
    *,
    fs: float | None = None,
    input: InputKind | None = None,
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    progress: ProgressCallback | None = None,
    fast: bool | int = False,
) -> AllanResult:
    """Time deviation of a record: :func:`avar` with ``kind="time"``.

    ``tau * mdev / sqrt(3)`` (NIST SP1065 eq. 15).

    Parameters
    ----------
    x, fs, input, taus, m, points, alpha, threads, units, memory_limit, progress, fast
        As for :func:`avar` (``fs`` keyword only, required for raw samples, taken from a
        :class:`~allanite.io.Record`).

    Returns
    -------
    AllanResult
        The variance in ``var``; the deviation is ``result.dev`` and its confidence interval
        ``result.ci(level)``.
    """
    return _named("time", locals())


@keyword_only_fs
def totdev(
    x: ArrayLike | Record | ChunkedRecord | str | os.PathLike[str],
    *,
    fs: float | None = None,
    input: InputKind | None = None,
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    progress: ProgressCallback | None = None,
    fast: bool | int = False,
) -> AllanResult:
    """Total deviation of a record: :func:`avar` with ``kind="total"``.

    NIST SP1065 eq. 25: overlapping differences on the reflected extension of the record.

    Parameters
    ----------
    x, fs, input, taus, m, points, alpha, threads, units, memory_limit, progress, fast
        As for :func:`avar` (``fs`` keyword only, required for raw samples, taken from a
        :class:`~allanite.io.Record`).

    Returns
    -------
    AllanResult
        The variance in ``var``; the deviation is ``result.dev`` and its confidence interval
        ``result.ci(level)``.
    """
    return _named("total", locals())
