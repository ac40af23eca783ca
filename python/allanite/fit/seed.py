r"""The original program's fit (``method="seed"``), kept so that old results can be compared.

Unweighted nonlinear least squares on the Allan variance with five squared coefficients,

.. math:: \sigma^2(\tau) = r^2\tau^2 + k^2\tau + b^2 + n^2/\tau + q^2/\tau^2,

and 95 % bounds from the Jacobian as MATLAB's ``fit``/``confint`` compute them:
:math:`p \pm t_{0.975,\nu}\sqrt{\mathrm{diag}((J^\top J)^{-1})\,\mathrm{SSE}/\nu}`,
:math:`\nu` = points - 5. The IEEE coefficients follow as :math:`R = \sqrt2|r|`,
:math:`K = \sqrt3|k|`, :math:`B = |b|/\sqrt{2\ln2/\pi}`, :math:`N = |n|`,
:math:`Q = |q|/\sqrt3`. The bounds ignore the correlation and unequal spread of the AVAR
estimates; :func:`allanite.fit` with ``method="gls"`` does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import optimize, stats

from allanite.terms.flicker import PLATEAU

__all__ = ["SCALE", "SeedFit", "seed_fit"]

#: coefficient = SCALE[name] * |raw parameter|
SCALE = {
    "R": math.sqrt(2.0),
    "K": math.sqrt(3.0),
    "B": 1.0 / math.sqrt(PLATEAU),
    "N": 1.0,
    "Q": 1.0 / math.sqrt(3.0),
}
_RAW = ("r", "k", "b", "n", "q")
_POWERS = np.array([2.0, 1.0, 0.0, -1.0, -2.0])


@dataclass(frozen=True)
class SeedFit:
    """Raw parameters r, k, b, n, q with their 95 % bounds, and the fitted curve."""

    raw: dict[str, float]
    raw_bounds: dict[str, tuple[float, float]]
    raw_stderr: dict[str, float]
    fitted: NDArray[np.float64]
    sse: float
    dof: int


def seed_fit(tau: NDArray[np.float64], var: NDArray[np.float64]) -> SeedFit:
    """Fit the five-term polynomial to the Allan variance like the original program."""
    t = np.asarray(tau, dtype=np.float64)
    y = np.asarray(var, dtype=np.float64)
    if t.size < 6:
        raise ValueError(
            f"method='seed' fits 5 coefficients and needs at least 6 taus, got {t.size}; "
            "use a denser tau grid (taus='log')"
        )
    basis = t[:, None] ** _POWERS[None, :]
    scale = np.sqrt(np.max(np.abs(y)) / np.max(basis, axis=0))

    def residual(p: NDArray[np.float64]) -> NDArray[np.float64]:
        out: NDArray[np.float64] = basis @ (p * scale) ** 2 - y
        return out

    # start from the non-negative linear solution (as a curve-fitting user would seed it)
    lin, _ = optimize.nnls(basis * scale**2, y)
    p0 = np.sqrt(np.maximum(lin, 1e-6 * lin.max() if lin.max() > 0 else 1e-6))
    sol = optimize.least_squares(residual, p0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    p = sol.x * scale
    jac = sol.jac / scale[None, :]
    sse = float(np.sum(sol.fun**2))
    dof = max(t.size - 5, 1)
    cov = np.linalg.pinv(jac.T @ jac) * sse / dof
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    tq = float(stats.t.ppf(0.975, dof))
    raw = {name: float(v) for name, v in zip(_RAW, p, strict=True)}
    bounds = {
        name: (float(v - tq * s), float(v + tq * s)) for name, v, s in zip(_RAW, p, se, strict=True)
    }
    stderr = {name: float(s) for name, s in zip(_RAW, se, strict=True)}
    return SeedFit(raw, bounds, stderr, basis @ p**2, sse, dof)


def coefficient_bounds(lo: float, hi: float, scale: float) -> tuple[float, float]:
    """Map the bounds of a raw parameter to the bounds of ``scale * |parameter|``."""
    if lo <= 0.0 <= hi:
        return 0.0, scale * max(abs(lo), abs(hi))
    a, b = sorted((abs(lo), abs(hi)))
    return scale * a, scale * b
