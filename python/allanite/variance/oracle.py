"""Slow, obviously-correct numpy versions of every compiled kernel: the test oracle.

Nothing here is optimised; every function follows its textbook definition with explicit
numpy slicing so that it can be read against NIST SP1065 (Riley, *Handbook of Frequency
Stability Analysis*, 2008). The compiled kernels in :mod:`allanite._core` must agree with these
to rounding (the tests check 1e-12 relative).

All variance functions take a 1-D phase array ``x`` (``M`` points, tau0 = 1) and an averaging
factor ``m`` and return the variance in phase units per sample squared.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "hadamard_variance",
    "modified_variance",
    "overlapping_variance",
    "phase_from_record",
    "standard_hadamard_variance",
    "standard_variance",
    "total_variance",
    "variance",
]


def phase_from_record(x: ArrayLike, input: str = "rate") -> NDArray[np.float64]:
    """Detrended phase of a 1-D record, as the compiled ``phase`` kernel computes it.

    Parameters
    ----------
    x : array_like
        Samples of rate, angle increments or angle.
    input : {"rate", "increment", "angle"}
        ``rate``/``increment``: ``[0, cumsum(x - mean(x))]`` (``M = N + 1`` points).
        ``angle``: ``x`` minus its least-squares line (``M = N`` points).

    Returns
    -------
    numpy.ndarray
        The phase array, float64.
    """
    y = np.asarray(x, dtype=np.float64)
    if input in ("rate", "increment"):
        return np.concatenate(([0.0], np.cumsum(y - y.mean())))
    if input == "angle":
        k = np.arange(y.size, dtype=np.float64)
        slope, intercept = np.polyfit(k, y, 1)
        return np.asarray(y - (intercept + slope * k), dtype=np.float64)
    raise ValueError(f"unknown input kind {input!r}")


def _d2(x: NDArray[np.float64], m: int) -> NDArray[np.float64]:
    """Second differences x[k+2m] - 2 x[k+m] + x[k] for every admissible k."""
    n = x.size - 2 * m
    return x[2 * m : 2 * m + n] - 2.0 * x[m : m + n] + x[:n]


def _d3(x: NDArray[np.float64], m: int) -> NDArray[np.float64]:
    """Third differences x[k+3m] - 3 x[k+2m] + 3 x[k+m] - x[k]."""
    n = x.size - 3 * m
    return x[3 * m : 3 * m + n] - 3.0 * x[2 * m : 2 * m + n] + 3.0 * x[m : m + n] - x[:n]


def overlapping_variance(x: NDArray[np.float64], m: int) -> float:
    """Overlapping Allan variance, SP1065 eq. (11): mean(d2^2) / (2 m^2)."""
    d = _d2(x, m)
    return float(np.mean(d**2) / (2.0 * m**2))


def standard_variance(x: NDArray[np.float64], m: int) -> float:
    """Non-overlapping Allan variance, SP1065 eq. (7): d2 at k = 0, m, 2m, ..."""
    d = _d2(x, m)[::m]
    n = (x.size - 1) // m - 1
    return float(np.sum(d[:n] ** 2) / (2.0 * m**2 * n))


def modified_variance(x: NDArray[np.float64], m: int) -> float:
    """Return the modified Allan variance, SP1065 eq. (14): windows of m second differences."""
    d = _d2(x, m)
    n = x.size - 3 * m + 1
    windows = np.array([np.sum(d[j : j + m]) for j in range(n)])
    return float(np.sum(windows**2) / (2.0 * m**4 * n))


def hadamard_variance(x: NDArray[np.float64], m: int) -> float:
    """Overlapping Hadamard variance, SP1065 eq. (20): mean(d3^2) / (6 m^2)."""
    d = _d3(x, m)
    return float(np.mean(d**2) / (6.0 * m**2))


def standard_hadamard_variance(x: NDArray[np.float64], m: int) -> float:
    """Non-overlapping Hadamard variance: d3 at k = 0, m, 2m, ..."""
    n = (x.size - 1) // m - 2
    d = _d3(x, m)[::m][:n]
    return float(np.sum(d**2) / (6.0 * m**2 * n))


def total_variance(x: NDArray[np.float64], m: int) -> float:
    """Total variance, SP1065 eq. (25), with the point-reflected extension of the phase.

    ``x*[-j] = 2 x[0] - x[j]`` and ``x*[M-1+j] = 2 x[M-1] - x[M-1-j]`` for ``1 <= j <= M-2``.
    """
    big_m = x.size
    left = 2.0 * x[0] - x[big_m - 2 : 0 : -1]  # x*[-(M-2)] .. x*[-1]
    right = 2.0 * x[-1] - x[big_m - 2 : 0 : -1]  # x*[M] .. x*[2M-3]
    ext = np.concatenate((left, x, right))
    off = big_m - 2
    i = np.arange(1, big_m - 1)
    d = ext[off + i - m] - 2.0 * ext[off + i] + ext[off + i + m]
    return float(np.sum(d**2) / (2.0 * m**2 * (big_m - 2)))


_KERNELS = {
    "overlapping": overlapping_variance,
    "standard": standard_variance,
    "modified": modified_variance,
    "hadamard": hadamard_variance,
    "standard_hadamard": standard_hadamard_variance,
    "total": total_variance,
}


def variance(x: ArrayLike, m: ArrayLike, kind: str, input: str = "rate") -> NDArray[np.float64]:
    """Return the reference variance of a record for each averaging factor, every channel.

    Parameters
    ----------
    x : array_like
        Record, shape ``(N,)`` or ``(N, C)``.
    m : array_like of int
        Averaging factors.
    kind : str
        One of ``overlapping``, ``standard``, ``modified``, ``hadamard``,
        ``standard_hadamard``, ``total``.
    input : {"rate", "increment", "angle"}
        Meaning of the samples (see :func:`phase_from_record`).

    Returns
    -------
    numpy.ndarray
        Variances in sample units (tau0 = 1), shape ``(len(m), C)`` (or ``(len(m),)`` for 1-D
        input).
    """
    arr = np.asarray(x)
    cols = arr.reshape(arr.shape[0], -1)
    ms = np.atleast_1d(np.asarray(m, dtype=np.int64))
    kernel = _KERNELS[kind]
    out = np.empty((ms.size, cols.shape[1]))
    for c in range(cols.shape[1]):
        ph = phase_from_record(cols[:, c], input)
        out[:, c] = [kernel(ph, int(mi)) for mi in ms]
    return out[:, 0] if arr.ndim == 1 else out
