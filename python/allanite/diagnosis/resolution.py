r"""The output resolution of a record and the repeats it explains.

Real sensors and loggers quantize: ADC counts times an LSB, pulse counts of a ring-laser or
fibre gyro, a logger that rounds. Equal consecutive samples are then the rule, not a defect,
and a check for *held* samples (a logger that repeats the last value when one is missing)
must compare the repeats with what the resolution and the record's own level distribution
explain.

* :func:`output_resolution`: the lattice ``q`` the samples' first differences lie on, found by
  a lattice fit that tolerates float rounding. Differences below :data:`ROUNDING_ULPS` units
  in the last place of the samples are rounding, not steps (an angle accumulated in float and
  differenced makes equal counts differ by ``1e-15``); a candidate ``q`` (the smallest step of
  at least ``1e-2``, then ``1e-3``, then ``1e-6`` of the median step: the coarsest lattice
  first, and never the float grid itself, on which every float record lies) is refined by least
  squares over the steps of one to eight units, ``q = sum(k a) / sum(k^2)``, and accepted when
  :data:`LATTICE_SHARE` of all steps lie within :data:`LATTICE_TOL` of a multiple and at least
  :data:`RESOLVED` per sign are of one unit. Continuous samples have no such lattice.
* :func:`expected_repeats`: the probability that a sample repeats its predecessor without any
  holding, the larger of two laws (the alarm is raised only against both):

  - *independent levels*: two samples drawn from the record's local level distribution are
    equal with probability ``sum_k p_k^2``; estimated without bias as the share of equal pairs
    among the ``W (W - 1)`` ordered pairs of windows of :data:`PAIR_WINDOW` samples (the
    windows follow a drift). This is the law of pulse or count increments, which are close to
    independent (three levels at 13/66/21 % repeat ``0.13^2 + 0.66^2 + 0.21^2 = 49.6 %``);
  - *a quantized continuous difference*: a sample ``x_k = x_{k-1} + Delta`` rounded to the
    lattice with a uniformly distributed phase gives the integer step ``j`` with probability
    ``E[tri(Delta / q - j)]`` (``tri(v) = max(0, 1 - |v|)``, Widrow's quantization theorem).
    With ``Delta ~ N(mu, s^2)``, ``E[tri(Delta - j)] = G(j + 1) - 2 G(j) + G(j - 1)``,
    ``G(t) = (t - mu) Phi(z) + s phi(z)``, ``z = (t - mu) / s``; ``mu`` and ``s`` are the
    maximum-likelihood fit to the non-zero steps within the 99th percentile (so spikes do
    not widen it) and the zero steps are extrapolated from them. This is the law of a
    quantized rate whose samples are correlated (a sensor's own low-pass filter makes
    neighbours far more alike than independent draws).

The test (:func:`held_excess`) is one-sided on blocks: with ``P_b`` the repeat probability
of block ``b`` from its own levels and steps, the block's share of samples held beyond it is
``h_b = (n0_b / m_b - P_b) / (1 - P_b)``; their mean is compared with :data:`HELD_FLOOR` by a
Student t test over the blocks (their spread carries the correlation of the repeats and any
misfit of the laws). A logger that holds, on average, more than :data:`HELD_FLOOR` of the
samples is what the test looks for.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import optimize, stats

__all__ = [
    "HeldExcess",
    "expected_repeats",
    "held_excess",
    "output_resolution",
    "rounding_floor",
]

#: differences below this many units in the last place of the samples are float rounding
ROUNDING_ULPS = 16.0
#: a step lies on the lattice when ``|a / q - round(a / q)|`` is at most this
LATTICE_TOL = 0.1
#: ... and the samples are quantized when this share of all steps does
LATTICE_SHARE = 0.99
#: candidate spacings: the smallest step of at least these shares of the median step, the
#: coarsest first; a spacing below a millionth of the median step is the float grid itself
#: (an accumulated angle differenced), never a sensor's resolution
LATTICE_CUTS = (1e-2, 1e-3, 1e-6)
#: steps of one resolution unit (per sign) needed to call the samples quantized
RESOLVED = 5
#: widest step (units) the quantized-difference law is fitted over
MAX_SPAN = 2000
#: samples per window of the independent-levels law
PAIR_WINDOW = 64
#: the held share of samples the test looks beyond: the laws' misfit stays below it (measured
#: on the ADIS16405 accelerometer counts of the shared data, a few correlated levels with a
#: non-uniform phase: up to 0.021 in a half record; 0.003 on its gyro counts, |h| < 0.005
#: on the independent generators of tests/test_resolution.py)
HELD_FLOOR = 0.025
#: at most this many blocks, of at least BLOCK_MIN samples, for the t test
MAX_BLOCKS = 16
BLOCK_MIN = 256


def rounding_floor(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Size below which the difference of consecutive samples is float rounding."""
    mag = np.maximum(np.abs(x[1:]), np.abs(x[:-1]))
    return np.asarray(ROUNDING_ULPS * np.finfo(np.float64).eps * mag, dtype=np.float64)


