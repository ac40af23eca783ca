r"""Variance of the overlapping Allan variance estimate: Gaussian part and excess.

The overlapping estimate at averaging factor :math:`m` of a record of :math:`n` rate samples
:math:`y_j` is a quadratic form

.. math:: Q = c\sum_{h=0}^{M-1} d_h^2,\qquad d_h = \sum_j w(j-h)\,y_j,\qquad
          c = \frac{1}{2M},\quad M = n - 2m + 1,

with the second-difference weights :math:`w(t) = -1/m` on :math:`0 \le t < m`, :math:`+1/m` on
:math:`m \le t < 2m` (NIST SP1065 eq. 11; removing the record mean does not change it).

**Independent innovations.** When the record is a linear response to independent zero-mean
innovations :math:`\xi_z` (variance :math:`\kappa_2(z)`, fourth cumulant :math:`\kappa_4(z)`),
:math:`d_h = \sum_z g_h(z)\xi_z` and

.. math:: \operatorname{Var} Q = 2c^2\sum_{h,k}\operatorname{Cov}(d_h, d_k)^2
          + \sum_z \kappa_4(z)\,D(z)^2,\qquad D(z) = c\sum_h g_h(z)^2 .

The first part is the variance for a Gaussian process of the same covariance (what the
Greenhall-Riley EDF approximates for power laws; :func:`gaussian_estimate_variance` computes
it exactly from the sampled PSD); the second, the *excess*, is what the other functions
compute. For a Poisson random measure of jumps (rate :math:`\lambda`, i.i.d. symmetric sizes
:math:`J`, uniform positions) the sum becomes :math:`\lambda E[J^4]\int D(r)^2\,dr` (the
cumulants of a Poisson integral are :math:`\int f^k d\nu`). Spikes (i.i.d. samples) and bias
steps (a compound-Poisson random walk) are of this kind, so their excess is exact.

**Random telegraph signal** :math:`s = \pm a`, switching at rate :math:`\lambda = 1/(2T_c)`.
It is :math:`s(t) = \int_{-\infty}^t e^{-(t-r)/T_c}\,dM(r)` with the martingale
:math:`dM = -2s(r^-)(dN - \lambda\,dr)`: uncorrelated increments, but not independent ones.
Its increments have :math:`E[dM^2\,|\,\text{past}] = 4a^2\lambda\,dr` (no random volatility,
so the pair terms are Gaussian), :math:`E[dM^4] = 16a^4\lambda\,dr`, and a third conditional
moment :math:`E[dM^3\,|\,\text{past}] = -8a^2\lambda s\,dr` that correlates with earlier
increments: :math:`E[dM_r\,dM_{r'}^3] = -32a^4\lambda^2 e^{-(r'-r)/T_c}` for :math:`r < r'`.
Collecting the fourth moments of :math:`Q` (with :math:`\int_{r<r'} e^{-(r'-r)/T_c} g_h(r)\,dr
= \tfrac{T_c}{2}(g_h + f_h)(r')`) gives the exact

.. math:: \text{excess} = -16a^4\lambda\int D(r)\,[D(r) + 2E(r)]\,dr,\qquad
          E(r) = c\sum_h g_h(r) f_h(r),

with :math:`g_h(r)` the response of :math:`d_h` to a unit jump at :math:`r` (the later samples)
and :math:`f_h(r) = \int_{s<r} W_h(s) e^{-(r-s)/T_c} ds` its mirror image (the earlier
samples). At :math:`\tau \ll T_c`, :math:`f \approx -g` and the excess is the Poisson count
of switches, :math:`+16a^4\lambda\int D^2`, what a process driven by independent jumps of
:math:`\pm 2a` would give; at :math:`\tau \gg T_c`, :math:`f \approx g` and the excess is
negative, :math:`-48a^4\lambda\int D^2`: the two-valued signal is lighter-tailed than Gaussian.
(The approximation by independent jumps keeps only the first term; it overstates the variance
of the estimate by a factor 3.4 at :math:`\tau \approx 2T_c` for :math:`T_c = 0.3` s,
:math:`2^{14}` samples at 100 Hz, against Monte Carlo.)

**Responses.** Sample means of a jump in sample :math:`i` at the fraction :math:`v\in(0,1]` of
the period that follows it, relaxing as :math:`e^{-s/T_c}` (:math:`\theta = \Delta t/T_c`,
:math:`\phi = e^{-\theta}`; :math:`T_c = \infty` for a step): sample :math:`i` sees
:math:`\alpha(v) = (1 - e^{-v\theta})/\theta`, sample :math:`i+k` sees
:math:`\beta(v)\phi^{k-1}`, :math:`\beta(v) = e^{-v\theta}(1-\phi)/\theta` (:math:`\alpha = v`,
:math:`\beta = 1` for a step). With :math:`t = i - h`,
:math:`g = \alpha(v)\,w(t) + \beta(v)\,T(t)`, :math:`T(t) = \sum_{t'>t} w(t')\phi^{t'-t-1}`
(a geometric tail :math:`T(-1)\phi^{-t-1}` before the window), and
:math:`f = \alpha(1-v)\,w(t) - \beta(1-v)\,T(2m-1-t)` by symmetry. :math:`D` and :math:`E`
are sums of profile products over :math:`t\in[i-M+1, i]`, differences of prefix sums: each tau
costs :math:`O(n + m)` and the record edges (sites in fewer differences) are exact. A
stationary process's jumps before the record enter through the tail in closed form; the
integrals over :math:`v` use Gauss-Legendre panels.

References
----------
J. R. Magnus and H. Neudecker, *Matrix Differential Calculus* (1999): the variance of a
quadratic form in i.i.d. variables. C. A. Greenhall and W. J. Riley, "Uncertainty of stability
variances based on finite differences", PTTI (2003). S. Machlup, "Noise in semiconductors:
spectrum of a two-parameter random signal", J. Appl. Phys. 25, 341 (1954) (the telegraph
signal).
"""

