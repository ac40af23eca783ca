"""Averaging-time grids: octave, decade, all, log-spaced (the original program's grid), explicit."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite import _core

__all__ = [
    "STOP_RATIO",
    "TauSpec",
    "averaging_factors",
    "log_grid",
    "max_factor",
    "stable32_max_factor",
]

TauSpec = str | ArrayLike | None

#: kinds accepted by the variance kernels (``time`` is derived from ``modified``)
KERNEL_KIND = {
    "overlapping": "overlapping",
    "standard": "standard",
    "modified": "modified",
    "time": "modified",
    "hadamard": "hadamard",
    "standard_hadamard": "standard_hadamard",
    "total": "total",
}

#: Stable32's stop ratios: its octave/decade/all grids end at ``m = N // ratio`` (N data points).
#: W. J. Riley, "The evolution of frequency stability analysis", Table III.
STOP_RATIO = {
    "overlapping": 4,
    "standard": 5,
    "modified": 4,
    "time": 4,
    "hadamard": 4,
    "standard_hadamard": 5,
    "total": 2,
}


def stable32_max_factor(kind: str, n_samples: int, n_phase: int) -> int:
    """Largest factor of the named grids: Stable32's ``N // stop_ratio``, within the kernel's limit.

    Parameters
    ----------
    kind : str
        Variance kind.
    n_samples : int
        Record length (data points as Stable32 counts them).
    n_phase : int
        Number of phase points (sets the kernel's own limit).

    Returns
    -------
    int
        ``max(1, min(n_samples // STOP_RATIO[kind], max_factor(kind, n_phase)))``.
    """
    return max(1, min(n_samples // STOP_RATIO[kind], max_factor(kind, n_phase)))


def max_factor(kind: str, n_phase: int) -> int:
    """Largest averaging factor ``m`` that ``kind`` supports for ``n_phase`` phase points."""
    return int(_core.max_m(KERNEL_KIND[kind], n_phase))


def log_grid(n_samples: int, points: int) -> NDArray[np.int64]:
    """Log-spaced factors of the original MATLAB program.

    ``m = unique(ceil(logspace(0, log10(2**floor(log2(N/2))), P)))``.

    Parameters
    ----------
    n_samples : int
        Record length ``N``.
    points : int
        Number of grid points ``P`` before removing duplicates.

    Returns
    -------
    numpy.ndarray
        Sorted unique integer averaging factors.
    """
    if points < 2:
        raise ValueError(f"points must be at least 2, got {points}")
    top = 2.0 ** np.floor(np.log2(n_samples / 2))
    # clip: logspace's last value can round a hair above top, and ceil would then exceed it
    grid = np.minimum(np.ceil(np.logspace(0, np.log10(top), points)), top)
    return np.unique(grid).astype(np.int64)


#: samples x averaging times a ``taus="all"`` grid may cost (each tau is one pass over the
#: record): 2e10 is some tens of seconds; 2e6 samples (4e5 taus, 8e11) took hours
ALL_COST_LIMIT = 2e10


def _check_all_cost(n_taus: int, n_samples: int) -> None:
    """Refuse an ``all`` grid whose cost (one pass over the record per tau) is hours."""
    cost = float(n_taus) * float(n_samples)
    if cost <= ALL_COST_LIMIT:
        return
    longest = int(ALL_COST_LIMIT // max(n_samples, 1))
    raise ValueError(
        f"taus 'all' gives {n_taus:,} averaging times on {n_samples:,} samples: one pass over "
        f"the record each, about {cost:.1e} sample operations (hours; the cap is "
        f"{ALL_COST_LIMIT:.0e}, about {longest:,} taus at this length); use the 'log' grid "
        "with more points (CLI: --points 1000), 'octave'/'decade', or explicit taus"
    )


def averaging_factors(
    spec: TauSpec,
    *,
    fs: float,
    n_samples: int,
    n_phase: int,
    kind: str,
    m: ArrayLike | None = None,
    points: int = 100,
) -> NDArray[np.int64]:
    """Resolve a tau specification to sorted, unique, admissible averaging factors.

    Parameters
    ----------
    spec : {"octave", "decade", "all", "log"} or array_like of float or None
        Named grid or explicit averaging times in seconds (rounded to whole samples).
        ``octave`` (1, 2, 4, ...), ``decade`` (1, 2, 4, 10, 20, 40, ...) and ``all`` end where
        Stable32 ends them (:func:`stable32_max_factor`); ``log`` (the original program's grid)
        and explicit factors may go up to the kernel's limit :func:`max_factor`.
    fs : float
        Sampling frequency in Hz.
    n_samples, n_phase : int
        Record length and number of phase points.
    kind : str
        Variance kind (limits the largest factor).
    m : array_like of int, optional
        Explicit averaging factors; overrides ``spec``.
    points : int
        Number of points of the ``"log"`` grid.

    Returns
    -------
    numpy.ndarray
        Averaging factors, int64.

    Raises
    ------
    ValueError
        If the grid is empty or a requested tau is outside ``[1/fs, max]``.
    """
    top = max_factor(kind, n_phase)
    if top < 1:
        raise ValueError(
            f"record too short for kind={kind!r}: {n_samples} samples give no averaging time; "
            "record at least 3 samples (more for modified/hadamard)"
        )
    if m is not None:
        factors = np.asarray(m)
        if factors.size == 0:
            raise ValueError("m is empty; give at least one averaging factor")
        if not np.issubdtype(factors.dtype, np.integer) and (
            not np.all(np.isfinite(factors)) or np.any(factors != np.round(factors))
        ):
            raise ValueError("m must hold whole numbers of samples (averaging factors)")
        factors = np.unique(factors.astype(np.int64))
    elif spec is None or isinstance(spec, str):
        name = "log" if spec is None else spec
        if name == "octave":
            factors = 2 ** np.arange(int(np.floor(np.log2(top))) + 1, dtype=np.int64)
        elif name == "decade":
            decades = 10 ** np.arange(int(np.floor(np.log10(top))) + 1, dtype=np.int64)
            factors = np.unique(np.outer(decades, [1, 2, 4]).ravel())
        elif name == "all":
            factors = np.arange(1, top + 1, dtype=np.int64)
        elif name == "log":
            factors = log_grid(n_samples, points)
        else:
            raise ValueError(
                f"unknown tau grid {name!r}; use 'octave', 'decade', 'all', 'log' or an array "
                "of averaging times in seconds"
            )
        limit = top if name == "log" else stable32_max_factor(kind, n_samples, n_phase)
        factors = factors[factors <= limit]
        if name == "all":
            _check_all_cost(factors.size, n_samples)
    else:
        taus = np.asarray(spec, dtype=np.float64).ravel()
        if taus.size == 0:
            raise ValueError("taus is empty; give at least one averaging time in seconds")
        if not np.all(np.isfinite(taus)) or np.any(taus <= 0):
            raise ValueError("taus must be positive, finite averaging times in seconds")
        factors = np.unique(np.round(taus * fs).astype(np.int64))
    if factors.size == 0:
        raise ValueError(f"the tau grid is empty for a record of {n_samples} samples")
    if factors[0] < 1:
        raise ValueError(
            f"averaging time {factors[0] / fs:g} s is shorter than one sample (1/fs = {1 / fs:g} s)"
        )
    if factors[-1] > top:
        raise ValueError(
            f"averaging time {factors[-1] / fs:g} s (m = {factors[-1]}) exceeds the longest that "
            f"kind={kind!r} supports for this record, {top / fs:g} s (m = {top}); "
            "drop the longer taus or record longer"
        )
    return factors
