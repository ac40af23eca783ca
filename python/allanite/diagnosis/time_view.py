r"""The time view: where in the record the real sensor departs from the model.

The record is cut into ``W`` windows (32 when the record allows, at least 16) of ``L`` samples.
Per window it computes, for the real record and for every Monte Carlo replicate:

* ``level``: the window mean minus the record mean (warm-up transients, drifting bias);
* ``jump``: the difference of consecutive window means (bias steps);
* ``hf``: the log mean square of the first differences, ``log(2 AVAR(tau0))``, a dynamic Allan
  variance at the shortest tau (bursts of white noise, spikes);
* ``dyn``: the log non-overlapping Allan variance at ``m = max(2, L/16)`` (dynamic Allan
  variance at a mid tau: bursts of correlated noise, telegraph episodes);

(for ``hf`` and ``dyn`` the median residual over the windows is removed: a uniform change of
the noise level belongs to the tau view, the time view looks for changes in time)

plus three record-wide statistics: the largest deviations from a 9-sample running median in
units of their robust spread (``|h| / (1.4826 MAD(h))``, spikes: the 1st, 2nd, 4th and 8th
largest peaks, :data:`SPIKE_ORDERS`, each tested against the Poisson law of the k-th largest
with the replicates' pooled exceedance rate (:func:`spike_test`), Bonferroni over the four: a
few spikes of 5 sample sigmas are not much larger than the largest of 2^15 Gaussian samples,
but two or four of them are far beyond the null's 2nd or 4th largest),
the excess kurtosis at the
sample scale (two-sided: bursts, outliers, clipping; ``kurt_hf``, two statistics, Bonferroni
over both: of the first differences, and of the samples minus their 9-sample running mean,
which keeps ``sum a^4 / (sum a^2)^2 = 0.79`` of a sample-level scale mixture's excess where
differences keep 0.5 -- one in ten angle samples dropped at rest makes every tenth rate sample
``sqrt(2)`` times the noise, an excess of ~0.2 that the running-mean statistic resolves at ~10
s.e. in 2^16 samples, the differences at ~5 -- while a slow wander or ramp, which would make
the plain samples' kurtosis platykurtic, is removed) and the excess kurtosis of block means (8,
``L/16`` and ``L/4`` samples; Gaussian slow wander only dilutes it), tested one-sided for a
platykurtic,
two-level amplitude distribution (random telegraph noise changes the amplitude distribution,
not the Allan variance).

Each per-window residual ``r_w`` is normalised by its null spread, ``z_w = r_w / s_w``; windows
with ``|z_w|`` above the simultaneous threshold (the ``1 - alpha`` quantile of ``max_w |z_w|``
under the null, Gumbel fit; ``dyn``, left-skewed, gets a law for each side: :func:`window_scan`)
form the time segments. A significant jump is refined to a change
point with the CUSUM estimator ``argmax_k |sum_{i<k} (x_i - mean)|`` over the two windows
around it; spikes are the samples whose deviation from the running median exceeds the
threshold of the lowest significant order.

References
----------
L. Galleani, P. Tavella, "The dynamic Allan variance", IEEE Trans. UFFC 56 (2009) 450-464.
E. S. Page, "Continuous inspection schemes", Biometrika 41 (1954) 100-115 (CUSUM).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage, stats

from allanite.diagnosis.changepoint import StepScan, step_scan
from allanite.diagnosis.null import (
    ExceedanceTail,
    NullEnsemble,
    gumbel_isf,
    gumbel_sf,
    runs,
)

__all__ = [
    "TimePlan",
    "TimeView",
    "WindowScan",
    "added_level_variance",
    "block_kurtosis",
    "kurtosis_blocks",
    "largest_spikes",
    "sparse_jump_p",
    "spike_features",
    "spike_test",
    "tail_features",
    "tail_spread",
    "tail_test",
    "time_features",
    "time_plan",
    "time_view",
    "window_scan",
]

WINDOW_FAMILIES = ("level", "jump", "hf", "dyn")
#: per-window families whose largest and smallest scores get a law each (:func:`window_scan`):
#: the log of a mean over few pieces is left-skewed
SKEWED_FAMILIES = ("dyn",)
#: at most this many spikes are listed individually (the largest; every spike is counted)
MAX_SPIKES = 200
#: window of the running median that the spike finder removes
SPIKE_MEDIAN = 9
#: which largest deviations from the running median the spike statistic tests (k-th largest)
SPIKE_ORDERS = (1, 2, 4, 8)
#: levels (units of the robust spread) at which the spike null counts its exceedances
SPIKE_GRID = np.round(np.arange(3.0, 12.0 + 1e-9, 0.05), 2)
#: the features whose replicate means (:attr:`NullEnsemble.pooled`) the spike law needs
SPIKE_POOLED = ("spike_tail", "spike_n")
#: window of the running mean removed before the sample-level kurtosis (``kurt_hf``'s second)
KURT_MEAN = 9
#: band (units of the robust spread) of the tail-shape statistic: moderate deviations from the
#: running median; at or above the cap lies the far tail that spikes explain
TAIL_BAND = (3.0, 4.5)
#: window of the running mean removed before the tail-shape statistic: long, so that a
#: sample's own deviation stays whole (``1 - 1/33``; a spike stays above the band) and the
#: neighbours add little (a 9-sample mean keeps ``8/9`` and adds a tenth of the variance)
TAIL_MEAN = 33
#: levels at which the tail-shape statistic also counts its samples (for the report)
TAIL_LEVELS = (3.0, 4.0)


@dataclass(frozen=True)
class TimePlan:
    """Window layout: ``n_windows`` windows of ``length`` samples, block size ``m``."""

    n_windows: int
    length: int
    m: int


def time_plan(n: int) -> TimePlan:
    """Return the window layout for a record of ``n`` samples."""
    n_win = int(min(32, n // 32))
    length = n // n_win
    return TimePlan(n_windows=n_win, length=length, m=max(2, length // 16))


def highpass(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Subtract the running median over :data:`SPIKE_MEDIAN` samples (the spike finder)."""
    return np.asarray(x - ndimage.median_filter(x, size=SPIKE_MEDIAN, mode="nearest"))