from __future__ import annotations

import itertools
import math
import numbers
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import averaging_factor
from allanite.variance.transfer import avar_transfer

__all__ = [
    "gaussian_estimate_variance",
    "iid_excess_variance",
    "step_excess_variance",
    "telegraph_excess_variance",
]

#: Gauss-Legendre nodes per panel of the integrals over the jump position
_GAUSS_NODES = 16

Coefficients = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def _factors(tau: ArrayLike, dt: float, n: int) -> tuple[NDArray[np.int64], int]:
    """Whole averaging factors ``m = tau / dt`` and the record length, validated."""
    _, m, _ = averaging_factor(tau, dt)
    whole = np.rint(m)
    if np.any(np.abs(m - whole) > 1e-6 * whole) or np.any(whole < 1):
        raise ValueError(
            "tau must be whole multiples of dt for the estimator's excess variance; use the "
            "result's own tau grid (AllanResult.tau)"
        )
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 2:
        raise ValueError(f"n (record length in samples) must be an integer >= 2, got {n!r}")
    return whole.astype(np.int64), int(n)


def _geometric(k: ArrayLike, theta: float) -> NDArray[np.float64]:
    """``(1 - phi^k) / (1 - phi)`` with ``phi = exp(-theta)`` (``k`` when ``theta = 0``)."""
    k = np.asarray(k, dtype=np.float64)
    if theta == 0.0:
        return k
    return np.expm1(-k * theta) / math.expm1(-theta)


def _profiles(m: int, theta: float) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    r"""``w(t)``, ``T(t) = sum_{t'>t} w(t') phi^{t'-t-1}`` on ``t = 0 .. 2m-1``, ``T(-1)``."""
    t = np.arange(2 * m, dtype=np.float64)
    w = np.where(t < m, -1.0 / m, 1.0 / m)
    tail = _geometric(2 * m - 1 - t, theta) / m  # t >= m: the rest of the second window
    k = m - 1 - t[:m]  # t < m: the rest of the first window, then the whole second one, decayed
    whole = float(_geometric(m, theta))
    tail[:m] = (-_geometric(k, theta) + np.exp(-k * theta) * whole) / m
    before = whole * math.expm1(-m * theta) / m  # T(-1) = -(1 - phi^m)^2 / (m (1 - phi))
    return w, tail, before


