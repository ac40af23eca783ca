"""Starting values from an Allan curve: bounds from the asymptotes and hump locations."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from allanite.variance import AllanResult

__all__ = ["curve", "curve_bound", "hump"]


def curve(
    result: AllanResult, min_edf: float = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Finite, positive ``(tau, var)`` points of the first channel of ``result``.

    With ``min_edf`` only the points with at least that many degrees of freedom are kept
    (all points when none qualifies).
    """
    var = np.asarray(result.var, dtype=np.float64)
    edf = np.asarray(result.edf, dtype=np.float64)
    if var.ndim != 1:
        var, edf = var[:, 0], edf[:, 0]
    tau = np.asarray(result.tau, dtype=np.float64)
    ok = np.isfinite(var) & (var > 0)
    good = ok & (edf >= min_edf)
    if np.any(good):
        ok = good
    return tau[ok], var[ok]


def curve_bound(result: AllanResult, power: float) -> float | None:
    """``min(var * tau**power)``: the largest coefficient^2-like value the curve allows.

    Every term adds a non-negative Allan variance, so e.g. ``N^2 <= var(tau) * tau`` at every
    tau; the minimum is the tightest such bound (None when the curve has no valid point).
    """
    tau, var = curve(result, min_edf=20.0)
    if tau.size == 0:
        return None
    return float(np.min(var * tau**power))


def hump(result: AllanResult) -> tuple[float, float] | None:
    """``(tau, var)`` of the highest interior local maximum of the curve, or None.

    A Gauss-Markov process or a sinusoid shows as a hump of the Allan deviation; power laws
    never do.
    """
    tau, var = curve(result)
    if tau.size < 3:
        return None
    inner = np.flatnonzero((var[1:-1] > var[:-2]) & (var[1:-1] >= var[2:])) + 1
    if inner.size == 0:
        return None
    best = inner[np.argmax(var[inner])]
    return float(tau[best]), float(var[best])
