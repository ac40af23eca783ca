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

Long records (cost that does not grow with ``n_mc x N``)
--------------------------------------------------------
A feature that is a mean over ``k`` nearly independent pieces (Welch segments, first
differences) has a null residual whose variance scales as ``1/k``; the null of a record of
``N`` samples is then the null of shorter replicates (``k_s`` pieces) scaled by
``sqrt(k_s / k)`` (:func:`rescaled`). The mean of the log of such a mean carries the bias
``-var/2`` (delta method), so the reference moves by ``(var_s - var_N) / 2``. A maximum over
``N`` samples is the maximum over ``N / N_s`` independent short records: for a Gumbel law with
scale ``beta`` the location moves by ``beta ln(N / N_s)`` (max-stability, :func:`gumbel_scale`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import special, stats

__all__ = [
    "NullEnsemble",
    "chi2_like_sf",
    "empirical_sf",
    "gumbel_isf",
    "gumbel_scale",
    "gumbel_sf",
    "kth_max_isf",
    "kth_max_sf",
    "level_profiled",
    "max_shift",
    "rescaled",
    "rescaled_log_gamma",
    "runs",
]

Features = dict[str, NDArray[np.float64]]


def level_profiled(term: Any) -> bool:
    """Whether ``term``'s noise level follows a profile over the record.

    A non-stationary term with a ``variance_scale(t)`` (its variance over time relative to the
    record mean, :class:`allanite.terms.WhiteDrift`): second-order stationary but for that
    profile, with its time parameters on the record's timeline. The null treats it apart
    (its AVAR covariance, its short replicates, the reference of its window levels).
    """
    return not getattr(term, "stationary", True) and hasattr(term, "variance_scale")


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
    exact_tau : bool
        The tau residuals are draws from a known law
        (:func:`allanite.diagnosis.tau_view.gaussian_tau_null`), not replicates.
    """

    ref: Features
    null: dict[str, NDArray[np.float64]]
    real_scale: float
    exact_tau: bool = False

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


def _log_gamma_shape(var: NDArray[np.float64]) -> NDArray[np.float64]:
    """Shape ``a`` of a unit-mean gamma variable whose log has variance ``var``.

    Solves ``psi'(a) = var`` (trigamma) by Newton steps from ``a ~ 1/var + 1/2``.
    """
    v = np.maximum(np.asarray(var, dtype=np.float64), 1e-12)
    a = (1.0 + np.sqrt(1.0 + 2.0 * v)) / (2.0 * v)
    for _ in range(6):
        a = np.maximum(a - (special.polygamma(1, a) - v) / special.polygamma(2, a), 1e-3)
    return np.asarray(a, dtype=np.float64)


def rescaled_log_gamma(
    ens: NullEnsemble,
    name: str,
    ratio: float,
    *,
    reference: NDArray[np.float64] | None = None,
    n_reference: int | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Like :func:`rescaled` for the log of a mean of chi-square pieces (a Welch PSD).

    The log of a unit-mean gamma variable with shape ``a`` (``a`` ~ the number of averaged
    pieces) has the mean ``psi(a) - log a`` and a skewness ``~ -1/sqrt(a)`` that shrinks as
    pieces are added; scaling alone would keep the short record's light upper tail and make the
    line detector (a maximum over bins) anti-conservative. Each null residual is therefore
    mapped through its quantile: ``u = F_a(x)`` under the shape ``a_s`` of the short replicates
    (from their variance, ``psi'(a_s) = var``), ``x_N = F^{-1}_{a_N}(u)`` with ``a_N = a_s /
    ratio``; the result is scaled by ``sqrt(1 + var_s / (n var_n))`` for the error of the
    reference (the short replicates' mean), and the reference moves from the short law's mean
    to the long one's.

    ``reference`` (the mean of the feature over ``n_reference`` short replicates, those of
    ``ens`` included) replaces the replicates' mean: the reference error then adds
    ``var_s / (n_reference var_n)`` instead of ``var_s / (n var_n)``.
    """
    if not 0.0 < ratio <= 1.0:
        raise ValueError(f"ratio of piece counts must lie in (0, 1], got {ratio}")
    null = ens.null[name]
    n = null.shape[0]
    if (reference is None) != (n_reference is None):
        raise ValueError("give both reference and n_reference, or neither")
    if n_reference is not None and n_reference < n:
        raise ValueError(
            f"n_reference ({n_reference}) must count the ensemble's {n} replicates too"
        )
    var_s = null.var(axis=0, ddof=1) * (n - 1.0) / n
    a_s = _log_gamma_shape(var_s)
    a_n = a_s / ratio
    mean_s = special.digamma(a_s) - np.log(a_s)
    mean_n = special.digamma(a_n) - np.log(a_n)
    u = special.gammainc(a_s, a_s * np.exp(null * (n - 1.0) / n + mean_s))
    u = np.clip(u, 1e-300, 1.0 - 1e-16)
    mapped = np.log(special.gammaincinv(a_n, u) / a_n) - mean_n
    var_n = special.polygamma(1, a_n)
    n_ref = n if n_reference is None else n_reference
    mapped = mapped * np.sqrt(1.0 + var_s / (n_ref * var_n))
    ref = (ens.ref[name] if reference is None else reference) - mean_s + mean_n
    return np.asarray(ref, dtype=np.float64), np.asarray(mapped, dtype=np.float64)


def rescaled(
    ens: NullEnsemble, name: str, ratio: float, *, log_mean: bool, pool: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Reference and null residuals of ``name`` for a record with ``1 / ratio`` times the pieces.

    ``ens`` is the leave-one-out null of ``n`` shorter replicates (residual variance
    ``s^2 n / (n - 1)``). The real record's residual against the replicates' mean has the
    variance ``s^2 (ratio + 1/n)``: its own (``1/k`` scaling) plus the reference's; the null
    residuals are scaled to it. With ``pool`` the feature has one expected value for all its
    entries (the windows of a stationary record): the reference is the mean over entries and
    replicates and its error is negligible. With ``log_mean`` (the feature is the log of a
    mean) the reference moves by ``var (1 - ratio) / 2``, the change of the log-of-mean bias
    ``-var/2``.
    """
    if not 0.0 < ratio <= 1.0:
        raise ValueError(f"ratio of piece counts must lie in (0, 1], got {ratio}")
    null = ens.null[name]
    n = null.shape[0]
    ref = ens.ref[name]
    var = null.var(axis=0, ddof=1) * (n - 1.0) / n  # of one replicate's feature
    if pool:
        mean = float(np.mean(ref))
        resid = (null * (n - 1.0) / n + ref) - mean  # replicate minus the pooled mean
        ref = np.full_like(ref, mean)
        scale = np.sqrt(ratio)
    else:
        resid = null
        scale = np.sqrt((ratio + 1.0 / n) * (n - 1.0) / n)
    if log_mean:
        ref = ref + 0.5 * var * (1.0 - ratio)
    return np.asarray(ref, dtype=np.float64), np.asarray(resid * scale, dtype=np.float64)


def gumbel_scale(null: NDArray[np.float64]) -> float:
    """Scale ``beta = s sqrt(6) / pi`` of the moment-matched Gumbel law of a maximum."""
    return float(np.std(null, ddof=1) * np.sqrt(6.0) / np.pi)


def max_shift(null: NDArray[np.float64], k: float) -> float:
    """Location shift ``beta ln k`` of a maximum taken over ``k`` times as many values.

    The maximum of ``k`` independent Gumbel(``mu``, ``beta``) variables is Gumbel(``mu + beta
    ln k``, ``beta``) (max-stability). For maxima of lighter-than-exponential tails (Gaussian
    samples) the true shift and scale are smaller, so the extrapolated test is conservative.
    """
    if k < 1.0:
        raise ValueError(f"k must be >= 1 (a maximum over more values), got {k}")
    return gumbel_scale(null) * float(np.log(k))


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


def _kth_max_law(null: NDArray[np.float64], k: int) -> tuple[float, float]:
    """Location ``mu`` and scale ``beta`` of the k-th largest's law, moment-matched to ``null``.

    The ``k`` largest of many values from a Gumbel-domain tail are the first points of a
    Poisson process of intensity ``exp(-(x - mu) / beta)``, so the k-th largest is ``mu - beta
    log G`` with ``G ~ Gamma(k, 1)``: mean ``mu - beta psi(k)``, variance ``beta^2 psi'(k)``.
    """
    mean, sd = float(np.mean(null)), float(np.std(null, ddof=1))
    beta = sd / float(np.sqrt(special.polygamma(1, k)))
    return mean + beta * float(special.digamma(k)), beta


def kth_max_sf(value: float, null: NDArray[np.float64], k: int) -> float:
    """Tail probability of the ``k``-th largest of many values (``k = 1``: :func:`gumbel_sf`).

    ``P(X >= x) = P(G <= exp(-(x - mu) / beta))`` for ``G ~ Gamma(k, 1)`` (the regularised
    lower incomplete gamma function), ``mu`` and ``beta`` matched to the null's mean and
    spread (:func:`_kth_max_law`). The tail of the k-th largest is lighter than a Gumbel law
    of the same spread (``~ exp(-k z) / k!``): several moderate outliers are far less likely
    by chance than one.
    """
    if k < 1:
        raise ValueError(f"k must be >= 1 (1 = the maximum), got {k}")
    if k == 1:
        return gumbel_sf(value, null)
    if float(np.std(null, ddof=1)) <= 0:
        return empirical_sf(value, null)
    mu, beta = _kth_max_law(null, k)
    return float(special.gammainc(k, np.exp(-(value - mu) / beta)))


def kth_max_isf(p: float, null: NDArray[np.float64], k: int) -> float:
    """Inverse of :func:`kth_max_sf`: the value the k-th largest exceeds with probability ``p``."""
    if k < 1:
        raise ValueError(f"k must be >= 1 (1 = the maximum), got {k}")
    if k == 1:
        return gumbel_isf(p, null)
    mu, beta = _kth_max_law(null, k)
    return float(mu - beta * np.log(special.gammaincinv(k, p)))


def runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Index ranges ``[start, stop]`` (inclusive) of the runs of True in ``mask``."""
    idx = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return [(int(a), int(b) - 1) for a, b in zip(idx[::2], idx[1::2], strict=True)]
