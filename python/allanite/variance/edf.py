r"""Equivalent degrees of freedom and power-law noise identification.

Confidence limits of an Allan-family variance follow from a chi-square distribution with
``edf`` equivalent degrees of freedom (NIST SP1065 eq. 41). The EDF depends on the estimator,
the averaging factor, the record length and the dominant power-law noise
:math:`S_y(f) \propto f^\alpha`. This module computes

* the EDF of the overlapping/standard Allan, modified Allan (and time) and overlapping/standard
  Hadamard variances by the combined algorithm of Greenhall & Riley (2003);
* the EDF of the total variance by the empirical formulas of SP1065 (Table 11);
* the dominant noise exponent ``alpha`` at every averaging factor from the data, as Stable32
  does: the lag-1 autocorrelation method of Riley & Greenhall (2004) while at least 30
  decimated points remain, otherwise the B1 bias ratio (Howe et al. 2000), refined by the R(n)
  ratio between white and flicker phase noise. With so few points B1 and R(n) often read noise
  as phase noise at one long tau among frequency-noise neighbours, which inflates that tau's EDF
  (e.g. 127 between 9 and 7); beyond the longest tau the lag-1 method identified, the exponent
  is therefore capped at that tau's (:func:`cap_few_point_alpha`: noise moves toward lower
  ``alpha`` as tau grows, and the cap can only lower the EDF, widening the interval).
  An exponent that differs from both of its neighbours in tau while they agree (one flip of
  the identification, e.g. 3801 -> 13196 -> 3031 in the example record) is replaced by theirs
  (:func:`smooth_isolated_alpha`, applied by :func:`~allanite.variance.avar` unless Stable32's
  per-tau
  identification is asked for with ``alpha="stable32"``): the noise type of a power-law
  spectrum changes over decades, not at one averaging time.

References
----------
C. A. Greenhall and W. J. Riley, "Uncertainty of stability variances based on finite
differences", Proc. 35th PTTI Meeting (2003), pp. 267-280.

W. J. Riley and C. A. Greenhall, "Power law noise identification using the lag 1
autocorrelation", Proc. 18th EFTF (2004).

D. A. Howe, R. L. Beard, C. A. Greenhall, F. Vernotte, W. J. Riley, "A total estimator of the
Hadamard function used for GPS operations", Proc. 32nd PTTI (2000), Tables 3-4.

W. J. Riley, *Handbook of Frequency Stability Analysis*, NIST SP1065 (2008), sections 5.2-5.6.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from allanite import _core

__all__ = [
    "ACF_MIN_POINTS",
    "EstimatorShape",
    "acf_noise_id",
    "b1_noise_id",
    "cap_few_point_alpha",
    "equivalent_dof",
    "estimator_shape",
    "greenhall_edf",
    "identify_alpha",
    "lag1_acf",
    "smooth_isolated_alpha",
    "totvar_edf",
    "wants_identification",
]

#: Fewest decimated points for the lag-1 autocorrelation method (Stable32's rule).
ACF_MIN_POINTS = 30

#: Greenhall & Riley's J_max: longer basic sums are replaced by the asymptotic tables.
_J_MAX = 100

# Greenhall & Riley (2003) Table 1 (modified variances, F = 1): (a0, a1) by alpha, d.
_TABLE1: dict[tuple[int, int], tuple[float, float]] = {
    (2, 1): (2 / 3, 1 / 3), (2, 2): (7 / 9, 1 / 2), (2, 3): (22 / 25, 2 / 3),
    (1, 1): (0.840, 0.345), (1, 2): (0.997, 0.616), (1, 3): (1.141, 0.843),
    (0, 1): (1.079, 0.368), (0, 2): (1.033, 0.607), (0, 3): (1.184, 0.848),
    (-1, 2): (1.048, 0.534), (-1, 3): (1.180, 0.816),
    (-2, 2): (1.302, 0.535), (-2, 3): (1.175, 0.777),
    (-3, 3): (1.194, 0.703),
    (-4, 3): (1.489, 0.702),
}  # fmt: skip

# Table 2 (unmodified variances, F = m): (a0, a1) by alpha, d.
_TABLE2: dict[tuple[int, int], tuple[float, float]] = {
    (2, 1): (3 / 2, 1 / 2), (2, 2): (35 / 18, 1.0), (2, 3): (231 / 100, 3 / 2),
    (1, 1): (78.6, 25.2), (1, 2): (790.0, 410.0), (1, 3): (9950.0, 6520.0),
    (0, 1): (2 / 3, 1 / 6), (0, 2): (2 / 3, 1 / 3), (0, 3): (7 / 9, 1 / 2),
    (-1, 2): (0.852, 0.375), (-1, 3): (0.997, 0.617),
    (-2, 2): (1.079, 0.368), (-2, 3): (1.033, 0.607),
    (-3, 3): (1.053, 0.553),
    (-4, 3): (1.302, 0.535),
}  # fmt: skip

# Table 3 (unmodified variances, flicker PM, alpha = 1): (b0, b1) by d.
_TABLE3: dict[int, tuple[float, float]] = {1: (6.0, 4.0), 2: (15.23, 12.0), 3: (47.8, 40.0)}

# SP1065 Table 11, total variance EDF = b (T / tau) - c, by alpha.
_TOTVAR: dict[int, tuple[float, float]] = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}


@dataclass(frozen=True)
class EstimatorShape:
    """How an estimator filters the phase, in Greenhall & Riley's notation.

    Attributes
    ----------
    d : int
        Order of the phase difference (2 Allan, 3 Hadamard).
    overlapping : bool
        Stride ``tau / m`` (every sample) rather than ``tau``.
    modified : bool
        Phase averaged over ``m`` samples before differencing (filter factor F = 1).
    """

    d: int
    overlapping: bool
    modified: bool


_SHAPES = {
    "overlapping": EstimatorShape(2, True, False),
    "standard": EstimatorShape(2, False, False),
    "modified": EstimatorShape(2, True, True),
    "hadamard": EstimatorShape(3, True, False),
    "standard_hadamard": EstimatorShape(3, False, False),
    "total": EstimatorShape(2, True, False),
}


def estimator_shape(kind: str) -> EstimatorShape:
    """Difference order and structure of a kernel kind (``total`` counts as Allan, d = 2)."""
    try:
        return _SHAPES[kind]
    except KeyError:
        raise ValueError(f"unknown kind {kind!r}; use one of {', '.join(_SHAPES)}") from None


def _alpha_range(d: int) -> tuple[int, int]:
    """Noise exponents a difference of order d can handle: alpha + 2 d > 1, alpha <= 2."""
    return 2 - 2 * d, 2


# --------------------------------------------------------------------------------------------
# Greenhall & Riley (2003) EDF


def _sw(t: NDArray[np.float64], alpha: int) -> NDArray[np.float64]:
    """Generalised autocovariance of the continuous power-law process, G&R eq. (7)."""
    a = np.abs(t)
    if alpha == 2:
        return -a
    if alpha == 0:
        return a**3
    if alpha == -2:
        return -(a**5)
    if alpha == -4:
        return a**7
    log_a = np.log(a, out=np.zeros_like(a), where=a > 0)  # t^k log|t| -> 0 at t = 0
    if alpha == 1:
        return a**2 * log_a
    if alpha == -1:
        return -(a**4) * log_a
    if alpha == -3:
        return a**6 * log_a
    raise ValueError(f"alpha must be an integer in [-4, 2], got {alpha}")


def _sx(t: NDArray[np.float64], f: float, alpha: int) -> NDArray[np.float64]:
    """Autocovariance of the (filtered) phase, G&R eq. (8); f = inf is the unfiltered limit."""
    if math.isinf(f):
        return _sw(t, alpha + 2)
    return f * f * (2.0 * _sw(t, alpha) - _sw(t - 1.0 / f, alpha) - _sw(t + 1.0 / f, alpha))


_BINOMIAL_ROWS = {1: (2, -1), 2: (6, -4, 1), 3: (20, -15, 6, -1)}


def _sz(t: NDArray[np.float64], f: float, alpha: int, d: int) -> NDArray[np.float64]:
    """Autocovariance of the d-th difference, G&R eq. (9)."""
    row = _BINOMIAL_ROWS[d]
    out = row[0] * _sx(t, f, alpha)
    for k, c in enumerate(row[1:], start=1):
        out = out + c * (_sx(t - k, f, alpha) + _sx(t + k, f, alpha))
    return out


def _basic_sum(j: int, big_m: float, s: float, f: float, alpha: int, d: int) -> float:
    """G&R eq. (10): sz(0)^2 + 2 sum_{i<J} (1 - i/M) sz(i/S)^2 + (1 - J/M) sz(J/S)^2."""
    i = np.arange(1, j, dtype=np.float64)
    first = float(_sz(np.array([0.0]), f, alpha, d)[0]) ** 2
    last = (1.0 - j / big_m) * float(_sz(np.array([j / s]), f, alpha, d)[0]) ** 2
    middle = float(np.sum(2.0 * (1.0 - i / big_m) * _sz(i / s, f, alpha, d) ** 2))
    return first + middle + last


def _sz0_squared(f: float, alpha: int, d: int) -> float:
    return float(_sz(np.array([0.0]), f, alpha, d)[0]) ** 2


@functools.lru_cache(maxsize=4096)
def greenhall_edf(
    alpha: int, d: int, m: int, n_phase: int, *, overlapping: bool, modified: bool
) -> float:
    r"""Equivalent degrees of freedom by the combined algorithm of Greenhall & Riley (2003).

    The estimator averages :math:`M = 1 + \lfloor S (N - L) / m \rfloor` squared d-th
    differences of the phase (filter length :math:`L = m/F + m d`, stride factor ``S = m`` for
    overlapping and 1 for non-overlapping estimators, filter factor ``F = 1`` for modified and
    ``m`` for unmodified variances). With :math:`J = \min(M, (d+1) S)` and the autocovariance
    :math:`s_z` of the differenced pure power-law process,

    .. math:: \frac{1}{\mathrm{edf}} = \frac{1}{M s_z(0)^2}\Big[s_z(0)^2
              + 2\sum_{j=1}^{J-1}\big(1-\tfrac{j}{M}\big)s_z(j/S)^2
              + \big(1-\tfrac{J}{M}\big)s_z(J/S)^2\Big],

    replaced by the paper's tables and limits for long sums (J > 100), flicker PM
    (``alpha = 1``) and white PM (``alpha = 2``).

    Parameters
    ----------
    alpha : int
        Power-law exponent of the frequency noise, ``2`` (white PM) ... ``-4``; must satisfy
        ``alpha + 2 d > 1``.
    d : int
        Difference order: 2 for the Allan family, 3 for Hadamard.
    m : int
        Averaging factor.
    n_phase : int
        Number of phase points ``N``.
    overlapping : bool
        Overlapping estimator (stride 1 sample).
    modified : bool
        Modified variance (phase averaged over ``m`` samples).

    Returns
    -------
    float
        The equivalent degrees of freedom.

    Raises
    ------
    ValueError
        If ``alpha`` is outside what the difference order can measure or the record is shorter
        than one filter length.
    """
    lo, hi = _alpha_range(d)
    if d not in (1, 2, 3):
        raise ValueError(f"difference order d must be 1, 2 or 3, got {d}")
    if not lo <= alpha <= hi:
        raise ValueError(
            f"alpha = {alpha} is outside [{lo}, {hi}], the noise types a difference of order "
            f"{d} can measure (alpha + 2d > 1)"
        )
    if m < 1:
        raise ValueError(f"averaging factor m must be at least 1, got {m}")
    f: float = 1.0 if modified else float(m)
    s = float(m) if overlapping else 1.0
    filter_len = m / f + m * d
    if n_phase < filter_len:
        raise ValueError(
            f"{n_phase} phase points are fewer than one filter length ({filter_len:g}) for "
            f"m = {m}, d = {d}"
        )
    big_m = 1.0 + math.floor(s * (n_phase - filter_len) / m)
    j = int(min(big_m, (d + 1) * s))
    r = big_m / s

    if f == 1.0:  # case 1: modified variances (and unmodified ones at m = 1), every alpha
        if j <= _J_MAX:
            inv = _basic_sum(j, big_m, s, 1.0, alpha, d) / (big_m * _sz0_squared(1.0, alpha, d))
        elif r >= d + 1:
            a0, a1 = _TABLE1[(alpha, d)]
            inv = (a0 - a1 / r) / r
        else:
            mp = _J_MAX / r
            inv = _basic_sum(_J_MAX, _J_MAX, mp, 1.0, alpha, d) / (
                _J_MAX * _sz0_squared(1.0, alpha, d)
            )
    elif alpha <= 0:  # case 2: unmodified variances, white FM ... random run FM
        if j <= _J_MAX:
            fp = float(m) if m * (d + 1) <= _J_MAX else math.inf
            inv = _basic_sum(j, big_m, s, fp, alpha, d) / (big_m * _sz0_squared(fp, alpha, d))
        elif r >= d + 1:
            a0, a1 = _TABLE2[(alpha, d)]
            inv = (a0 - a1 / r) / r
        else:
            mp = _J_MAX / r
            inv = _basic_sum(_J_MAX, _J_MAX, mp, math.inf, alpha, d) / (
                _J_MAX * _sz0_squared(math.inf, alpha, d)
            )
    elif alpha == 1:  # case 3: unmodified variances, flicker PM
        b0, b1 = _TABLE3[d]
        if j <= _J_MAX:
            inv = _basic_sum(j, big_m, s, float(m), 1, d) / (big_m * _sz0_squared(float(m), 1, d))
        elif r >= d + 1:
            a0, a1 = _TABLE2[(1, d)]
            inv = (a0 - a1 / r) / (r * (b0 + b1 * math.log(m)) ** 2)
        else:
            mp = _J_MAX / r
            inv = _basic_sum(_J_MAX, _J_MAX, mp, mp, 1, d) / (_J_MAX * (b0 + b1 * math.log(m)) ** 2)
    else:  # case 4: unmodified variances, white PM
        k_max = math.ceil(r)
        if k_max <= d:
            centre = math.comb(2 * d, d) ** 2
            total = 1.0 + sum(
                2.0 * (1.0 - k / r) * math.comb(2 * d, d - k) ** 2 / centre for k in range(1, k_max)
            )
            inv = total / big_m
        else:
            a0, a1 = _TABLE2[(2, d)]
            inv = (a0 - a1 / r) / big_m
    return 1.0 / inv


def totvar_edf(alpha: int, m: int, n_phase: int) -> float:
    r"""EDF of the total variance as Stable32 reports it (NIST SP1065 sections 5.2.11, 5.3.1).

    Frequency noises use the TOTVAR formula of SP1065 Table 11,
    :math:`\mathrm{edf} = b\,T/\tau - c` with record length :math:`T = (N-1)\tau_0` and
    ``(b, c) = (1.50, 0)``, ``(1.17, 0.22)``, ``(0.93, 0.36)`` for white, flicker and random
    walk FM. The handbook has no TOTVAR formula for phase noise; there Stable32 uses the simple
    Allan-variance approximations of SP1065 Table 5 (Stein 1985):

    .. math:: \text{white PM: } \frac{(N+1)(N-2m)}{2(N-m)},\qquad
              \text{flicker PM: } \exp\sqrt{\ln\frac{N-1}{2m}\,\ln\frac{(2m+1)(N-1)}{4}}.

    Parameters
    ----------
    alpha : int
        Noise exponent (``2`` ... ``-2``).
    m : int
        Averaging factor.
    n_phase : int
        Number of phase points ``N``.

    Returns
    -------
    float
        Equivalent degrees of freedom.
    """
    n = float(n_phase)
    if alpha in _TOTVAR:
        b, c = _TOTVAR[alpha]
        return b * (n - 1.0) / m - c
    if alpha == 2:
        return (n + 1.0) * (n - 2.0 * m) / (2.0 * (n - m))
    if alpha == 1:
        a = math.log((n - 1.0) / (2.0 * m))
        b1 = math.log((2.0 * m + 1.0) * (n - 1.0) / 4.0)
        return math.exp(math.sqrt(max(a * b1, 0.0)))
    raise ValueError(f"alpha = {alpha} is outside [-2, 2], the range of the total variance")


def equivalent_dof(
    kind: str, alpha: NDArray[np.int64], m: NDArray[np.int64], n_phase: int
) -> NDArray[np.float64]:
    """EDF for every averaging factor and channel.

    Parameters
    ----------
    kind : str
        Kernel kind (``overlapping``, ``standard``, ``modified``, ``hadamard``,
        ``standard_hadamard``, ``total``); ``time`` uses ``modified``.
    alpha : numpy.ndarray
        Noise exponents, shape ``(T, C)`` (or ``(T,)``), clipped to the estimator's range.
    m : numpy.ndarray
        Averaging factors, shape ``(T,)``.
    n_phase : int
        Number of phase points.

    Returns
    -------
    numpy.ndarray
        EDF, shaped like ``alpha``.
    """
    shape = estimator_shape(kind)
    lo, hi = _alpha_range(shape.d) if kind != "total" else (-2, 2)
    alphas = np.asarray(alpha, dtype=np.int64)
    factors = np.asarray(m, dtype=np.int64)
    if alphas.shape[0] != factors.size:
        raise ValueError(f"alpha has {alphas.shape[0]} rows for {factors.size} averaging factors")
    width = int(np.prod(alphas.shape[1:]))
    clipped = np.clip(alphas, lo, hi).reshape(factors.size, width).tolist()
    cache: dict[tuple[int, int], float] = {}
    rows = []
    for mi, row in zip(factors.reshape(-1).tolist(), clipped, strict=True):
        for a in row:
            key = (a, mi)
            if key not in cache:
                if kind == "total":
                    cache[key] = totvar_edf(a, mi, n_phase)
                else:
                    cache[key] = greenhall_edf(
                        a,
                        shape.d,
                        mi,
                        n_phase,
                        overlapping=shape.overlapping,
                        modified=shape.modified,
                    )
        rows.append([cache[(a, mi)] for a in row])
    return np.array(rows, dtype=np.float64).reshape(alphas.shape)


# --------------------------------------------------------------------------------------------
# Noise identification


def lag1_acf(z: NDArray[np.float64]) -> float:
    r"""Lag-1 autocorrelation as Stable32 computes it (Riley & Greenhall 2004, eq. 2).

    .. math:: r_1 = \frac{N-1}{N}\,\frac{\sum_{i=0}^{N-2}(z_i-\bar z)(z_{i+1}-\bar z)}
              {\sum_{i=0}^{N-1}(z_i-\bar z)^2}

    Parameters
    ----------
    z : numpy.ndarray
        1-D series.

    Returns
    -------
    float
        The lag-1 autocorrelation (0 for a constant series).
    """
    z0 = np.asarray(z, dtype=np.float64) - np.mean(z)
    den = float(np.dot(z0, z0))
    if den == 0.0:
        return 0.0
    return float(np.dot(z0[:-1], z0[1:]) / den * (z0.size - 1) / z0.size)


def _acf_decision(r1_of_level: Callable[[int], float], dmax: int, n: int, *, phase: bool) -> int:
    r"""Riley & Greenhall's stopping rule on the lag-1 autocorrelations of successive levels.

    ``r1_of_level(d)`` is the lag-1 autocorrelation of the d-th difference of a series of ``n``
    values. Difference until :math:`\delta = r_1/(1+r_1) < 0.25`, ``d = dmax`` or fewer than
    3 values remain; then :math:`p = -\mathrm{round}(2\delta) - 2d`.
    """
    d = 0
    while True:
        r1 = r1_of_level(d)
        delta = r1 / (1.0 + r1)
        if delta < 0.25 or d >= dmax or n - d < 3:
            p = -round(2.0 * delta) - 2 * d
            return int(p + 2 if phase else p)
        d += 1


def _acf_decision_of(levels: list[float], dmax: int, n: int, phase: bool) -> int | None:
    """:func:`_acf_decision` on the levels computed so far; None when it needs a deeper one."""
    try:
        return _acf_decision(levels.__getitem__, dmax, n, phase=phase)
    except IndexError:
        return None


def acf_noise_id(z: NDArray[np.float64], dmax: int, *, phase: bool) -> int:
    r"""Dominant power-law exponent by the lag-1 autocorrelation (Riley & Greenhall 2004).

    The series is differenced until :math:`\delta = r_1/(1+r_1) < 0.25` or ``dmax``
    differences were taken; then :math:`p = -\mathrm{round}(2\delta) - 2d` and
    :math:`\alpha = p + 2` for phase data, ``p`` for frequency data.

    Parameters
    ----------
    z : numpy.ndarray
        Decimated phase (``phase=True``) or averaged frequency at the averaging time of interest.
    dmax : int
        Largest number of differences: 2 for the Allan family, 3 for Hadamard.
    phase : bool
        Whether ``z`` is phase data.

    Returns
    -------
    int
        Estimated ``alpha`` (not clipped).
    """
    levels = [np.asarray(z, dtype=np.float64)]

    def r1_of_level(d: int) -> float:
        while len(levels) <= d:
            levels.append(np.diff(levels[-1]))
        return lag1_acf(levels[d])

    return _acf_decision(r1_of_level, dmax, levels[0].size, phase=phase)


def _b1_expected(n: int, mu: int) -> float:
    """Return the expected B1 for n frequency averages, phase exponent mu (Howe et al. Table 3)."""
    if mu == 2:
        return n * (n + 1) / 6.0
    if mu == 1:
        return n / 2.0
    if mu == 0:
        return n * math.log(n) / (2.0 * (n - 1) * math.log(2.0))
    if mu == -1:
        return 1.0
    if mu == -2:
        return (n * n - 1.0) / (1.5 * n * (n - 1.0))
    return float(n * (1.0 - n**mu) / (2.0 * (n - 1.0) * (1.0 - 2.0**mu)))


def _rn_expected(m: int, alpha: int) -> float:
    """Return the expected MVAR/AVAR ratio R(n) for white (2) and flicker (1) PM (SP1065 5.6)."""
    if alpha == 2:
        return 1.0 / m
    return 3.37 / (1.04 + 3.0 * math.log(math.pi * m))


_MU_TO_ALPHA = {2: -3, 1: -2, 0: -1, -1: 0}


def _b1_frequency_class(ybar: NDArray[np.float64]) -> int | None:
    """B1 step of :func:`b1_noise_id`: ``alpha`` of a frequency noise, None for phase noise."""
    n = ybar.size
    if n < 3:
        return 0
    diffs = np.diff(ybar)
    avar = 0.5 * float(np.mean(diffs**2))
    if avar == 0.0:
        return 0
    b1 = float(np.var(ybar, ddof=1)) / avar
    expected = {mu: _b1_expected(n, mu) for mu in (2, 1, 0, -1, -2)}
    for mu in (2, 1, 0, -1):
        lo, hi = expected[mu - 1], expected[mu]
        boundary = 0.5 * (lo + hi) if mu == 2 else math.sqrt(lo * hi)
        if b1 > boundary:
            return _MU_TO_ALPHA[mu]
    return None


def _rn_phase_class(ratio: float | None, m: int) -> int:
    """R(n) step of :func:`b1_noise_id`: white (2) or flicker (1) PM; 1 without a ratio."""
    if ratio is None:
        return 1
    boundary = math.sqrt(_rn_expected(m, 1) * _rn_expected(m, 2))
    return 1 if ratio > boundary else 2


def b1_noise_id(
    ybar: NDArray[np.float64], m: int, rn: Callable[[], float | None] | float | None
) -> int:
    r"""Dominant power-law exponent from the B1 bias ratio (and R(n) for phase noise).

    :math:`B_1 = s^2 / \sigma_y^2` is the ratio of the sample variance of the ``n`` averaged
    frequency values to their (non-overlapping) Allan variance. It is compared with the
    expected values for phase exponents ``mu = 2 ... -2`` at the geometric-mean boundaries
    (arithmetic between ``mu = 2`` and ``1``); ``mu = -2`` (white or flicker PM) is split by the
    ratio :math:`R(n) = \mathrm{MVAR}/\mathrm{AVAR}` against ``1/m`` and
    ``3.37/(1.04 + 3\ln(\pi m))``.

    Parameters
    ----------
    ybar : numpy.ndarray
        Non-overlapping averages of the frequency over ``m`` samples (at least 2).
    m : int
        Averaging factor.
    rn : float, callable or None
        Measured R(n) at ``m`` (or a function computing it, called only when needed), or None
        when the modified variance is unavailable (then flicker PM is reported for phase
        noise).

    Returns
    -------
    int
        Estimated ``alpha``.
    """
    alpha = _b1_frequency_class(np.asarray(ybar, dtype=np.float64))
    if alpha is not None:
        return alpha
    return _rn_phase_class(rn() if callable(rn) else rn, m)


def _uncapped(
    pending: list[tuple[int, int]],
    out: NDArray[np.int64],
    factors: NDArray[np.int64],
    n_series: NDArray[np.int64],
) -> list[tuple[int, int]]:
    """The (tau, channel) of ``pending`` whose R(n) answer survives :func:`cap_few_point_alpha`.

    The others get the "no ratio" answer (flicker PM, 1), which the cap then replaces by the
    exponent (at most 1) of the longest factor identified by the lag-1 method.
    """
    reliable = n_series >= ACF_MIN_POINTS
    if not pending or not reliable.any():
        return pending
    ref = int(np.flatnonzero(reliable)[np.argmax(factors[reliable])])
    kept = []
    for i, c in pending:
        if factors[i] > factors[ref] and out[ref, c] <= 1:
            out[i, c] = _rn_phase_class(None, int(factors[i]))
        else:
            kept.append((i, c))
    return kept


def _mvar_avar_ratios(
    phase: NDArray[np.float64], factors: list[int], threads: int
) -> dict[int, NDArray[np.float64]]:
    """R(n) = MVAR / AVAR (overlapping) of every channel at each factor (compiled, one pass).

    :func:`allanite._core.mvar_avar_ratio`, threaded over factors; factors with ``3m`` beyond
    the record get no entry, zero AVAR gives NaN (both mean "no ratio").
    """
    usable = [m for m in factors if 3 * m <= phase.shape[0]]
    if not usable:
        return {}
    ratio = np.asarray(_core.mvar_avar_ratio(phase, np.asarray(usable, dtype=np.int64), threads))
    return {m: ratio[i] for i, m in enumerate(usable)}


_CORE_DTYPES = (np.float64, np.float32, np.int16, np.int32, np.int64)


def _as_core_array(x: NDArray[np.generic]) -> NDArray[np.generic]:
    """2-D view the compiled module reads without a copy (converted only for other dtypes)."""
    arr = np.asarray(x)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ValueError(f"phase must be 1-D or 2-D (samples, channels), got shape {arr.shape}")
    if arr.dtype.type not in _CORE_DTYPES or not arr.dtype.isnative:
        arr = arr.astype(np.float64)
    return arr


def cap_few_point_alpha(
    alpha: NDArray[np.int64], factors: NDArray[np.int64], n_points: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Cap the few-point exponents at the one of the longest reliably identified factor.

    At factors with at least :data:`ACF_MIN_POINTS` decimated points the lag-1 method is
    reliable; beyond the longest such factor (per channel) the B1/R(n) answer is limited to at
    most that factor's ``alpha``. Power-law noise moves toward lower exponents (phase noise at
    short tau, frequency noise and random walks at long tau), and the Allan-family EDF grows
    with ``alpha``, so the cap never narrows an interval.

    Parameters
    ----------
    alpha : numpy.ndarray
        Identified exponents, shape ``(T, C)``.
    factors : numpy.ndarray
        Averaging factors, shape ``(T,)`` (any order).
    n_points : numpy.ndarray
        Decimated points the identification used at each factor, shape ``(T,)``.

    Returns
    -------
    numpy.ndarray
        A capped copy of ``alpha``.
    """
    out = np.array(alpha, dtype=np.int64, copy=True)
    f = np.asarray(factors, dtype=np.int64).reshape(-1)
    reliable = np.asarray(n_points).reshape(-1) >= ACF_MIN_POINTS
    if not reliable.any() or reliable.all():
        return out
    ref = int(np.flatnonzero(reliable)[np.argmax(f[reliable])])
    beyond = (~reliable) & (f > f[ref])
    out[beyond] = np.minimum(out[beyond], out[ref][None, :])
    return out


