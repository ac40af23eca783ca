r"""Exact Allan variances of the two streaming flicker generators of :mod:`allanite.simulation`.

The flicker term's own law is :meth:`allanite.terms.Flicker.avar`; the simulated samples follow
the law of the generator that produced them, which these functions give exactly:

* :func:`bank_avar`: the streaming generator
  :class:`allanite.simulation.flicker.FlickerStream` (AR(1) bank, random walk and FIR
  residual, designed by :func:`allanite.simulation.flicker.flicker_design`);
* :func:`kasdin_avar`: Kasdin's fractional-difference filter
  (:class:`allanite.simulation.kasdin.KasdinStream`), stationary or truncated at the record
  start (see :mod:`allanite.simulation.kasdin` for the derivation).

Model formulas live in :mod:`allanite.terms`; the generators' designs (filter coefficients,
bank components) stay with the generators, which this module imports (one direction).
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import integrate

from allanite.simulation.flicker import FlickerDesign, flicker_design
from allanite.simulation.kasdin import kasdin_coefficients
from allanite.terms._checks import averaging_factor
from allanite.terms.markov import sampled_ar1_avar
from allanite.variance.transfer import avar_transfer

__all__ = ["bank_avar", "kasdin_avar"]

#: the stationary law sums u_m(p)^2 exactly up to p = TAIL_FACTOR m + TAIL_START, then
#: integrates the asymptotic form of H (relative error of the tail below 1e-7)
TAIL_FACTOR = 4
TAIL_START = 4096


def bank_avar(
    tau: ArrayLike,
    dt: float,
    B: float,
    *,
    cutoff_hz: float | None = None,
    n_samples: int | None = None,
) -> NDArray[np.float64]:
    r"""Return the exact Allan variance of the streaming flicker generator.

    The sum of its three independent parts (:mod:`allanite.simulation.flicker`): the AR(1)
    components (:func:`~allanite.terms.markov.sampled_ar1_avar`), the random walk
    (:math:`K^2\Delta t(2m^2+1)/(6m)`) and the FIR residual, whose Allan variance is
    :math:`\frac{1}{2m^2}\sum_k R_k\,(2t_k - t_{k-m} - t_{k+m})` from its taps'
    autocovariance :math:`R_k` and :math:`t_k = \max(m - |k|, 0)`; with a cutoff below Nyquist
    minus what the low-pass on the bank removes (:func:`_lowpass_loss`).

    Parameters
    ----------
    tau : array_like
        Averaging times in seconds, whole multiples ``m dt`` of the sample period.
    dt : float
        Sample period in seconds.
    B : float
        Flicker coefficient (rate).
    cutoff_hz : float, optional
        The term's cutoff ``f0`` (None: Nyquist).
    n_samples : int, optional
        Record length the generator was designed for (None: its default).

    Raises
    ------
    ValueError
        For ``tau`` off the sample grid.
    """
    t, m = _whole_factors(tau, dt)
    cutoff = 0.5 if cutoff_hz is None else cutoff_hz * dt
    design = flicker_design(n_samples, cutoff)
    mf = m.astype(np.float64)
    total = design.walk * (2.0 * mf**2 + 1.0) / (6.0 * mf)
    for tc in design.tcs:
        total = total + sampled_ar1_avar(design.variance, 1.0 / float(tc), mf)
    total = total + _fir_avar(design.taps, m) - _lowpass_loss(design, m)
    return np.asarray(B * B * total, dtype=np.float64).reshape(t.shape)


def _lowpass_loss(design: FlickerDesign, m: NDArray[np.int64]) -> NDArray[np.float64]:
    r"""Allan variance the low-pass removes from the bank (zero without a low-pass).

    :math:`\int_0^{1/2} (1 - |G(u)|^2)\,S_\text{bank}(u)\,|H_m(u)|^2\,du` (trapezoid rule on
    the design's ``grid`` lines from below the pass-band
    edge, where :math:`1 - |G|^2` stops being negligible; the integrand is smooth and even
    about 1/2). For ``m`` above a sixteenth of the grid :math:`\sin^4(\pi u m)` is replaced
    by its mean 3/8 (the oscillating rest vanishes faster than any power of 1/m).
    """
    out = np.zeros(m.shape, dtype=np.float64)
    if design.lowpass is None:
        return out
    grid = design.grid
    u = np.arange(1, grid // 2 + 1) / grid
    loss = (1.0 - design.lowpass_gain(grid)[1:]) * design.bank_psd(u)
    start = int(np.argmax(np.abs(loss) > 1e-18 * np.abs(loss).max()))
    u, loss = u[start:], loss[start:] / grid
    loss[-1] *= 0.5  # the Nyquist end of the trapezoid
    for index, mm in np.ndenumerate(m):
        if mm <= grid // 16:
            out[index] = float(np.sum(loss * avar_transfer(u, [float(mm)], 1.0)[0]))
        else:
            out[index] = 0.75 / float(mm) ** 2 * float(np.sum(loss / np.sin(np.pi * u) ** 2))
    return out


def _fir_avar(taps: NDArray[np.float64], m: NDArray[np.int64]) -> NDArray[np.float64]:
    """Allan variance of unit white noise through ``taps`` at whole factors ``m``."""
    n = taps.size
    size = 1 << math.ceil(math.log2(2 * n))
    spectrum = np.fft.rfft(taps, size)
    autocov = np.fft.irfft(spectrum.real**2 + spectrum.imag**2, size)[:n]  # R_0 .. R_{n-1}
    lags = np.arange(n, dtype=np.float64)
    total_r = autocov[0] + 2.0 * float(np.sum(autocov[1:]))
    total_kr = 2.0 * float(np.sum(lags * autocov))
    out = np.empty(m.shape, dtype=np.float64)
    for index, mm in np.ndenumerate(m):
        mm = int(mm)
        if mm >= n:
            # all lags inside the blocks: the weight is 2m - 3|k|
            out[index] = (2.0 * mm * total_r - 3.0 * total_kr) / (2.0 * mm * mm)
            continue
        tri = np.clip(mm - lags, 0.0, None)
        shifted_down = np.clip(mm - np.abs(lags - mm), 0.0, None)
        shifted_up = np.clip(mm - (lags + mm), 0.0, None)  # zero for k >= 0
        weight = 2.0 * tri - shifted_down - shifted_up
        # R is even: lag 0 once, the others twice
        value = autocov[0] * weight[0] + 2.0 * float(np.sum(autocov[1:] * weight[1:]))
        out[index] = value / (2.0 * mm * mm)
    return out


def _cumulative_table(k_max: int) -> NDArray[np.float64]:
    r""":math:`H(k) = \sum_{i<k} h_i = 2k h_k` (alpha = 1) for ``k = 0 .. k_max``."""
    k = np.arange(k_max + 1, dtype=np.float64)
    return 2.0 * k * kasdin_coefficients(k_max + 1)


def _responses(m: int, last: int, table: NDArray[np.float64]) -> NDArray[np.float64]:
    r""":math:`u_m(p)` for :math:`p = 1 - 2m \ldots` ``last`` from :func:`_cumulative_table`."""
    padded = np.concatenate((np.zeros(2 * m), table[: last + 2 * m + 1]))  # H(k <= 0) = 0
    count = last + 2 * m  # number of p values; padded[j] = H(j - 2m)
    high = padded[2 * m + 1 : 2 * m + 1 + count]  # H(p + 2m) = padded[p + 4m]
    mid = padded[m + 1 : m + 1 + count]
    low = padded[1 : 1 + count]
    return (high - 2.0 * mid + low) / m


def _tail(m: int, start: float) -> float:
    r"""Integral of :math:`u_m(p)^2` over :math:`p \ge` ``start`` from the asymptotic H.

    :math:`H(k) = \tfrac{2}{\sqrt\pi}(\sqrt k - k^{-1/2}/8 + O(k^{-3/2}))`; the second
    difference of :math:`\sqrt k` is written without cancellation,
    :math:`-2m^2/[(s_2 + s_0)(s_2 + s_1)(s_1 + s_0)]` with :math:`s_j = \sqrt{p + jm}`.
    """

    def integrand(p: float) -> float:
        s0, s1, s2 = math.sqrt(p), math.sqrt(p + m), math.sqrt(p + 2 * m)
        root = -2.0 * m * m / ((s2 + s0) * (s2 + s1) * (s1 + s0))
        inverse = 1.0 / s2 - 2.0 / s1 + 1.0 / s0
        return (2.0 / math.sqrt(math.pi) * (root - inverse / 8.0) / m) ** 2

    # substitute p = start / t (t in (0, 1]) so that the range is finite and smooth
    value, _ = integrate.quad(
        lambda t: integrand(start / t) * start / (t * t), 0.0, 1.0, epsabs=0.0, epsrel=1e-10
    )
    return float(value)


def _whole_factors(tau: ArrayLike, dt: float) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    t, m, _ = averaging_factor(tau, dt)
    whole = np.round(m)
    if np.any(np.abs(m - whole) > 1e-6 * np.maximum(whole, 1.0)) or np.any(whole < 1):
        raise ValueError(
            "tau must be whole multiples of the sample period dt (tau = m dt, m >= 1); "
            "round tau to the sample grid"
        )
    return t, whole.astype(np.int64)


def kasdin_avar(
    tau: ArrayLike, dt: float, B: float, n_samples: int | None = None
) -> NDArray[np.float64]:
    r"""Return the exact Allan variance of Kasdin flicker samples of coefficient ``B``.

    Parameters
    ----------
    tau : array_like
        Averaging times in seconds, whole multiples ``m dt`` of the sample period.
    dt : float
        Sample period in seconds.
    B : float
        Flicker coefficient (rate); the innovations have variance :math:`Q_d = B^2`.
    n_samples : int, optional
        None: the stationary law :math:`\tfrac{B^2}{2}\sum_{p \ge 1-2m} u_m(p)^2` of the
        infinite-history process. An integer ``N``: the expected overlapping Allan variance of
        a record of ``N`` samples from the truncated filter (what
        :class:`~allanite.simulation.kasdin.KasdinStream` produces),
        :math:`\tfrac{B^2}{2K}\sum_{p=1-2m}^{K-1} u_m(p)^2 (K - \max(p, 0))`,
        :math:`K = N - 2m + 1`. See the module docstring for both.

    Returns
    -------
    numpy.ndarray
        Allan variance per ``tau`` in rate units squared.

    Raises
    ------
    ValueError
        For ``tau`` off the sample grid, ``B < 0``, or ``2m > n_samples``.

    References
    ----------
    N. J. Kasdin, Proc. IEEE 83(5) (1995), eq. (116) for the filter.
    """
    if isinstance(B, bool) or not isinstance(B, numbers.Real):
        raise TypeError(f"B must be a number (rate units), got {B!r}")
    if not math.isfinite(B) or B < 0:
        raise ValueError(f"B must be finite and non-negative, got {B!r}")
    t, m = _whole_factors(tau, dt)
    if n_samples is not None:
        if isinstance(n_samples, bool) or not isinstance(n_samples, numbers.Integral):
            raise TypeError(f"n_samples must be a whole number of samples, got {n_samples!r}")
        if np.any(2 * m > n_samples):
            raise ValueError(
                f"tau = {t.max()} s needs 2 tau / dt = {2 * int(m.max())} samples but the record "
                f"has n_samples = {n_samples}; use tau <= n_samples dt / 2"
            )
    if n_samples is None:
        table = _cumulative_table(int(TAIL_FACTOR * m.max() + TAIL_START + 2 * m.max()))
    else:
        table = _cumulative_table(int(n_samples))
    out = np.empty(m.shape, dtype=np.float64)
    for index, mm in np.ndenumerate(m):
        mm = int(mm)
        if n_samples is None:
            last = TAIL_FACTOR * mm + TAIL_START
            u = _responses(mm, last, table)
            total = float(np.sum(u * u)) + _tail(mm, last + 0.5)
        else:
            windows = int(n_samples) - 2 * mm + 1
            u = _responses(mm, windows - 1, table)
            weight = windows - np.maximum(np.arange(1 - 2 * mm, windows), 0)
            total = float(np.sum(u * u * weight)) / windows
        out[index] = 0.5 * B * B * total
    return out