def _site_sums(
    pairs: list[tuple[NDArray[np.float64], NDArray[np.float64]]], m: int, n: int
) -> NDArray[np.float64]:
    """``sum_{h<M} p(i-h) q(i-h)`` at sites ``i = 0 .. n-1`` per pair (``p, q`` on ``[0, 2m)``)."""
    terms = n - 2 * m + 1
    i = np.arange(n)
    hi = np.minimum(i, 2 * m - 1) + 1
    lo = np.maximum(i - terms + 1, 0)
    out = np.empty((len(pairs), n))
    for row, (p, q) in enumerate(pairs):
        prefix = np.concatenate(([0.0], np.cumsum(p * q)))
        out[row] = prefix[hi] - prefix[lo]
    return out


def _alpha_beta(v: NDArray[np.float64], theta: float) -> tuple[NDArray[np.float64], ...]:
    """Response of the jump's own sample (alpha) and of the next one (beta), see module doc."""
    if theta == 0.0:
        return v, np.ones_like(v)
    return -np.expm1(-v * theta) / theta, np.exp(-v * theta) * -math.expm1(-theta) / theta


def _position_integral(first: Coefficients, second: Coefficients, theta: float) -> Any:
    """``int_0^1 first(v)_a second(v)_b dv`` on Gauss-Legendre panels ``0, 1/theta, 2/theta, ...``.

    The panels double in width so that a relaxation much faster than a sample (``theta >> 1``)
    is resolved; the integrands are polynomials in ``v`` for steps (exact there).
    """
    edges = [0.0]
    while edges[-1] < 1.0:
        edges.append(min(1.0, max(1.0 / max(theta, 1e-300), 2.0 * edges[-1])))
    x, weights = np.polynomial.legendre.leggauss(_GAUSS_NODES)
    total: Any = 0.0
    for lo, hi in itertools.pairwise(edges):
        v = lo + (hi - lo) * (x + 1.0) / 2.0
        total = total + (first(v) * weights * (hi - lo) / 2.0) @ second(v).T
    return total


def _per_factor(
    factors: NDArray[np.int64], n: int, one: Callable[[int], float]
) -> NDArray[np.float64]:
    """``one(m)`` at every factor with ``2m <= n`` (at least one difference), NaN elsewhere."""
    out = np.full(factors.shape, np.nan)
    for index, m in np.ndenumerate(factors):
        if 2 * int(m) <= n:
            out[index] = one(int(m))
    return out