def _lattice_fit(a: NDArray[np.float64], q0: float) -> float | None:
    """The lattice spacing near ``q0`` that the steps ``a`` (all > 0) lie on, or None."""
    q = q0
    for _ in range(3):
        k = np.rint(a / q)
        small = (k >= 1) & (k <= 8)
        if not small.any():
            return None
        q = float(np.sum(k[small] * a[small]) / np.sum(k[small] ** 2))
    k = np.rint(a / q)
    on = np.abs(a / q - k) <= LATTICE_TOL
    if np.count_nonzero(k == 1) < 2 * RESOLVED or on.mean() < LATTICE_SHARE:
        return None
    return q


def output_resolution(samples: NDArray[np.float64]) -> float | None:
    """The resolution (lattice spacing) of the samples, or None when they are continuous.

    Parameters
    ----------
    samples : ndarray
        One channel, as recorded.

    Returns
    -------
    float or None
        ``q`` such that the first differences are integer multiples of it within
        :data:`LATTICE_TOL` (float rounding tolerated); None for continuous samples.
    """
    x = np.asarray(samples, dtype=np.float64).ravel()
    if x.size < 3:
        return None
    a = np.abs(np.diff(x))
    a = a[a > rounding_floor(x)]
    if a.size < 2 * RESOLVED:
        return None
    med = float(np.median(a))
    tried: set[float] = set()
    for cut in LATTICE_CUTS:
        q0 = float(a[a >= cut * med].min())
        if q0 in tried:
            continue
        tried.add(q0)
        q = _lattice_fit(a, q0)
        if q is not None:
            return q
    return None


