r"""Level changes (bias steps) of the time view: a likelihood-ratio scan under the model's noise.

A bias step of size ``d`` at time ``t`` moves the window means after it by ``d`` (the window
that holds ``t`` by the fraction of it after ``t``), so it adds ``d u_t`` to the differences of
consecutive window means, ``j`` (``W - 1`` of them), with ``u_t`` the differences of that
profile. Under the model the jumps are Gaussian with covariance ``C``; the generalised
likelihood ratio of "one step at ``t``" against "no step" is

.. math:: z_t^2 = \frac{(u_t^\top P j)^2}{u_t^\top P u_t}, \qquad P = C^{-1},

and the statistic is ``Z = max_t |z_t|`` over a grid of quarter windows. ``C`` comes from the
model's own replicates (the time view's null ensemble: the model's flicker, random walk and
any slow noise are in it, so a random walk's wander is not a step), as a stationary
(Toeplitz) covariance (:func:`toeplitz_covariance`). With a white-noise model ``z_t`` is the
standardised CUSUM of the window means (the CUSUM's optimal form for one step); with slow
noise the whitening ``P`` removes the slow wander a plain CUSUM of block means is dominated
by.

**Calibration.** The null law of ``Z`` comes from the same replicates, out of sample: they are
cut into :data:`FOLDS` folds, and each fold's ``Z`` values are computed with ``C`` estimated
from the other folds (a covariance estimated on the vector it tests would make the null too
small). A moment-matched Gumbel law of those maxima gives the p-value
(:func:`~allanite.diagnosis.null.gumbel_sf`, like the other per-window scans). The real
record's ``C`` uses all replicates (a slightly better ``C`` than the folds': conservative).

**Location, size and their intervals.** The step's time is the grid point of the largest
``|z_t|``; its 95 % interval is a parametric bootstrap on the model's own replicates (the
fitted step added to each replicate's jumps and located again: the 2.5-97.5 % quantiles of
the located times, widened by half a grid step); its size is the generalised-least-squares estimate
``d = u^\top P j / u^\top P u`` with standard error ``1 / sqrt(u^\top P u)`` (the model's
noise, replicates' covariance).

**Several steps** (binary segmentation with a joint refit): after a significant step, every
step found so far is refitted jointly (GLS with one column per step) and the residual jumps
are scanned again, against the same null law and the same level; at most :data:`MAX_STEPS`.
Only the first scan is a test of "no step" at the stated level; the later ones are
conditional on the first and each runs at that level too.

References
----------
E. S. Page, "Continuous inspection schemes", Biometrika 41 (1954) (CUSUM). A. J. Scott, M.
Knott, Biometrics 30 (1974) 507 (binary segmentation).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import linalg

from allanite.diagnosis.null import gumbel_sf

__all__ = ["FOLDS", "GRID", "MAX_STEPS", "Step", "StepScan", "step_scan", "toeplitz_covariance"]

#: folds of the out-of-sample calibration of the null maxima
FOLDS = 4
#: candidate step times per window (a grid of quarter windows)
GRID = 4
#: at most this many steps are located (binary segmentation)
MAX_STEPS = 4
#: coverage of the bootstrap interval of the step time
TIME_LEVEL = 0.95


@dataclass(frozen=True)
class Step:
    """One located level change.

    Attributes
    ----------
    t_s : float
        Time of the step (grid of quarter windows).
    t_interval_s : (float, float)
        Bootstrap interval of the time (95 %, the model's replicates).
    size, size_sd : float
        Step size (after minus before, rate units) and its standard error under the model's
        noise.
    z : float
        The scan statistic ``|z_t|`` at the step (units of standard errors).
    p_value : float
        p-value of the scan that found it (the first: "no step"; later ones: conditional).
    """

    t_s: float
    t_interval_s: tuple[float, float]
    size: float
    size_sd: float
    z: float
    p_value: float

    def text(self, units: str | None = None) -> str:
        """One line: time with its interval, size with its standard error."""
        lo, hi = self.t_interval_s
        hours = f" = {self.t_s / 3600:.3g} h" if self.t_s >= 3600 else ""
        unit = f" {units}" if units else ""
        return (
            f"at {self.t_s:.5g} s{hours} (95 % interval {lo:.5g}-{hi:.5g} s), size "
            f"{self.size:+.3g} +/- {self.size_sd:.2g}{unit} (1 sigma, {self.z:.3g} s.e.)"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "t_s": self.t_s,
            "t_interval_s": list(self.t_interval_s),
            "size": self.size,
            "size_sd": self.size_sd,
            "z": self.z,
            "p_value": self.p_value,
        }


@dataclass(frozen=True)
class StepScan:
    """The step test of one record: statistic, p-value, the steps found and what to re-test.

    ``jumps`` are the real record's jump residuals, ``cov`` their null covariance (Toeplitz),
    ``null_max`` the out-of-sample null maxima of the statistic.
    """

    statistic: float
    p_value: float
    steps: list[Step]
    jumps: NDArray[np.float64] = field(repr=False)
    cov: NDArray[np.float64] = field(repr=False)
    null_max: NDArray[np.float64] = field(repr=False)
    window_s: float = 1.0

    def p_with_extra(self, extra_jump_var: float) -> float:
        """p-value of the first scan if the sensor had an extra process of jump variance ``2A``.

        The added process's jump variance (``2 A(window)``, independent across jumps: exact
        for a random walk, the diagonal for other processes) is added to ``C``; the statistic
        is judged against the same null law (its law is that of a maximum of standardised
        Gaussian scores whatever ``C``).
        """
        if extra_jump_var <= 0 or self.jumps.size == 0:
            return self.p_value
        cov = self.cov + np.eye(self.cov.shape[0]) * extra_jump_var
        z = _scores(_profiles(self.jumps.size + 1), _inv(cov), self.jumps)
        return gumbel_sf(float(np.abs(z).max()), self.null_max)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "statistic": self.statistic,
            "p_value": self.p_value,
            "steps": [s.to_dict() for s in self.steps],
        }

    def with_extra(self, extra_jump_var: float) -> StepScan:
        """The scan with an extra independent jump variance in its covariance (re-tests)."""
        if extra_jump_var <= 0:
            return self
        cov = self.cov + np.eye(self.cov.shape[0]) * extra_jump_var
        return replace(self, cov=cov, p_value=self.p_with_extra(extra_jump_var))


def _inv(c: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(np.linalg.inv(c), dtype=np.float64)


def toeplitz_covariance(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Covariance of the rows of ``x`` averaged along its diagonals (a stationary sequence).

    The jumps of window means of a process with stationary increments (white, flicker,
    random walk, Gauss-Markov noise) are a stationary sequence: their covariance depends on
    the lag only, ``W - 1`` numbers measured from every pair of the replicates' jumps (a free
    covariance, ``W (W - 1) / 2`` numbers from a few hundred replicates, is too noisy to invert,
    and shrinking it towards its diagonal discards the correlations that whitening needs).
    Eigenvalues are kept at or above ``1e-9`` of the largest. For a non-stationary model (a
    warm-up) the matrix is a stationary approximation: the out-of-sample null keeps the test
    at its level, only its power depends on it.
    """
    n, p = x.shape
    xc = x - x.mean(axis=0)
    s = xc.T @ xc / (n - 1)
    acov = np.array([np.mean(np.diagonal(s, offset=k)) for k in range(p)])
    c = linalg.toeplitz(acov)
    w, v = np.linalg.eigh(c)
    w = np.maximum(w, 1e-9 * float(w.max()))
    return np.asarray((v * w) @ v.T, dtype=np.float64)