def _check_cumulant(value: float, name: str) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def gaussian_estimate_variance(
    spectrum: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    tau: ArrayLike,
    dt: float,
    n: int,
) -> NDArray[np.float64]:
    r"""Variance of the overlapping AVAR estimate of a Gaussian process with sampled PSD ``S``.

    .. math:: \operatorname{Var} Q = 2c^2\Bigl[M C_0^2 + 2\sum_{k=1}^{M-1}(M-k)\,C_k^2\Bigr],
              \qquad C_k = \int_0^{1/(2\Delta t)} S(f)\,2|H_m(f)|^2\cos(2\pi f k\Delta t)\,df,

    :math:`|H_m(f)|^2 = 2\sin^4(\pi f m\Delta t)/(m\sin(\pi f\Delta t))^2` (so that
    :math:`C_0 = 2\sigma^2(\tau)`), :math:`C_k = \operatorname{Cov}(d_h, d_{h+k})`: the first
    part of the module docstring's identity, exact for any covariance where the Greenhall-Riley
    EDF assumes a power law. The integral is the trapezoid rule on :math:`L \ge 4n`
    frequencies (one FFT per tau), exact for the periodic sampled spectrum up to the lag
    aliasing :math:`C_{k+L}`.

    Parameters
    ----------
    spectrum : callable
        One-sided PSD of the sampled rate, ``S(f)`` for ``0 < f <= 1/(2 dt)`` (rate^2/Hz),
        e.g. ``lambda f: term.psd_sampled(f, dt)``.
    tau : array_like
        Averaging times in seconds (whole multiples of ``dt``).
    dt : float
        Sample period in seconds.
    n : int
        Record length in samples.

    Returns
    -------
    numpy.ndarray
        Variance of the estimate in rate^4, shaped like ``tau`` (NaN where ``2m > n``).
    """
    factors, n = _factors(tau, dt, n)
    size = 1 << math.ceil(math.log2(4 * n))
    f = np.arange(size // 2 + 1) / (size * dt)
    f[0] = 1e-6 / (size * dt)  # the f -> 0 limit of S |H|^2 (finite for a random walk)
    density = np.asarray(spectrum(f), dtype=np.float64)

    def one(m: int) -> float:
        terms = n - 2 * m + 1
        response = 2.0 * avar_transfer(f, [m], dt)[0]
        cov = np.fft.irfft(density * response, n=size)[:terms] / (2.0 * dt)
        k = np.arange(1, terms)
        sums = terms * cov[0] ** 2 + 2.0 * float(np.sum((terms - k) * cov[1:] ** 2))
        return float(2.0 * sums / (2.0 * terms) ** 2)

    return _per_factor(factors, n, one)


def iid_excess_variance(
    tau: ArrayLike, dt: float, n: int, fourth_cumulant: float
) -> NDArray[np.float64]:
    r"""Excess variance of the overlapping AVAR estimate of i.i.d. samples (exact).

    .. math:: \text{excess} = \kappa_4\,c^2\sum_{i=0}^{n-1}\Bigl(\frac{N_i}{m^2}\Bigr)^2,

    :math:`N_i` the number of second differences that contain sample :math:`i` (:math:`2m`
    inside, fewer at the record edges), :math:`\kappa_4 = E x^4 - 3(E x^2)^2`.

    Parameters
    ----------
    tau : array_like
        Averaging times in seconds (whole multiples of ``dt``).
    dt : float
        Sample period in seconds.
    n : int
        Record length in samples.
    fourth_cumulant : float
        :math:`\kappa_4` of one sample (rate^4).

    Returns
    -------
    numpy.ndarray
        Excess variance in rate^4, shaped like ``tau`` (NaN where ``2m > n``).
    """
    factors, n = _factors(tau, dt, n)
    kappa = _check_cumulant(fourth_cumulant, "fourth_cumulant")

    def one(m: int) -> float:
        w, _, _ = _profiles(m, 0.0)
        diagonal = _site_sums([(w, w)], m, n)[0] / (2.0 * (n - 2 * m + 1))
        return kappa * float(np.sum(diagonal**2))

    return _per_factor(factors, n, one)


def _jump_excess(m: int, n: int, theta: float, mirrored: bool) -> float:
    r"""Site sum of the excess for ``(2M)^2 = 1/c^2`` units of the fourth-cumulant rate.

    ``sum_i int_0^1 Dh (Dh + 2 Eh) dv`` (``mirrored``, the telegraph) or ``sum_i int Dh^2 dv``
    over the sites of the record and before it, divided by ``(2M)^2`` (``Dh = D/c``,
    ``Eh = E/c``).
    """
    terms = n - 2 * m + 1
    w, tail, before = _profiles(m, theta)
    # D: pairs (w,w), (w,T), (T,T) with coefficients alpha^2, 2 alpha beta, beta^2
    d_sums = _site_sums([(w, w), (w, tail), (tail, tail)], m, n)
    if before != 0.0:
        # part of the differences before their window: T(t) = T(-1) phi^(-t-1), t < 0
        count = np.maximum(terms - 1 - np.arange(n), 0)
        d_sums[2] += before**2 * _geometric(count, 2.0 * theta)

    def d_coefficients(v: NDArray[np.float64]) -> NDArray[np.float64]:
        alpha, beta = _alpha_beta(v, theta)
        return np.stack([alpha**2, 2.0 * alpha * beta, beta**2])

    total = float(
        np.sum(_position_integral(d_coefficients, d_coefficients, theta) * (d_sums @ d_sums.T))
    )
    if mirrored:
        # E: f = alpha(1-v) w(t) - beta(1-v) T(2m-1-t); pairs with g = alpha(v) w + beta(v) T
        mirror = -tail[::-1]
        e_sums = _site_sums([(w, w), (w, mirror), (tail, w), (tail, mirror)], m, n)

        def e_coefficients(v: NDArray[np.float64]) -> NDArray[np.float64]:
            alpha, beta = _alpha_beta(v, theta)
            alpha_m, beta_m = _alpha_beta(1.0 - v, theta)
            return np.stack([alpha * alpha_m, alpha * beta_m, beta * alpha_m, beta * beta_m])

        cross = _position_integral(d_coefficients, e_coefficients, theta)
        total += 2.0 * float(np.sum(cross * (d_sums @ e_sums.T)))
    if before != 0.0:
        # sites i < 0 (E = 0 there): D = beta^2 T(-1)^2 phi^(2(-i-1)) (1 - phi^2M)/(1 - phi^2)
        block = before**2 * float(_geometric(terms, 2.0 * theta))

        def beta_squared(v: NDArray[np.float64]) -> NDArray[np.float64]:
            return _alpha_beta(v, theta)[1][None, :] ** 2

        fourth = float(_position_integral(beta_squared, beta_squared, theta)[0, 0])
        total += block**2 * fourth / -math.expm1(-4.0 * theta)
    return total / (2.0 * terms) ** 2


def step_excess_variance(
    tau: ArrayLike, dt: float, n: int, step_rate: float, step_fourth_moment: float
) -> NDArray[np.float64]:
    r"""Excess variance of the overlapping AVAR estimate of Poisson bias steps (exact).

    Steps of i.i.d. symmetric size :math:`J` at the events of a Poisson process
    (``step_rate`` :math:`\lambda` per second, uniform within a sample), the rate being their
    running sum from zero at the start of the record; samples are means over each period:

    .. math:: \text{excess} = \lambda\Delta t\,E[J^4]\,c^2\sum_{i=0}^{n-1}\int_0^1
              \bigl(v^2 S_{ww}(i) + 2v S_{wT}(i) + S_{TT}(i)\bigr)^2\,dv,

    :math:`S_{pq}(i) = \sum_h p(i-h)q(i-h)` with :math:`T` the triangle ``(t+1)/m`` then
    ``(2m-1-t)/m`` (module docstring).

    Parameters
    ----------
    tau : array_like
        Averaging times in seconds (whole multiples of ``dt``).
    dt : float
        Sample period in seconds.
    n : int
        Record length in samples.
    step_rate : float
        Steps per second.
    step_fourth_moment : float
        :math:`E[J^4]` of a step size (``3 b^4`` for Gaussian sizes of standard deviation b).

    Returns
    -------
    numpy.ndarray
        Excess variance in rate^4, shaped like ``tau`` (NaN where ``2m > n``).
    """
    factors, n = _factors(tau, dt, n)
    scale = float(step_rate) * dt * _check_cumulant(step_fourth_moment, "step_fourth_moment")
    return _per_factor(factors, n, lambda m: scale * _jump_excess(m, n, 0.0, mirrored=False))


def telegraph_excess_variance(
    tau: ArrayLike, dt: float, n: int, amplitude: float, tau_c: float
) -> NDArray[np.float64]:
    r"""Excess variance of the overlapping AVAR estimate of a random telegraph signal (exact).

    Sample means of the stationary symmetric telegraph signal :math:`\pm a` with correlation
    time :math:`T_c` (switching rate :math:`\lambda = 1/(2T_c)`):

    .. math:: \text{excess} = -16a^4\lambda\Delta t\,c^2\sum_i\int_0^1
              \hat D\,(\hat D + 2\hat E)\,dv,

    summed over the samples of the record and the stationary past (module docstring for
    :math:`\hat D = D/c`, :math:`\hat E = E/c` and the derivation). Positive (a Poisson count
    of switches) at :math:`\tau \ll T_c`, negative at :math:`\tau \gg T_c`.

    Parameters
    ----------
    tau : array_like
        Averaging times in seconds (whole multiples of ``dt``).
    dt : float
        Sample period in seconds.
    n : int
        Record length in samples.
    amplitude : float
        Level :math:`a`.
    tau_c : float
        Correlation time :math:`T_c` in seconds.

    Returns
    -------
    numpy.ndarray
        Excess variance in rate^4, shaped like ``tau`` (NaN where ``2m > n``).
    """
    factors, n = _factors(tau, dt, n)
    if not tau_c > 0.0 or not math.isfinite(tau_c):
        raise ValueError(f"tau_c must be a positive, finite time in seconds, got {tau_c!r}")
    theta = dt / tau_c
    scale = -16.0 * _check_cumulant(amplitude, "amplitude") ** 4 * dt / (2.0 * tau_c)
    return _per_factor(factors, n, lambda m: scale * _jump_excess(m, n, theta, mirrored=True))