def _pair_equality(levels: NDArray[np.int64]) -> float:
    """Share of equal pairs among the ordered pairs of each window (independent levels)."""
    w = PAIR_WINDOW
    n = levels.size // w * w
    if n == 0:
        return 0.0
    lv = levels[:n] - levels[:n].min()
    key = np.arange(n, dtype=np.int64) // w * (int(lv.max()) + 1) + lv
    _, counts = np.unique(key, return_counts=True)
    c = counts.astype(np.float64)
    return float(np.sum(c * (c - 1.0)) / ((n // w) * w * (w - 1.0)))


def _step_law(j: NDArray[np.float64], mu: float, s: float) -> NDArray[np.float64]:
    """``P(step = j)`` for ``Delta ~ N(mu, s^2)`` quantized with a uniform phase (q units)."""

    def g(t: NDArray[np.float64]) -> NDArray[np.float64]:
        z = (t - mu) / s
        return np.asarray((t - mu) * stats.norm.cdf(z) + s * stats.norm.pdf(z))

    return np.maximum(g(j + 1.0) - 2.0 * g(j) + g(j - 1.0), 1e-300)


def _quantized_difference(steps: NDArray[np.int64]) -> float:
    """Probability of a zero step extrapolated from the non-zero steps (quantized Gaussian)."""
    size = steps.size
    if size == 0:
        return 0.0
    span = max(2, int(np.ceil(np.quantile(np.abs(steps), 0.99))))
    if span > MAX_SPAN:  # far finer than the noise: a zero step is as likely as a neighbour
        return float(np.mean(np.abs(steps) == 1)) / 2.0
    inside = steps[(np.abs(steps) <= span) & (steps != 0)]
    if inside.size < RESOLVED:
        return 0.0
    j, n_j = np.unique(inside, return_counts=True)
    jj = j.astype(np.float64)
    grid = np.arange(-span, span + 1, dtype=np.float64)
    grid = grid[grid != 0]

    def nll(theta: NDArray[np.float64]) -> float:
        mu, s = float(theta[0]), float(np.exp(theta[1]))
        norm = float(np.sum(_step_law(grid, mu, s)))
        return -float(np.sum(n_j * np.log(_step_law(jj, mu, s) / norm)))

    var = float(np.var(inside))
    start = np.array([float(np.mean(inside)), 0.5 * np.log(max(var - 1.0 / 6.0, 0.05))])
    res = optimize.minimize(nll, start, method="Nelder-Mead", options={"xatol": 1e-4})
    mu, s = float(res.x[0]), float(np.exp(res.x[1]))
    p0 = float(_step_law(np.zeros(1), mu, s)[0])
    expected = inside.size * p0 / float(np.sum(_step_law(grid, mu, s)))
    return float(expected) / float(size)


def expected_repeats(levels: NDArray[np.int64]) -> float:
    """Probability that a sample repeats its predecessor without holding (larger law).

    Parameters
    ----------
    levels : ndarray of int
        The samples as integer multiples of the resolution.
    """
    steps = np.diff(levels)
    return float(max(_pair_equality(levels), _quantized_difference(steps)))


@dataclass(frozen=True)
class HeldExcess:
    """Repeats of a quantized record against what its resolution explains.

    Attributes
    ----------
    resolution : float
        The lattice spacing ``q``.
    count : int
        Zero steps (samples equal to their predecessor within rounding).
    expected : float
        Zero steps the record's levels and steps explain, summed over the blocks.
    held_share : float
        Mean share of samples held beyond that, ``mean(h_b)``.
    p_value : float
        One-sided p-value of ``mean(h_b) <= HELD_FLOOR`` (1 when it cannot be judged).
    """

    resolution: float
    count: int
    expected: float
    held_share: float
    p_value: float


def held_excess(samples: NDArray[np.float64], resolution: float) -> HeldExcess:
    """Test the repeats of a quantized record against its resolution, block by block."""
    x = np.asarray(samples, dtype=np.float64).ravel()
    levels = np.rint((x - x[0]) / resolution).astype(np.int64)
    zero = np.diff(levels) == 0
    n_blocks = min(MAX_BLOCKS, zero.size // BLOCK_MIN)
    if n_blocks < 4:
        return HeldExcess(resolution, int(zero.sum()), float("nan"), 0.0, 1.0)
    edges = np.linspace(0, zero.size, n_blocks + 1).astype(np.int64)
    shares, expected = [], 0.0
    for lo, hi in itertools.pairwise(edges.tolist()):
        p = min(expected_repeats(levels[lo : hi + 1]), 1.0 - 1e-9)
        m = hi - lo
        expected += p * m
        shares.append((float(zero[lo:hi].mean()) - p) / (1.0 - p))
    h = np.asarray(shares)
    sd = float(np.std(h, ddof=1)) / np.sqrt(h.size)
    mean = float(h.mean())
    if sd == 0.0:
        p_value = 0.0 if mean > HELD_FLOOR else 1.0
    else:
        p_value = float(stats.t.sf((mean - HELD_FLOOR) / sd, h.size - 1))
    return HeldExcess(resolution, int(zero.sum()), expected, mean, p_value)