def _robust_spread(v: NDArray[np.float64]) -> float:
    """``1.4826 MAD``, the standard deviation of Gaussian data, robust to outliers."""
    mad = float(np.median(np.abs(v - np.median(v)))) * 1.4826
    return mad if mad > 0 else (float(np.std(v)) or 1.0)


def _kurtosis(v: NDArray[np.float64]) -> float:
    v = v - v.mean()
    v2 = v * v  # (v * v)^2, not v**4: the integer power goes through pow() and is ~10x slower
    s2 = float(np.mean(v2))
    return float(np.mean(v2 * v2) / (s2 * s2) - 3.0) if s2 > 0 else 0.0


def time_features(
    x: NDArray[np.float64],
    plan: TimePlan,
    *,
    kurt_blocks: tuple[int, ...] | None = None,
    sample_scale: bool = True,
) -> dict[str, NDArray[np.float64]]:
    """Per-window and record-wide features of a rate record.

    ``kurt_blocks`` overrides the block sizes of ``kurt_lf`` (default
    :func:`kurtosis_blocks`; a decimated replicate uses the same block durations). Without
    ``sample_scale`` the statistics of the sampling scale (``hf``, ``spike``, ``kurt_hf``) are
    left out (a decimated replicate cannot stand for them).
    """
    if kurt_blocks is None:
        kurt_blocks = kurtosis_blocks(plan)
    w, length, m = plan.n_windows, plan.length, plan.m
    used = x[: w * length].reshape(w, length)
    means = used.mean(axis=1)
    nb = length // m
    blocks = used[:, : nb * m].reshape(w, nb, m).mean(axis=2)
    dyn = np.log(np.maximum(0.5 * np.mean(np.diff(blocks, axis=1) ** 2, axis=1), 1e-300))
    out = {
        "level": means - x.mean(),
        "jump": np.diff(means),
        "dyn": dyn,
        "kurt_lf": np.array([block_kurtosis(used, b) for b in kurt_blocks]),
    }
    if sample_scale:
        d = np.diff(used, axis=1)
        out["hf"] = np.log(np.maximum(np.mean(d * d, axis=1), 1e-300))
        del d
        out.update(spike_features(x))
        d1 = _kurtosis(np.diff(x))
        hp = ndimage.uniform_filter1d(x, KURT_MEAN, mode="nearest")
        np.subtract(x, hp, out=hp)
        out["kurt_hf"] = np.array([d1, _kurtosis(hp)])
        out["tail"] = tail_features(x, work=hp)
        del hp
    return out