def _profiles(n_windows: int) -> NDArray[np.float64]:
    """Jump profiles ``u_t`` (rows) of a unit step at each grid time (quarter windows)."""
    t = np.arange(1, n_windows * GRID) / GRID
    i = np.arange(n_windows)
    level = np.clip(i[None, :] + 1.0 - t[:, None], 0.0, 1.0)  # share of window i after t
    return np.asarray(np.diff(level, axis=1), dtype=np.float64)


def _scores(
    u: NDArray[np.float64], prec: NDArray[np.float64], j: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``z_t`` of every grid time (rows of ``u``) for each jump vector (last axis of ``j``)."""
    up = u @ prec
    info = np.sum(up * u, axis=1)
    return np.asarray((j @ up.T) / np.sqrt(np.maximum(info, 1e-300)), dtype=np.float64)


def _null_maxima(null_jumps: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
    """Out-of-sample null maxima of ``|z_t|``: each fold scored with the others' covariance."""
    n = null_jumps.shape[0]
    folds = np.arange(n) % FOLDS
    out = np.empty(n)
    for f in range(FOLDS):
        test = folds == f
        prec = _inv(toeplitz_covariance(null_jumps[~test]))
        out[test] = np.abs(_scores(u, prec, null_jumps[test])).max(axis=1)
    return out


def _fit_steps(
    u: NDArray[np.float64], prec: NDArray[np.float64], j: NDArray[np.float64], idx: list[int]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Joint GLS sizes of the steps at grid indices ``idx`` and their covariance."""
    x = u[idx].T
    info = x.T @ prec @ x
    cov = _inv(info)
    return np.asarray(cov @ (x.T @ prec @ j)), np.asarray(cov)


def _time_interval(
    u: NDArray[np.float64],
    prec: NDArray[np.float64],
    null_jumps: NDArray[np.float64],
    k: int,
    size: float,
) -> tuple[float, float]:
    """Bootstrap interval of the step time (window units) from the model's own replicates.

    The fitted step is added to every replicate's jumps and located again; the interval runs
    from the ``(1 - TIME_LEVEL) / 2`` to the ``(1 + TIME_LEVEL) / 2`` quantile of the located
    times, widened by half a grid step.
    """  # fmt: skip
    z = _scores(u, prec, null_jumps + size * u[k])
    found = (np.argmax(np.abs(z), axis=1) + 1) / GRID
    q = (1.0 - TIME_LEVEL) / 2.0
    half = 0.5 / GRID
    lo, hi = np.quantile(found, [q, 1.0 - q])
    return float(lo) - half, float(hi) + half


def step_scan(
    jumps: NDArray[np.float64],
    null_jumps: NDArray[np.float64],
    window_s: float,
    alpha: float,
    *,
    real_scale: float = 1.0,
) -> StepScan:
    """Scan the jumps of the window means for level changes.

    Parameters
    ----------
    jumps : numpy.ndarray
        Real differences of consecutive window means minus the simulated sensor's, scaled to
        the variance of one null residual.
    null_jumps : numpy.ndarray
        The replicates' residual jumps, shape ``(n_null, W - 1)``.
    window_s : float
        Window length in seconds.
    alpha : float
        Level of each scan (the first is the test of "no step").
    real_scale : float
        Variance of the real residual relative to a null residual (sizes are unscaled with it).
    """
    j = np.asarray(jumps, dtype=np.float64)
    nj = np.asarray(null_jumps, dtype=np.float64)
    u = _profiles(j.size + 1)
    cov = toeplitz_covariance(nj)
    prec = _inv(cov)
    null_max = _null_maxima(nj, u)
    z = _scores(u, prec, j)
    stat = float(np.abs(z).max())
    p = gumbel_sf(stat, null_max)
    idx: list[int] = []
    steps: list[Step] = []
    resid, zk, pk = j, z, p
    while pk < alpha and len(idx) < MAX_STEPS:
        k = int(np.argmax(np.abs(zk)))
        if k in idx:
            break
        idx.append(k)
        size, size_cov = _fit_steps(u, prec, j, idx)
        resid = j - u[idx].T @ size
        lo, hi = _time_interval(u, prec, nj, k, float(size[-1]))
        steps.append(
            Step(
                t_s=(k + 1) / GRID * window_s,
                t_interval_s=(max(lo, 0.0) * window_s, hi * window_s),
                size=float(size[-1]) * np.sqrt(real_scale),
                size_sd=float(np.sqrt(size_cov[-1, -1] * real_scale)),
                z=float(abs(zk[k])),
                p_value=pk,
            )
        )
        zk = _scores(u, prec, resid)
        pk = gumbel_sf(float(np.abs(zk).max()), null_max)
    # sizes of all steps from the final joint fit
    if len(idx) > 1:
        size, size_cov = _fit_steps(u, prec, j, idx)
        sc = np.sqrt(real_scale)
        steps = [
            replace(s, size=float(size[i]) * sc, size_sd=float(np.sqrt(size_cov[i, i])) * sc)
            for i, s in enumerate(steps)
        ]
    steps.sort(key=lambda s: s.t_s)
    return StepScan(stat, p, steps, j, cov, null_max, window_s)
