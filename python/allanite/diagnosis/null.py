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
p-values below ``1/n`` remain meaningful. The k-th largest of many samples (spikes) is judged
against the exceedance rate of the replicates' pooled samples (:class:`ExceedanceTail`, from
the replicates' mean counts, :attr:`NullEnsemble.pooled`).

Long records (cost that does not grow with ``n_mc x N``)
--------------------------------------------------------
A feature that is a mean over ``k`` nearly independent pieces (Welch segments, first
differences) has a null residual whose variance scales as ``1/k``; the null of a record of
``N`` samples is then the null of shorter replicates (``k_s`` pieces) scaled by
``sqrt(k_s / k)`` (:func:`rescaled`). The mean of the log of such a mean carries the bias
``-var/2`` (delta method), so the reference moves by ``(var_s - var_N) / 2``. The k-th largest
of ``N`` samples needs no rescaling: the per-sample exceedance rate of the short replicates
times ``N`` is the Poisson mean of the long record's exceedances (:class:`ExceedanceTail`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import special, stats

__all__ = [
    "ExceedanceTail",
    "NullEnsemble",
    "chi2_like_sf",
    "empirical_sf",
    "gumbel_isf",
    "gumbel_sf",
    "level_profiled",
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
    pooled : dict
        Mean of each feature over all ``n_pooled`` replicates (for a model: ``ref``; for a
        record: the replicates', not the simulated record's), e.g. the mean exceedance counts
        of the spike statistic's tail.
    n_pooled : int
        Number of replicates behind ``pooled``.
    sim_record : bool
        ``ref`` holds the features of a simulated record (:meth:`from_record`), not a mean.
    """

    ref: Features
    null: dict[str, NDArray[np.float64]]
    real_scale: float
    exact_tau: bool = False
    pooled: Features = field(default_factory=dict)
    n_pooled: int = 0
    sim_record: bool = False

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
        return cls(ref=ref, null=null, real_scale=1.0, pooled=ref, n_pooled=n)

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
        pooled = {
            name: np.mean([r[name] for r in replicates[: 2 * n]], axis=0) for name in sim_features
        }
        return cls(
            ref=dict(sim_features), null=null, real_scale=1.0, pooled=pooled, n_pooled=2 * n,
            sim_record=True,
        )  # fmt: skip

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


#: pooled exceedances that make a level's rate measured; beyond it the tail is extrapolated
TAIL_MIN_COUNT = 25
#: the extrapolation's decay is the secant over the last measured decade of counts
TAIL_DECADE = 10.0
#: decay of the log rate per unit level when the replicates measure no slope (a light tail)
TAIL_FALLBACK_SLOPE = -2.0


@dataclass(frozen=True)
class ExceedanceTail:
    r"""Per-sample rate ``q(x)`` at which a statistic's declustered peaks exceed a level ``x``.

    Measured from the pooled counts of ``n_pooled`` replicate records (:meth:`from_counts`):
    ``q(x) = C(x) / M`` on the grid levels whose pooled count ``C`` is at least
    :data:`TAIL_MIN_COUNT` (``M`` pooled samples; log-linear between grid levels). Beyond the
    last measured level ``x_1`` the log rate decays linearly, with the secant slope over the
    last measured decade of counts (``C(x_0) = TAIL_DECADE C(x_1)``): an exponential tail.
    Gaussian-like tails are log-concave, so this extrapolation over-states the rate (the test
    is conservative there) and needs no shape assumption inside the data.

    For ``n`` samples the peaks above ``x`` are a Poisson process of mean ``n q(x)`` (rare,
    declustered exceedances), so the k-th largest exceeds ``x`` with probability
    ``P(Poisson(n q(x)) >= k)`` (:meth:`kth_sf`), whatever the replicates' length: the law of a
    long record comes from short replicates with no other change.

    References
    ----------
    M. R. Leadbetter, G. Lindgren, H. Rootzen, "Extremes and related properties of random
    sequences and processes", Springer (1983), ch. 2 and 5 (Poisson limit of exceedances,
    the k-th largest).
    """

    levels: NDArray[np.float64]
    log_rate: NDArray[np.float64]
    slope: float
    floor_levels: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    floor_rate: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    @classmethod
    def from_counts(
        cls,
        levels: NDArray[np.float64],
        counts: NDArray[np.float64],
        samples: float,
        floor: tuple[NDArray[np.float64], float] | None = None,
    ) -> ExceedanceTail:
        """Tail from the pooled ``counts`` of peaks at or above ``levels`` in ``samples`` samples.

        ``counts`` are non-increasing along the increasing ``levels``. With fewer than
        :data:`TAIL_MIN_COUNT` peaks above the lowest level, that level's rate is taken as
        ``TAIL_MIN_COUNT / samples`` (an upper bound) and the decay beyond it as
        :data:`TAIL_FALLBACK_SLOPE`. ``floor = (counts_1, samples_1)``, the counts of one more
        record on the same levels, keeps the rate at or above that record's own
        ``counts_1 / samples_1`` (a simulated record whose own tail the replicates, Gaussian
        surrogates, do not carry).
        """
        levels = np.asarray(levels, dtype=np.float64)
        counts = np.asarray(counts, dtype=np.float64)
        if levels.ndim != 1 or counts.shape != levels.shape or levels.size < 2:
            raise ValueError(
                "levels and counts must be 1-D arrays of the same length (>= 2), got shapes "
                f"{levels.shape} and {counts.shape}"
            )
        if samples <= 0:
            raise ValueError(f"samples (the pooled record length) must be > 0, got {samples}")
        if floor is not None:
            tail = cls.from_counts(levels, counts, samples)
            own = np.asarray(floor[0], dtype=np.float64)
            if own.shape != levels.shape or floor[1] <= 0:
                raise ValueError(
                    "floor must be (counts on the same levels, samples > 0), got shape "
                    f"{own.shape} and {floor[1]} samples"
                )
            return cls(
                levels=tail.levels,
                log_rate=tail.log_rate,
                slope=tail.slope,
                floor_levels=levels,
                floor_rate=own / floor[1],
            )
        measured = np.flatnonzero(counts >= TAIL_MIN_COUNT)
        if measured.size == 0:
            return cls(
                levels=levels[:1],
                log_rate=np.array([np.log(TAIL_MIN_COUNT / samples)]),
                slope=TAIL_FALLBACK_SLOPE,
            )
        hi = int(measured[-1])
        lo = np.flatnonzero(counts >= TAIL_DECADE * counts[hi])
        slope = TAIL_FALLBACK_SLOPE
        if lo.size and levels[hi] > levels[int(lo[-1])]:
            j = int(lo[-1])
            slope = float(np.log(counts[hi] / counts[j]) / (levels[hi] - levels[j]))
        elif hi > 0:
            slope = float(np.log(counts[hi] / counts[0]) / (levels[hi] - levels[0]))
        return cls(
            levels=levels[: hi + 1],
            log_rate=np.log(counts[: hi + 1] / samples),
            slope=min(slope, -1e-6),
        )

    def rate(self, x: float) -> float:
        """Per-sample rate of peaks at or above ``x`` (the lowest level's below it)."""
        if x >= self.levels[-1]:
            out = float(np.exp(self.log_rate[-1] + self.slope * (x - self.levels[-1])))
        else:
            out = float(np.exp(np.interp(x, self.levels, self.log_rate)))
        i = int(np.searchsorted(self.floor_levels, x, side="right")) - 1
        return max(out, float(self.floor_rate[i])) if i >= 0 else out

    def level(self, rate: float) -> float:
        """The level whose rate is ``rate`` (inverse of :meth:`rate`; the lowest level at most).

        With a floor: the level where both the tail and the floor are at or below ``rate``
        (infinite when the floor stays above it over all its levels).
        """
        target = float(np.log(rate))
        if target <= self.log_rate[-1]:
            x = float(self.levels[-1] + (target - self.log_rate[-1]) / self.slope)
        else:  # log_rate is non-increasing: interpolate on the reversed arrays
            x = float(np.interp(target, self.log_rate[::-1], self.levels[::-1]))
        above = np.flatnonzero(self.floor_rate > rate)
        if above.size:
            j = int(above[-1])  # the floor's rate is non-increasing along its levels
            last = j + 1 >= self.floor_levels.size
            x = max(x, np.inf if last else float(self.floor_levels[j + 1]))
        return x

    def kth_sf(self, value: float, n: float, k: int) -> float:
        """``P(k-th largest of n samples >= value) = P(Poisson(n q(value)) >= k)``.

        Values below the lowest level (no evidence of anything rare) get 1.
        """
        if k < 1:
            raise ValueError(f"k must be >= 1 (1 = the maximum), got {k}")
        if value < self.levels[0]:
            return 1.0
        return float(special.gammainc(k, n * self.rate(value)))

    def kth_isf(self, p: float, n: float, k: int) -> float:
        """Inverse of :meth:`kth_sf`: the level the k-th largest exceeds with probability ``p``."""
        if k < 1:
            raise ValueError(f"k must be >= 1 (1 = the maximum), got {k}")
        if not 0.0 < p < 1.0:
            raise ValueError(f"p must lie in (0, 1), got {p}")
        return self.level(float(special.gammaincinv(k, p)) / n)


def runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Index ranges ``[start, stop]`` (inclusive) of the runs of True in ``mask``."""
    idx = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return [(int(a), int(b) - 1) for a, b in zip(idx[::2], idx[1::2], strict=True)]