def spike_features(x: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    """The spike statistic of a rate record and the counts its null pools.

    ``a = |hp| / spread``, with ``hp`` the record minus its running median (:func:`highpass`)
    and ``spread`` its robust spread (``1.4826 MAD``); a *peak* is a sample whose ``a`` is the
    largest within :data:`SPIKE_MEDIAN` samples (a spike and its running-median neighbours are
    one event). Returns ``spike``, the :data:`SPIKE_ORDERS` largest peaks; ``spike_tail``, the
    number of peaks at or above each level of :data:`SPIKE_GRID`; ``spike_n``, the number of
    samples.
    """
    hp = highpass(x)
    a = np.abs(hp)
    a /= _robust_spread(hp)
    del hp
    # the peaks at or above the grid: each candidate against its +-4 neighbours (cheap: few
    # candidates); all peaks only when fewer than the orders reach the grid
    cand = np.flatnonzero(a >= SPIKE_GRID[0])
    half = SPIKE_MEDIAN // 2
    near = np.clip(cand[:, None] + np.arange(-half, half + 1), 0, a.size - 1)
    top = np.sort(a[cand][a[cand] >= a[near].max(axis=1, initial=0.0)])
    if top.size >= max(SPIKE_ORDERS):
        peak = top
    else:
        peak = a[a >= ndimage.maximum_filter1d(a, SPIKE_MEDIAN, mode="nearest")]
    return {
        "spike": _largest(peak, SPIKE_ORDERS),
        "spike_tail": (top.size - np.searchsorted(top, SPIKE_GRID, side="left")).astype(float),
        "spike_n": np.array([float(x.size)]),
    }


def _tail_highpass(
    x: NDArray[np.float64], work: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """The record minus its :data:`TAIL_MEAN`-sample running mean (into ``work``, if given)."""
    hp = np.empty_like(x) if work is None else work
    ndimage.uniform_filter1d(x, TAIL_MEAN, output=hp, mode="nearest")
    return np.asarray(np.subtract(x, hp, out=hp))


def tail_spread(x: NDArray[np.float64]) -> float:
    """The unit of the tail-shape statistic: the robust spread of :func:`tail_features`' ``hp``."""
    return _robust_spread(_tail_highpass(np.asarray(x, dtype=np.float64)))


def tail_features(
    x: NDArray[np.float64], *, work: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """The tail-shape statistic of a rate record (:func:`tail_test`).

    ``hp`` is the record minus its :data:`TAIL_MEAN`-sample running mean and ``a = |hp| /
    spread`` (``1.4826 MAD``: a linear high-pass keeps Gaussian samples Gaussian, so ``a`` is
    in units of their standard deviation). Returns, as means over the samples, the
    scale-mixture score ``exp(a^2 / 4)`` on the band :data:`TAIL_BAND` (0 outside it) and the
    share of the samples in the band at or above each level of :data:`TAIL_LEVELS`. ``work``
    (an array of ``x``'s shape) holds the high-pass, saving an allocation.
    """
    hp = _tail_highpass(x, work)
    a = np.abs(hp) / _robust_spread(hp)
    lo, cap = TAIL_BAND
    band = a[(a >= lo) & (a < cap)]
    score = float(np.sum(np.exp(0.25 * band * band)))
    shares = [float(np.count_nonzero(band >= level)) for level in TAIL_LEVELS]
    return np.array([score, *shares], dtype=np.float64) / float(max(hp.size, 1))


def _largest(a: NDArray[np.float64], orders: tuple[int, ...]) -> NDArray[np.float64]:
    """The ``k``-th largest values of ``a`` for ``k`` in ``orders``.

    A record shorter than ``max(orders)`` repeats its smallest value.
    """
    top = max(orders)
    if a.size > top:
        part = np.partition(a, a.size - top)[a.size - top :]
    else:
        part = np.concatenate([a, np.full(top - a.size, float(np.min(a)))])
    desc = np.sort(part)[::-1]
    return np.asarray(desc[np.asarray(orders) - 1], dtype=np.float64)


def kurtosis_blocks(plan: TimePlan) -> tuple[int, ...]:
    """Block sizes of the low-frequency kurtosis: 8 samples, ``L/16`` and ``L/4``."""
    return tuple(sorted({8, plan.m, max(plan.length // 4, 2)}))


def block_kurtosis(used: NDArray[np.float64], b: int) -> float:
    """Excess kurtosis of the means of ``b``-sample blocks (windows in rows)."""
    return _block_moments(used, b)[1]


def _block_moments(used: NDArray[np.float64], b: int) -> tuple[float, float]:
    """Variance and excess kurtosis of the means of ``b``-sample blocks (windows in rows)."""
    nb = used.shape[1] // b
    blocks = used[:, : nb * b].reshape(used.shape[0], nb, b).mean(axis=2).ravel()
    return float(np.var(blocks)), _kurtosis(blocks)


def added_block_kurtosis(
    term: Any,
    fs: float,
    n: int,
    n_windows: int,
    blocks: tuple[int, ...],
    *,
    n_rep: int = 32,
    seed: int = 20261125,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Block-mean variance, mean and spread of the excess kurtosis of ``term`` alone.

    Monte Carlo over ``n_rep`` records of ``n`` samples of the term on its own (fixed seed),
    laid out like the time view's ``n_windows`` windows, per block size of ``blocks``: a
    random walk's or a slow Gauss-Markov process's block means over one record are
    platykurtic (the path does not visit its range like a Gaussian sample). The samples are
    linear in the term's first (amplitude) parameter: the Monte Carlo runs once per shape at
    unit amplitude (cached) and the variance is scaled. The shape's time scales (a
    Gauss-Markov ``tau_c``: every fit finds a new one) are rounded to
    :data:`SHAPE_STEPS_PER_OCTAVE` steps per octave, so the fits of one diagnosis share a few
    Monte Carlo runs (a rounding of at most 2.2 % in ``tau_c`` moves the block kurtosis far
    less than its Monte Carlo spread).
    """
    name = term.params[0].name
    amplitude = float(term.values()[name])
    unit = term.with_values(**{name: 1.0, **_rounded_shape(term)})
    key = (repr(unit), fs, n, n_windows, tuple(blocks), n_rep, seed)
    if key not in _BLOCK_CACHE:
        if len(_BLOCK_CACHE) >= 256:
            _BLOCK_CACHE.pop(next(iter(_BLOCK_CACHE)))
        _BLOCK_CACHE[key] = _block_kurtosis_mc(unit, fs, n, n_windows, blocks, n_rep, seed)
    var, k, sd = _BLOCK_CACHE[key]
    return var * amplitude**2, k, sd


#: steps per octave of the time scales of :func:`added_block_kurtosis`'s cached shapes
SHAPE_STEPS_PER_OCTAVE = 16


def _rounded_shape(term: Any) -> dict[str, float]:
    """The term's time-scale parameters (rate power 0, not ``duration``) on a log grid."""
    out = {}
    for spec in term.params[1:]:
        value = float(getattr(term, spec.name))
        if spec.rate == 0 and spec.time != 0 and spec.name != "duration" and value > 0:
            steps = round(math.log2(value) * SHAPE_STEPS_PER_OCTAVE)
            out[spec.name] = 2.0 ** (steps / SHAPE_STEPS_PER_OCTAVE)
    return out


_BLOCK_CACHE: dict[
    tuple[Any, ...], tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
] = {}


def _block_kurtosis_mc(
    term: Any, fs: float, n: int, n_windows: int, blocks: tuple[int, ...], n_rep: int, seed: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    from allanite.model import NoiseModel

    x = NoiseModel((term,)).simulate(n, fs=fs, n_channels=n_rep, seed=seed, allow_aliasing=True)
    length = n // n_windows
    moments = np.array(
        [
            [
                _block_moments(x[: n_windows * length, i].reshape(n_windows, length), b)
                for b in blocks
            ]
            for i in range(n_rep)
        ]
    )  # (rep, block, [var, kurt])
    var = moments[:, :, 0].mean(axis=0)
    kurt = moments[:, :, 1]
    return var, kurt.mean(axis=0), kurt.std(axis=0, ddof=1)


@dataclass(frozen=True)
class TimeView:
    """Result of the time view (plotting-ready arrays).

    Attributes
    ----------
    t_s : numpy.ndarray
        Window centres in seconds.
    window_s : float
        Window length in seconds.
    level, level_sd : numpy.ndarray
        Window mean minus record mean of the real record, and its spread under the null.
    z : dict of numpy.ndarray
        Normalised per-window residuals of ``level``, ``jump`` (at window boundaries), ``hf``
        and ``dyn``.
    thresholds : dict of float
        Simultaneous thresholds of each family.
    family_p : dict of float
        p-value of each family and of the record-wide statistics.
    kurtosis : dict
        Excess kurtosis (``hf``: first differences, ``hf_samples``: the samples minus their
        running mean, ``lf``: block means) of the real record and of the simulated sensor.
    lf_kurtosis : dict
        The low-frequency kurtosis per block size (``blocks``, samples): the real record's
        excess kurtosis of its block means (``real``) and their variance (``var``), the
        simulated sensor's (``ref``) and its null spread (``sd``), for
        :meth:`lf_kurtosis_p_value`.
    spike_times_s, spike_amplitudes : list of float
        Detected spikes (time and signed height above the local median), every one; the
        segments list the :data:`MAX_SPIKES` largest (:func:`largest_spikes`).
    spike_raise : numpy.ndarray
        Per window, how much the detected spikes raise the log mean square of the first
        differences (``hf``): ``log(D_w / (D_w - 2 sum h^2 / (L - 1)))`` with ``D_w`` the
        window's mean square and ``h`` the heights of its spikes (a spike enters two
        differences); zeros without spikes.
    tail : dict
        The tail's shape (:func:`tail_test`): the real record's ``score`` and the simulated
        sensor's ``expected`` score; per level of :data:`TAIL_LEVELS`, the real ``count`` of
        samples between the level and the band's cap (robust spreads from the running mean)
        and the simulated sensor's ``expected_count``; the ``spread`` (rate units,
        :func:`tail_spread`).
    change_points_s : list of float
        Refined times of significant level jumps.
    segments_s : list of (float, float)
        Time segments where the record departs from the model.
    """

    t_s: NDArray[np.float64]
    window_s: float
    level: NDArray[np.float64]
    level_sd: NDArray[np.float64]
    z: dict[str, NDArray[np.float64]]
    thresholds: dict[str, float]
    family_p: dict[str, float]
    kurtosis: dict[str, float]
    spike_times_s: list[float]
    spike_amplitudes: list[float]
    change_points_s: list[float]
    segments_s: list[tuple[float, float]]
    residual: dict[str, NDArray[np.float64]] = field(default_factory=dict, repr=False)
    spread: dict[str, NDArray[np.float64]] = field(default_factory=dict, repr=False)
    null_max: dict[str, NDArray[np.float64]] = field(default_factory=dict, repr=False)
    lf_kurtosis: dict[str, Any] = field(default_factory=dict, repr=False)
    spike_raise: NDArray[np.float64] = field(
        default_factory=lambda: np.zeros(0, dtype=np.float64), repr=False
    )
    tail: dict[str, Any] = field(default_factory=dict, repr=False)
    steps: StepScan | None = field(default=None, repr=False)

    def level_p_values(
        self,
        extra_avar_window: float,
        extra_level_var: NDArray[np.float64] | None = None,
        *,
        gaussian: bool = True,
    ) -> dict[str, float]:
        """p-values of ``jump`` and ``level`` if the sensor had an extra independent process.

        A process with stationary increments and Allan variance ``A`` at the window length adds
        ``2 A`` to the variance of the difference of consecutive window means (the definition
        of the Allan variance), so the jump spreads become ``sqrt(s_w^2 + 2 A)``. The level
        spreads (window mean minus record mean) become ``sqrt(s_w^2 + v_w)`` with ``v_w`` the
        process's own level variance per window (``extra_level_var``, e.g. from
        :func:`added_level_variance`; a random walk wanders most at the record ends); without
        it they are inflated by the average jump factor. A candidate that adds enough slow
        noise explains the level evidence without being a step or a warm-up. The jump
        p-value of a ``gaussian`` process also holds the sparse-jump test
        (:func:`sparse_jump_p`, Bonferroni over the two): a Gaussian process, of any size,
        does not explain a few large jumps among small ones (a two-level process may).
        """
        out: dict[str, float] = {}
        if "jump" not in self.residual:
            return out
        sd_j = self.spread["jump"]
        new_j = np.sqrt(sd_j**2 + 2.0 * max(extra_avar_window, 0.0))
        p_max = gumbel_sf(float(np.abs(self.residual["jump"] / new_j).max()), self.null_max["jump"])
        # a Gaussian process spreads the jumps evenly; a few large ones are level changes
        # (bias steps), whatever the process's size: both tests, Bonferroni
        # the step scan (whitened CUSUM, :mod:`~allanite.diagnosis.changepoint`) with the
        # process's jump variance in its covariance: one more statistic of the family
        tests = [p_max]
        if self.steps is not None:
            tests.append(self.steps.p_with_extra(2.0 * max(extra_avar_window, 0.0)))
        if gaussian:
            tests.append(sparse_jump_p(self.residual["jump"] / sd_j))
        out["jump"] = min(1.0, len(tests) * min(tests))
        sd_l = self.spread["level"]
        if extra_level_var is None:
            new_l = sd_l * float(np.mean(new_j / sd_j))
        else:
            new_l = np.sqrt(sd_l**2 + np.maximum(extra_level_var, 0.0))
        out["level"] = gumbel_sf(
            float(np.abs(self.residual["level"] / new_l).max()), self.null_max["level"]
        )
        return out

    def lf_kurtosis_p_value(
        self, added: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
    ) -> float | None:
        r"""p-value of the platykurtic block means if the sensor had an extra slow process.

        ``added`` is the process's own block-mean variance ``v_c``, mean excess kurtosis
        ``k_c`` and its spread (:func:`added_block_kurtosis`). Independent parts add their
        cumulants: with the simulated sensor's share ``v_s = max(v - v_c, 0)`` of the real
        block-mean variance ``v``, the expected excess kurtosis is

        .. math:: k = \frac{k_s v_s^2 + k_c v_c^2}{(v_s + v_c)^2}

        with the spread combined alike; the one-sided test of :func:`time_view`
        (Bonferroni over the block sizes) on ``(k_real - k) / spread``. None without the
        detail.
        """
        lf = self.lf_kurtosis
        if not lf:
            return None
        v_c, k_c, sd_c = (np.asarray(a, dtype=np.float64) for a in added)
        v_s = np.maximum(lf["var"] - v_c, 0.0)
        total = np.maximum(v_s + v_c, 1e-300)
        w_s, w_c = (v_s / total) ** 2, (v_c / total) ** 2
        k = w_s * lf["ref"] + w_c * k_c
        sd = np.sqrt((w_s * lf["sd"]) ** 2 + (w_c * sd_c) ** 2)
        z = (lf["real"] - k) / np.where(sd > 0, sd, np.inf)
        return float(min(1.0, z.size * stats.norm.sf(float((-z).max()))))

    @property
    def p_value(self) -> float:
        """Bonferroni combination over the statistics of the time view."""
        return min(1.0, len(self.family_p) * min(self.family_p.values()))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "t_s": self.t_s.tolist(),
            "window_s": self.window_s,
            "level": self.level.tolist(),
            "level_sd": self.level_sd.tolist(),
            "z": {k: v.tolist() for k, v in self.z.items()},
            "thresholds": dict(self.thresholds),
            "family_p": dict(self.family_p),
            "kurtosis": dict(self.kurtosis),
            "spike_times_s": list(self.spike_times_s),
            "spike_amplitudes": list(self.spike_amplitudes),
            "change_points_s": list(self.change_points_s),
            "segments_s": [list(s) for s in self.segments_s],
            "tail": dict(self.tail),
            "steps": self.steps.to_dict() if self.steps is not None else None,
            "p_value": self.p_value,
        }


#: mixing weights and slab variances (in units of the null spread squared) of the sparse-jump
#: test's alternative; the slab grid is also the Gaussian hypothesis' grid of added variance
SPARSE_WEIGHTS = np.geomspace(0.02, 0.9, 8)
SPARSE_VARIANCES = np.geomspace(0.1, 1e5, 25)
#: Monte Carlo draws of the sparse-jump test's null (fixed seed, cached per grid point)
SPARSE_DRAWS = 2000
_SPARSE_CACHE: dict[tuple[int, int], NDArray[np.float64]] = {}


def _gaussian_fit(z2: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Best log-likelihood of ``z ~ N(0, 1 + g)`` over the grid (g = 0 included), and its index.

    ``z2`` holds squared standardised jumps in its last axis.
    """
    v = np.concatenate([[1.0], 1.0 + SPARSE_VARIANCES])
    ll = -0.5 * (z2.shape[-1] * np.log(v) + z2.sum(axis=-1)[..., None] / v)
    return ll.max(axis=-1), ll.argmax(axis=-1)


def _sparse_gain(z2: NDArray[np.float64]) -> NDArray[np.float64]:
    """``2 (max log L_mixture - max log L_gauss)`` per row of squared standardised jumps.

    Gaussian: ``z ~ N(0, 1 + g)``; mixture: ``(1 - pi) N(0, 1) + pi N(0, 1 + h)`` (a few jumps of
    size ``h``, the others the null's own), both maximised over the grids.
    """
    gauss, _ = _gaussian_fit(z2)
    h = 1.0 + SPARSE_VARIANCES  # (H,)
    l0 = -0.5 * z2[..., None, None]  # (..., n, 1, 1)
    l1 = -0.5 * (np.log(h) + z2[..., None] / h)[..., None, :]  # (..., n, 1, H)
    w = SPARSE_WEIGHTS[:, None]  # (P, 1)
    mix = np.logaddexp(np.log1p(-w) + l0, np.log(w) + l1).sum(axis=-3)  # (..., P, H)
    best = np.maximum(mix.max(axis=(-2, -1)), gauss)
    return np.asarray(2.0 * (best - gauss), dtype=np.float64)


def sparse_jump_p(z: NDArray[np.float64]) -> float:
    r"""p-value of "the jumps are Gaussian": a few large level changes, not a slow process.

    ``z`` are the jumps (differences of consecutive window means) in units of their null
    spread. Any Gaussian stationary process added to the sensor (a random walk, a
    Gauss-Markov process, flicker) makes them ``N(0, 1 + g)`` with one common ``g`` (it adds
    ``2 A(window)`` to every jump's variance); bias steps make a few of them large and leave
    the others at the null's ``N(0, 1)``. The statistic is the likelihood ratio of the scale
    mixture ``(1 - pi) N(0, 1) + pi N(0, 1 + h)`` against the best Gaussian, both maximised on
    grids (:data:`SPARSE_WEIGHTS`, :data:`SPARSE_VARIANCES`); its null is simulated
    (:data:`SPARSE_DRAWS` draws of Gaussian jumps at the fitted ``g``, fixed seed). The test
    needs no candidate: it asks whether *any* Gaussian slow process explains the jumps.
    """
    z = np.asarray(z, dtype=np.float64)
    z = z[np.isfinite(z)]
    if z.size < 4:
        return 1.0
    z2 = z * z
    stat = float(_sparse_gain(z2))
    _, idx = _gaussian_fit(z2)
    key = (z.size, int(idx))
    if key not in _SPARSE_CACHE:
        v = 1.0 if key[1] == 0 else 1.0 + float(SPARSE_VARIANCES[key[1] - 1])
        rng = np.random.default_rng(20261125 + 1000 * z.size + key[1])
        draws = [
            _sparse_gain(v * rng.standard_normal((500, z.size)) ** 2)
            for _ in range(SPARSE_DRAWS // 500)
        ]
        _SPARSE_CACHE[key] = np.sort(np.concatenate(draws))
    null = _SPARSE_CACHE[key]
    exceed = null.size - int(np.searchsorted(null, stat - 1e-9, side="left"))
    return float((1 + exceed) / (1 + null.size))


def added_level_variance(
    term: Any, fs: float, n: int, n_windows: int, *, n_rep: int = 48, seed: int = 20261121
) -> NDArray[np.float64]:
    """Level variance per window (window mean minus record mean) of ``term`` alone.

    Monte Carlo over ``n_rep`` records of ``n`` samples of the term on its own (fixed seed, so
    the diagnosis stays reproducible), laid out like the time view's ``n_windows`` windows.
    Window means do not depend on the sampling rate for the rate-free terms of
    :func:`allanite.diagnosis.decimation.decimation`, so long records are simulated over the
    same duration at ``fs / D``.
    """
    from allanite.diagnosis.decimation import decimation
    from allanite.model import NoiseModel

    model = NoiseModel((term,))
    d = decimation(model, n, fs) if n > 4 * 2**16 else 1
    n_d = n // d
    x = model.simulate(n_d, fs=fs / d, n_channels=n_rep, seed=seed, allow_aliasing=True)
    length = (n // n_windows) // d
    means = x[: n_windows * length].reshape(n_windows, length, n_rep).mean(axis=1)
    level = means - x.mean(axis=0)
    return np.asarray(np.mean(level * level, axis=1), dtype=np.float64)


def _merge(segments: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for a, b in sorted(segments):
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def _spikes(x: NDArray[np.float64], threshold: float) -> tuple[list[int], list[float]]:
    hp = highpass(x)
    score = np.abs(hp) / _robust_spread(hp)
    flagged = np.flatnonzero(score > threshold)
    found: list[int] = []
    for i in flagged:
        k = int(i)
        if found and k - found[-1] <= 1:
            if score[k] > score[found[-1]]:
                found[-1] = k
            continue
        found.append(k)
    return found, [float(hp[k]) for k in found]


def largest_spikes(amplitudes: Sequence[float], limit: int = MAX_SPIKES) -> list[int]:
    """Positions of the ``limit`` largest spikes (by absolute height), in time order.

    Every spike is counted; only a listing is capped, and then by size, so that the spikes
    listed are those that matter rather than the first seconds of the record.
    """
    heights = np.abs(np.asarray(amplitudes, dtype=np.float64))
    if heights.size <= limit:
        return list(range(heights.size))
    keep = np.argsort(-heights, kind="stable")[:limit]
    return sorted(int(i) for i in keep)


def _change_point(x: NDArray[np.float64], start: int, stop: int) -> int:
    seg = x[start:stop]
    cs = np.cumsum(seg - seg.mean())
    return start + int(np.argmax(np.abs(cs[:-1]))) + 1


def _kurtosis_checks(
    x: NDArray[np.float64],
    real: dict[str, NDArray[np.float64]],
    ens: NullEnsemble,
    plan: TimePlan,
    fam_p: dict[str, float],
) -> dict[str, Any]:
    """The kurtosis statistics' p-values into ``fam_p``; return the block-means details.

    ``kurt_hf`` two-sided (bursts and outliers +, clipping -), ``kurt_lf`` one-sided (a
    two-level, telegraph amplitude distribution is platykurtic), each Bonferroni over its
    block sizes. The returned ``kurt_lf`` details (blocks, real values, block variances,
    reference and the real residual's spread) let a candidate re-test the block means.
    """
    length = plan.length
    lf: dict[str, Any] = {}
    for name, sign in (("kurt_hf", 0), ("kurt_lf", -1)):
        sd = ens.null[name].std(axis=0, ddof=1)
        if name == "kurt_lf":
            blocks = kurtosis_blocks(plan)
            used = x[: plan.n_windows * length].reshape(plan.n_windows, length)
            lf = {
                "blocks": blocks,
                "real": np.asarray(real[name], dtype=np.float64),
                "var": np.array([_block_moments(used, b)[0] for b in blocks]),
                "ref": np.asarray(ens.ref[name], dtype=np.float64),
                # the real residual's spread (the null's, times the real record's scale)
                "sd": np.asarray(sd * np.sqrt(ens.real_scale), dtype=np.float64),
            }
        zk = ens.residual(real, name) / np.where(sd > 0, sd, np.inf)
        if sign == 0:  # two-sided: bursts and outliers (+), clipping (-)
            tail = 2.0 * stats.norm.sf(float(np.abs(zk).max()))
        else:  # one-sided: a two-level (telegraph) amplitude distribution is platykurtic
            tail = stats.norm.sf(float((sign * zk).max()))
        fam_p[name] = float(min(1.0, zk.size * tail))  # Bonferroni over the block sizes
    return lf


@dataclass(frozen=True)
class WindowScan:
    """One per-window family judged against its null (see :func:`window_scan`)."""

    z: NDArray[np.float64]
    threshold: float
    p_value: float
    residual: NDArray[np.float64]
    spread: NDArray[np.float64]
    null_max: NDArray[np.float64]


def window_scan(
    r: NDArray[np.float64],
    null: NDArray[np.float64],
    alpha: float,
    *,
    sides: bool = False,
    median: bool = False,
) -> WindowScan:
    """Scores, simultaneous threshold and p-value of a per-window residual.

    ``r`` is the real record's residual per window, ``null`` the null residuals (replicates
    in rows). With ``median`` the across-window median is removed from both (a uniform change
    of the noise level is the tau view's business). Each window's score is ``z_w = r_w /
    s_w`` (``s_w`` the null spread); every null value is scored against the OTHER replicates'
    spread (leave-one-out: the real record is not part of the spread estimate either, so with
    few replicates its score has heavier tails than in-sample null scores). The threshold and
    p-value come from a Gumbel law fitted to the null's ``max_w |z_w|``.

    With ``sides`` the largest and the smallest score each get their own Gumbel law (fitted
    to the null's ``max_w z_w`` and ``max_w -z_w``), for a skewed per-window law: the log of a
    mean over few pieces (``dyn``: 15 block-mean differences) has an exponential lower tail
    and a light upper one; one law of ``max |z|`` mixes the two sides, so the lowest window
    took the whole level (600 null flicker records: every p < 0.05 from the lowest window, 36
    against a binomial bound of 28) and a raised window had to pass the lower side's
    threshold. The p-value is twice the smaller side's
    (Bonferroni), each side's threshold is its ``1 - alpha/2`` quantile, and the reported
    scores are on the upper side's scale (``z_w`` below zero times ``thr_+ / thr_-``), so
    ``|z| > threshold`` flags a window past its own side's threshold.
    """
    r = np.asarray(r, dtype=np.float64)
    null = np.asarray(null, dtype=np.float64)
    if median:
        r = r - np.median(r)
        null = null - np.median(null, axis=1, keepdims=True)
    n_rep = null.shape[0]
    sd = null.std(axis=0, ddof=1)
    sd = np.where(sd > 0, sd, np.inf)
    zf = r / sd
    loo = np.sqrt(np.maximum((np.sum(null**2, axis=0) - null**2) / max(n_rep - 2, 1), 1e-300))
    z_null = null / np.where(np.isfinite(sd), loo, np.inf)
    if not sides:
        zmax_null = np.abs(z_null).max(axis=1)
        return WindowScan(
            z=zf,
            threshold=gumbel_isf(alpha, zmax_null),
            p_value=gumbel_sf(float(np.abs(zf).max()), zmax_null),
            residual=r,
            spread=sd,
            null_max=zmax_null,
        )
    up, low = z_null.max(axis=1), (-z_null).max(axis=1)
    thr_up, thr_low = gumbel_isf(alpha / 2.0, up), gumbel_isf(alpha / 2.0, low)
    p = 2.0 * min(gumbel_sf(float(zf.max()), up), gumbel_sf(float(-zf.min()), low))
    ratio = thr_up / thr_low if thr_up > 0 and thr_low > 0 else 1.0
    return WindowScan(
        z=np.where(zf < 0, zf * ratio, zf),
        threshold=thr_up,
        p_value=float(min(1.0, p)),
        residual=r,
        spread=sd,
        null_max=np.maximum(up, low * ratio),
    )


def time_view(
    x: NDArray[np.float64],
    fs: float,
    real: dict[str, NDArray[np.float64]],
    ens: NullEnsemble,
    plan: TimePlan,
    alpha: float,
) -> TimeView:
    """Per-window scan, change points, spikes and kurtosis checks of the time view."""
    length = plan.length
    alpha = alpha / 8.0  # eight statistics share the view's level (Bonferroni)
    z: dict[str, NDArray[np.float64]] = {}
    thr: dict[str, float] = {}
    fam_p: dict[str, float] = {}
    flagged: dict[str, NDArray[np.bool_]] = {}
    residual: dict[str, NDArray[np.float64]] = {}
    spread: dict[str, NDArray[np.float64]] = {}
    null_max: dict[str, NDArray[np.float64]] = {}
    for fam in WINDOW_FAMILIES:
        # a skewed per-window law (the log of a mean over few pieces) gets a law per side
        scan = window_scan(
            ens.residual(real, fam), ens.null[fam], alpha, sides=fam in SKEWED_FAMILIES,
            median=fam in ("hf", "dyn"),
        )  # fmt: skip
        thr[fam], fam_p[fam] = scan.threshold, scan.p_value
        z[fam] = scan.z
        flagged[fam] = np.abs(scan.z) > scan.threshold
        residual[fam], spread[fam], null_max[fam] = scan.residual, scan.spread, scan.null_max
    # level changes: the step scan shares the jump family's level with the largest jump
    steps = step_scan(
        ens.residual(real, "jump"), ens.null["jump"], length / fs, alpha / 2.0,
        real_scale=float(np.mean(ens.real_scale)),
    )  # fmt: skip
    fam_p["jump"] = min(1.0, 2.0 * min(fam_p["jump"], steps.p_value))
    # record-wide statistics
    fam_p["spike"], spike_thr = spike_test(real, ens, alpha)
    fam_p["tail"], tail = tail_test(real, ens)
    tail["spread"] = tail_spread(x)
    lf = _kurtosis_checks(x, real, ens, plan, fam_p)
    # localisation
    segments: list[tuple[float, float]] = []
    change_points: list[float] = []
    for a, b in runs(flagged["jump"]):
        w = a + int(np.argmax(np.abs(z["jump"][a : b + 1])))
        k = _change_point(x, w * length, (w + 2) * length)
        t = k / fs
        change_points.append(t)
        segments.append((max(t - length / (4 * fs), 0.0), t + length / (4 * fs)))
    # the scan's located steps are reported (``steps``) and localised, but they are not the
    # change points the step candidate's level misfit gets for free: a warm-up's settling
    # reads as a staircase of located steps at the record's start, which would make a bias-step
    # process the cheapest reading of every transient (the warm-up + Gauss-Markov pair)
    segments.extend(st.t_interval_s for st in steps.steps)
    for fam in ("hf", "dyn") + (() if change_points else ("level",)):
        for a, b in runs(flagged[fam]):
            segments.append((a * length / fs, (b + 1) * length / fs))
    spike_idx: list[int] = []
    spike_amp: list[float] = []
    if fam_p["spike"] < alpha and spike_thr:
        # the lowest significant order's threshold: a higher order's lower threshold would
        # also list samples the null reaches (~1.3 of them above the 8th largest's level)
        spike_idx, spike_amp = _spikes(x, spike_thr[0])
        listed = [spike_idx[i] for i in largest_spikes(spike_amp)]
        segments.extend(((k - 1) / fs, (k + 1) / fs) for k in listed)
    spike_raise = _spike_raise(real.get("hf"), spike_idx, spike_amp, plan)
    kurt = {
        "hf_real": float(real["kurt_hf"][0]),
        "hf_sim": float(ens.ref["kurt_hf"][0]),
        # the samples minus their running mean (sample-level scale mixtures, dropped samples)
        "hf_samples_real": float(real["kurt_hf"][-1]),
        "hf_samples_sim": float(ens.ref["kurt_hf"][-1]),
        "lf_real": float(real["kurt_lf"][0]),
        "lf_sim": float(ens.ref["kurt_lf"][0]),
    }
    return TimeView(
        t_s=np.asarray((np.arange(plan.n_windows) + 0.5) * length / fs, dtype=np.float64),
        window_s=length / fs,
        level=real["level"],
        level_sd=ens.null["level"].std(axis=0, ddof=1),
        z=z,
        thresholds=thr,
        family_p=fam_p,
        kurtosis=kurt,
        spike_times_s=[k / fs for k in spike_idx],
        spike_amplitudes=spike_amp,
        change_points_s=change_points,
        segments_s=_merge(segments),
        residual=residual,
        spread=spread,
        null_max=null_max,
        lf_kurtosis=lf,
        spike_raise=spike_raise,
        tail=tail,
        steps=steps,
    )


def spike_test(
    real: dict[str, NDArray[np.float64]], ens: NullEnsemble, alpha: float
) -> tuple[float, list[float]]:
    """p-value of the spike statistic (Bonferroni over the orders) and the spike thresholds.

    The replicates' pooled peak counts (:func:`spike_features`, :attr:`NullEnsemble.pooled`)
    give the per-sample rate ``q(x)`` of peaks above ``x``
    (:class:`~allanite.diagnosis.null.ExceedanceTail`, measured where the pooled samples reach
    and extrapolated exponentially beyond); the real record's k-th largest peak ``r_k`` of
    ``n`` samples has ``p_k = P(Poisson(n q(r_k)) >= k)`` for each k of :data:`SPIKE_ORDERS`,
    and the p-value is ``min(1, 4 min p_k)``. Against a simulated record (its replicates are
    Gaussian surrogates) the rate is at least the record's own, level by level. The
    thresholds (units of the robust spread) are those of the significant orders: order ``k``
    is significant when ``r_k`` exceeds the level the k-th largest exceeds with probability
    ``alpha / len(orders)``: then at least ``k`` peaks lie above it. Listed by order (the
    first is the lowest significant order's, the level the spikes are located at).
    """
    if any(name not in ens.pooled for name in SPIKE_POOLED) or ens.n_pooled < 1:
        raise ValueError(
            "the null ensemble has no pooled spike counts: build it with "
            "NullEnsemble.from_model / from_record from time_features of the replicates"
        )
    n_rep = float(ens.pooled["spike_n"][0])
    # a simulated record's own tail counts too: its Gaussian surrogates do not carry it
    own = (ens.ref["spike_tail"], float(ens.ref["spike_n"][0])) if ens.sim_record else None
    tail = ExceedanceTail.from_counts(
        SPIKE_GRID, ens.pooled["spike_tail"] * ens.n_pooled, ens.n_pooled * n_rep, own
    )
    n = float(real["spike_n"][0])
    values = real["spike"]
    orders = SPIKE_ORDERS[: values.size]
    level = alpha / len(orders)
    p = min(tail.kth_sf(float(v), n, k) for v, k in zip(values, orders, strict=True))
    out = []
    for v, k in zip(values, orders, strict=True):
        thr = tail.kth_isf(level, n, k)
        if v > thr:
            out.append(thr)
    return float(min(1.0, len(orders) * p)), out


def tail_test(
    real: dict[str, NDArray[np.float64]], ens: NullEnsemble
) -> tuple[float, dict[str, Any]]:
    r"""p-value of the tail's shape: more moderate deviations than the simulated sensor has.

    ``a = |hp| / spread`` as in :func:`tail_features` (``hp``: the samples minus their
    :data:`TAIL_MEAN`-sample running mean). The statistic is the score of a scale mixture over
    the band :data:`TAIL_BAND` = ``[x_0, x_1)``,

    .. math:: S = \sum_{x_0 \le a_i < x_1} e^{a_i^2 / 4},

    the likelihood ratio's weight (up to constants) of a small share of samples with
    ``sqrt(2)`` times the spread against Gaussian samples, ``e^{a^2 (1 - 1/2) / 2}``: each
    moderate deviation counts, the more the larger, while the far tail at or above ``x_1`` (a
    few spikes, which the spike statistic judges) does not count at all. ``S`` is judged
    against the replicates: its expected value ``m = n s_ref`` (``s_ref`` the reference mean
    per sample, ``n`` the record's samples) and variance ``v = n^2 var(null residuals)``, at
    least ``m e^{x_0^2 / 4}`` (a compound Poisson sum's ``m E[w^2] / E[w]``); its law is the
    gamma law of that mean and variance, ``p = P(G >= S)``, one-sided (a sum of few positive
    weights is right-skewed; the null calibration is measured in
    ``tests/test_diagnosis_tail_shape.py`` and ``benchmarks/results/*_tailshape*``).

    A scale mixture (one rate sample in ten the sum of two increments, a noise level that
    changes from sample to sample) puts many samples at 3-4.5 spreads: ``P(|Z| >= 3) = 0.27 %``
    for Gaussian samples, ~0.6 % when one sample in ten has ``sqrt(2)`` times the spread.
    Spikes of more than 4.5 spreads lie above the band, so a spikes effect that explains the far
    tail (the spike statistic, the kurtosis) leaves this one standing: the statistic tells a
    scale mixture from a few spikes. ``S / n`` is a mean over the samples, so the long-record
    null rescales it like the other means (:func:`allanite.diagnosis.null.rescaled`).

    When no replicate reaches the band (a bounded law such as quantization noise) the gamma
    law is undefined and the p-value is the Monte Carlo one, ``(1 + #{null >= S}) / (1 +
    n_null)``: 1 when the record does not reach the band either.

    Returns the p-value and the details (``band``, the real ``score`` and the ``expected``
    one, the ``levels`` of :data:`TAIL_LEVELS` with the real ``count`` of samples between
    each and the band's cap and the ``expected_count``, ``n``).
    """
    if "tail" not in ens.ref or "tail" not in real:
        raise ValueError(
            "the null ensemble has no tail-shape feature: build it from time_features of the "
            "replicates (it returns 'tail' next to spike_features' 'spike_n')"
        )
    n = float(real["spike_n"][0])
    lo = TAIL_BAND[0]
    value = np.asarray(real["tail"], dtype=np.float64) * n
    expected = np.asarray(ens.ref["tail"], dtype=np.float64) * n
    mean = max(float(expected[0]), 1e-300)
    # at least a compound Poisson sum's variance, ``m E[w^2] / E[w] >= m w_min``
    null = np.asarray(ens.null["tail"][:, 0], dtype=np.float64)
    var = max(float(null.var(ddof=1)) * n * n, mean * math.exp(0.25 * lo * lo))
    if expected[0] > 0 and var > 0:
        p = float(stats.gamma.sf(value[0], mean * mean / var, scale=var / mean))
    else:  # the replicates never reach the band (a bounded law, e.g. quantization noise):
        # the Monte Carlo p-value, 1 when the record does not reach it either
        reached = np.count_nonzero(expected[0] + null * n >= value[0])
        p = float((1 + reached) / (1 + null.size))
    details = {
        "band": list(TAIL_BAND),
        "score": float(value[0]),
        "expected": float(expected[0]),
        "levels": list(TAIL_LEVELS),
        "count": value[1:].round().tolist(),
        "expected_count": expected[1:].tolist(),
        "n": n,
    }
    return p, details


def _spike_raise(
    hf: NDArray[np.float64] | None, idx: list[int], amp: list[float], plan: TimePlan
) -> NDArray[np.float64]:
    """Per-window raise of the log mean square of first differences that the spikes cause.

    A spike of height ``h`` enters two first differences, adding ``2 h^2`` to their sum of
    squares over the window's ``L - 1`` differences (see :attr:`TimeView.spike_raise`).
    """
    w = plan.n_windows
    if hf is None or hf.size != w:
        return np.zeros(w, dtype=np.float64)
    added = np.zeros(w, dtype=np.float64)
    for k, h in zip(idx, amp, strict=True):
        if k < w * plan.length:
            added[k // plan.length] += 2.0 * h * h / (plan.length - 1)
    total = np.exp(hf)
    rest = np.maximum(total - added, 1e-12 * total)
    return np.asarray(np.log(total / rest), dtype=np.float64)