#: the ``alpha`` value that asks for Stable32's per-tau identification, without smoothing
STABLE32_ALPHA = "stable32"


def wants_identification(alpha: object) -> bool:
    """Whether ``alpha`` asks for identification from the data (None or ``"stable32"``).

    Raises
    ------
    TypeError
        If ``alpha`` is a string other than ``"stable32"`` (as for any other non-integer).
    """
    if isinstance(alpha, str):
        if alpha != STABLE32_ALPHA:
            raise TypeError(
                f"alpha={alpha!r}: give a power-law exponent, None (identified, isolated flips "
                f"smoothed) or {STABLE32_ALPHA!r} (Stable32's per-tau identification)"
            )
        return True
    return alpha is None


def smooth_isolated_alpha(
    alpha: NDArray[np.int64], factors: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Replace isolated flips of the identified exponent by the value of their neighbours.

    In the order of increasing averaging factor, an exponent that differs from both the previous
    and the next one while these two agree is set to theirs (per channel; the comparison uses
    the unsmoothed values, so the result does not depend on the order of evaluation). The
    dominant noise type of a power-law spectrum changes over decades of tau; a single tau whose
    noise type differs from both neighbours is an identification error of that tau's estimate,
    and would make its EDF, hence its interval, jump (e.g. 3801 -> 13196 -> 3031). Runs of two or
    more equal exponents and the first and last factors are kept as identified.

    Parameters
    ----------
    alpha : numpy.ndarray
        Identified exponents, shape ``(T, C)``.
    factors : numpy.ndarray
        Averaging factors, shape ``(T,)`` (any order).

    Returns
    -------
    numpy.ndarray
        A smoothed copy of ``alpha``.
    """
    out = np.array(alpha, dtype=np.int64, copy=True)
    order = np.argsort(np.asarray(factors).reshape(-1), kind="stable")
    if order.size < 3:
        return out
    a = out[order]
    prev, mid, nxt = a[:-2], a[1:-1], a[2:]
    flip = (prev == nxt) & (mid != prev)
    mid[flip] = prev[flip]
    out[order] = a
    return out


def identify_alpha(
    phase: NDArray[np.generic],
    m: NDArray[np.int64],
    kind: str,
    *,
    data: str = "frequency",
    detrended: NDArray[np.float64] | None = None,
    threads: int = 0,
) -> NDArray[np.int64]:
    """Dominant power-law exponent ``alpha`` for each averaging factor and channel.

    As Stable32: at factor ``m`` the phase is decimated (``x[::m]``, phase data) or the
    frequency averaged over ``m`` samples (frequency data; the first difference of the decimated
    phase), then the lag-1 autocorrelation method (:func:`acf_noise_id`, ``dmax`` = 2 for the
    Allan family and 3 for Hadamard) is applied when at least :data:`ACF_MIN_POINTS` values
    remain, the B1/R(n) method (:func:`b1_noise_id`) otherwise, capped beyond the longest
    lag-1 factor by :func:`cap_few_point_alpha`. The result
    is clipped to the exponents the
    estimator can measure (``alpha + 2d > 1``).

    Cost and memory: the lag-1 statistics come from the compiled
    :func:`allanite._core.lag1_acf`: one streaming pass over the record per worker thread,
    every factor of the thread's group reading its rows ``x[::m]`` from tiles in cache (no copy
    of the record or of the decimated series). The levels are lazy: a first pass computes
    level 0 only; a second pass, over the factors whose stopping rule asks to difference, all
    ``dmax + 1`` levels (a level's sums are the same in either pass). Then the B1 ratio from
    the fewer than 30 averages, and R(n) from the compiled one-pass
    :func:`allanite._core.mvar_avar_ratio`, evaluated only at the factors where B1 points to
    phase noise and the cap of :func:`cap_few_point_alpha` leaves the answer open (the longest
    lag-1 factor's ``alpha`` above 1). Extra memory is O(T C) besides the input; nothing here
    calls :mod:`allanite.variance.oracle` (the test oracle).

    Parameters
    ----------
    phase : numpy.ndarray
        Phase array ``(M, C)`` (or ``(M,)``) in sample units: for frequency-like records the
        prefix sums of :func:`allanite._core.phase`; for phase data (angle input) the phase as
        recorded, trend included, which is what Stable32 analyses (a frequency offset makes the
        lag-1 method difference at least once). float64, float32, int16, int32 or int64 are
        read in place (strided views too); other dtypes are converted.
    m : numpy.ndarray
        Averaging factors, shape ``(T,)``.
    kind : str
        Kernel kind (sets ``dmax`` and the clipping range).
    data : {"frequency", "phase"}
        Whether the record was frequency-like (rate, increments) or phase-like (angle); selects
        Stable32's frequency or phase variant of the method.
    detrended : numpy.ndarray, optional
        The detrended float64 phase of the same record (``_core.phase(x, "angle")``), used for
        the ratio R(n) = MVAR/AVAR instead of ``phase``: second differences cancel the trend,
        so the ratio is the same while no float64 copy of a raw record is needed.
    threads : int
        Worker threads of the compiled passes (0: all cores); the result does not depend on it.

    Returns
    -------
    numpy.ndarray
        ``alpha``, int64, shape ``(T, C)``.
    """
    if data not in ("frequency", "phase"):
        raise ValueError(f"data must be 'frequency' or 'phase', got {data!r}")
    shape = estimator_shape(kind)
    dmax = shape.d
    lo, hi = (-2, 2) if kind == "total" else _alpha_range(shape.d)
    x2 = _as_core_array(phase)
    rows, channels = x2.shape
    factors = np.asarray(m, dtype=np.int64).reshape(-1)
    if factors.size and factors.min() < 1:
        raise ValueError(f"averaging factors must be at least 1, got {factors.min()}")
    is_phase = data == "phase"
    n_series = -(-rows // factors) if is_phase else (rows - 1) // factors
    out = np.empty((factors.size, channels), dtype=np.int64)

    # Lazy levels: level 0 of every factor first; the deeper levels only at the factors whose
    # stopping rule asks for them (the compiled sums of a level do not depend on how many
    # levels a pass computes, so the decisions are those of one pass over all levels).
    undecided = np.flatnonzero(n_series >= ACF_MIN_POINTS)
    n_levels = 1
    while undecided.size:
        r1 = np.asarray(_core.lag1_acf(x2, factors[undecided], data, n_levels, threads))
        r1 = r1.reshape(undecided.size, channels, n_levels)
        deeper = []
        for row, i in enumerate(undecided.tolist()):
            for c in range(channels):
                alpha = _acf_decision_of(r1[row, c].tolist(), dmax, int(n_series[i]), is_phase)
                if alpha is None:
                    deeper.append(i)
                    break
                out[i, c] = alpha
        undecided = np.asarray(deeper, dtype=np.int64)
        n_levels = dmax + 1

    pending: list[tuple[int, int]] = []  # (tau index, channel) where B1 points to phase noise
    for i in np.flatnonzero(n_series < ACF_MIN_POINTS).tolist():
        mi = int(factors[i])
        rows_used = x2[: (rows - 1) // mi * mi + 1 : mi].astype(np.float64)
        ybar = np.diff(rows_used, axis=0) / mi
        for c in range(channels):
            alpha = _b1_frequency_class(ybar[:, c])
            if alpha is None:
                pending.append((i, c))
            else:
                out[i, c] = alpha
    # R(n) only chooses between white (2) and flicker (1) PM; where the cap of
    # cap_few_point_alpha is at most 1 the choice cannot change the result: no ratio needed
    pending = _uncapped(pending, out, factors, n_series)
    if pending:
        source = detrended if detrended is not None else x2.astype(np.float64, copy=False)
        ratios = _mvar_avar_ratios(
            np.asarray(source, dtype=np.float64),
            sorted({int(factors[i]) for i, _ in pending}),
            threads,
        )
        for i, c in pending:
            mi = int(factors[i])
            ratio = float(ratios[mi][c]) if mi in ratios else math.nan
            out[i, c] = _rn_phase_class(None if math.isnan(ratio) else ratio, mi)
    return np.clip(cap_few_point_alpha(out, factors, n_series), lo, hi)
