"""The null ensemble: reference features and residuals of Monte Carlo replicates.

Every view of the diagnosis compares a *feature* of the real record (log Allan variance per
tau, log PSD per frequency bin, per-window statistics, ...) with the same feature of the
simulated sensor. The residual ``r = f_real - f_ref`` is judged against residuals that occur
by chance, taken from replicates of the simulated sensor:

* model: ``f_ref`` is the mean over ``n`` replicates and the null residuals are the
  leave-one-out residuals ``f_j - mean_{-j} = (f_j - mean) * n / (n - 1)``, distributed like
  the real residual ``f_real - mean`` up to a factor ``1 + O(1/n^2)`` in variance;
* record: ``f_ref`` is the simulated record's own feature and the null residuals are
  differences of independent replicate pairs ``f_2j - f_2j+1`` (both sides noisy, like the
  real-vs-sim comparison).

Tail probabilities of the scalar statistics built on these residuals come from distributions
fitted to the null values (scaled chi-square for quadratic forms, Gumbel for maxima), so
p-values below ``1/n`` remain meaningful.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import stats

__all__ = ["NullEnsemble", "chi2_like_sf", "empirical_sf", "gumbel_isf", "gumbel_sf", "runs"]

Features = dict[str, NDArray[np.float64]]


@dataclass(frozen=True)
class NullEnsemble:
    """Reference features and null residuals, per feature name.

    Attributes
    ----------
    ref : dict
        Reference feature vectors.
    null : dict
        Null residuals, arrays of shape ``(n_null, len(feature))``.
    real_scale : float
        Variance factor of the real residual relative to one null residual (1 for both kinds;
        kept for sources whose reference is averaged over several simulated records).
    """

    ref: Features
    null: dict[str, NDArray[np.float64]]
    real_scale: float

    @property
    def n_null(self) -> int:
        """Number of null residuals."""
        return int(next(iter(self.null.values())).shape[0])

    @classmethod
    def from_model(cls, replicates: list[Features]) -> NullEnsemble:
        """Null ensemble from ``n`` replicates of a model (leave-one-out residuals)."""
        n = len(replicates)
        if n < 20:
            raise ValueError(f"need at least 20 Monte Carlo replicates, got {n}")
        ref: Features = {}
        null: dict[str, NDArray[np.float64]] = {}
        for name in replicates[0]:
            stack = np.stack([r[name] for r in replicates])
            mean = stack.mean(axis=0)
            ref[name] = mean
            null[name] = (stack - mean) * (n / (n - 1.0))
        return cls(ref=ref, null=null, real_scale=1.0)

    @classmethod
    def from_record(cls, sim_features: Features, replicates: list[Features]) -> NullEnsemble:
        """Null ensemble for a simulated record: pair differences of replicates."""
        n = len(replicates) // 2
        if n < 20:
            raise ValueError(f"need at least 40 Monte Carlo replicates for a record, got {2 * n}")
        null = {
            name: np.stack(
                [replicates[2 * j][name] - replicates[2 * j + 1][name] for j in range(n)]
            )
            for name in sim_features
        }
        return cls(ref=dict(sim_features), null=null, real_scale=1.0)

    def residual(self, real: Features, name: str) -> NDArray[np.float64]:
        """Real residual of one feature, scaled to the variance of a null residual."""
        return np.asarray((real[name] - self.ref[name]) / np.sqrt(self.real_scale))


def empirical_sf(value: float, null: NDArray[np.float64]) -> float:
    """Monte Carlo p-value ``(1 + #{null >= value}) / (n + 1)``."""
    null = np.asarray(null)
    return float((1 + np.count_nonzero(null >= value)) / (null.size + 1))


def chi2_like_sf(value: float, null: NDArray[np.float64]) -> float:
    """Tail probability from a scaled chi-square ``a * chi2(b)`` matched to the null moments.

    ``a = var / (2 mean)``, ``b = 2 mean^2 / var`` (Satterthwaite, 1946).
    """
    mean, var = float(np.mean(null)), float(np.var(null, ddof=1))
    if mean <= 0 or var <= 0:
        return empirical_sf(value, null)
    a, b = var / (2 * mean), 2 * mean * mean / var
    return float(stats.chi2.sf(value / a, b))


def gumbel_sf(value: float, null: NDArray[np.float64]) -> float:
    """Tail probability of a maximum-type statistic from a moment-matched Gumbel law.

    ``beta = s sqrt(6) / pi``, ``mu = mean - 0.5772 beta``; ``P(X >= x) = 1 - exp(-exp(-(x -
    mu) / beta))``.
    """
    mean, sd = float(np.mean(null)), float(np.std(null, ddof=1))
    if sd <= 0:
        return empirical_sf(value, null)
    beta = sd * np.sqrt(6.0) / np.pi
    mu = mean - np.euler_gamma * beta
    return float(-np.expm1(-np.exp(-(value - mu) / beta)))


def gumbel_isf(p: float, null: NDArray[np.float64]) -> float:
    """Inverse of :func:`gumbel_sf`: the value exceeded with probability ``p`` under the null."""
    mean, sd = float(np.mean(null)), float(np.std(null, ddof=1))
    beta = sd * np.sqrt(6.0) / np.pi
    mu = mean - np.euler_gamma * beta
    return float(mu - beta * np.log(-np.log1p(-p)))


def runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Index ranges ``[start, stop]`` (inclusive) of the runs of True in ``mask``."""
    idx = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return [(int(a), int(b) - 1) for a, b in zip(idx[::2], idx[1::2], strict=True)]
