"""In-memory variance passes over a phase array: exact (optionally reporting progress) or fast.

Both :func:`allanite.variance.avar` (record in memory) and the out-of-core path
(:mod:`allanite.variance.outofcore`, when its phase store fits in memory) call these, so the
two give the same variances bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite import _core
from allanite.variance.edf import cap_few_point_alpha, identify_alpha
from allanite.variance.fast import DEFAULT_Q, fast_variance

__all__ = ["ProgressCallback", "fast_q", "identify_bounded", "series_points", "variances"]

#: progress(stage, done, total): stage "phase" counts samples x passes, "variance" counts taus
ProgressCallback = Callable[[str, int, int], None]


def fast_q(fast: bool | int | None) -> int | None:
    """Terms kept per factor in fast mode (:mod:`allanite.variance.fast`), or None for exact.

    ``False``/``None`` is exact, ``True`` is :data:`~allanite.variance.fast.DEFAULT_Q`, a
    positive integer is that ``q``.
    """
    if fast is None or fast is False:
        return None
    if fast is True:
        return DEFAULT_Q
    if isinstance(fast, (int, np.integer)) and not isinstance(fast, bool) and fast >= 1:
        return int(fast)
    raise ValueError(f"fast must be True, False or a positive integer q, got {fast!r}")


def variances(
    phase: NDArray[np.float64],
    factors: NDArray[np.int64],
    kernel_kind: str,
    *,
    threads: int,
    progress: ProgressCallback | None = None,
    q: int | None = None,
    meta: dict[str, Any] | None = None,
) -> NDArray[np.float64]:
    """Variances in sample units (tau0 = 1), shape ``(T, C)``, of an in-memory phase.

    Parameters
    ----------
    phase : numpy.ndarray
        Detrended phase ``(M, C)`` from :func:`allanite._core.phase`.
    factors : numpy.ndarray
        Averaging factors.
    kernel_kind : str
        Kernel kind (see :data:`allanite.variance.taus.KERNEL_KIND`).
    threads : int
        Worker threads (0: all cores).
    progress : callable, optional
        ``progress("variance", done, total)`` after each group of factors (exact mode).
    q : int, optional
        Fast mode with this ``q`` (:func:`allanite.variance.fast.fast_variance`); the strides
        go to ``meta["fast_stride"]`` and ``q`` to ``meta["fast_q"]``.
    meta : dict, optional
        Receives the fast-mode entries.
    """
    nt = factors.size
    if q is not None:
        var, strides = fast_variance(phase, factors, kernel_kind, q=q, threads=threads)
        if meta is not None:
            meta["fast_q"] = q
            meta["fast_stride"] = strides
        if progress is not None:
            progress("variance", nt, nt)
        return var
    if progress is None:
        return np.asarray(_core.variance(phase, factors, kernel_kind, threads))
    var = np.empty((nt, phase.shape[1]))
    group = max(1, nt // 20)
    for start in range(0, nt, group):
        sl = slice(start, start + group)
        var[sl] = _core.variance(phase, factors[sl], kernel_kind, threads)
        progress("variance", min(start + group, nt), nt)
    return var


def series_points(decimated_rows: int, identify: str) -> int:
    """Values the identification sees in a decimated phase (one fewer for frequency data)."""
    return decimated_rows if identify == "phase" else decimated_rows - 1


def identify_bounded(
    phase: NDArray[np.float64],
    factors: NDArray[np.int64],
    kernel_kind: str,
    identify: str,
    alpha_rows: int,
) -> NDArray[np.int64]:
    """Noise identification on an in-memory phase with at most ``alpha_rows`` points per tau.

    Each factor's decimated phase ``x[::m]`` is cut to its first ``alpha_rows`` points (the
    same rule as the out-of-core pass), so the temporary arrays of the identification stay
    small; exponents identified from few points are capped as in
    :func:`allanite.variance.edf.cap_few_point_alpha`.
    """
    out = np.empty((factors.size, phase.shape[1]), dtype=np.int64)
    points = np.empty(factors.size, dtype=np.int64)
    for i, m in enumerate(factors.tolist()):
        decimated = np.ascontiguousarray(phase[: m * alpha_rows : m])
        out[i] = identify_alpha(decimated, np.array([1]), kernel_kind, data=identify)[0]
        points[i] = series_points(decimated.shape[0], identify)
    return cap_few_point_alpha(out, factors, points)
