r"""Flicker (1/f) rate noise by Kasdin's fractional-difference filter, and its exact law.

White innovations :math:`w_j \sim N(0, Q_d)` are filtered by the causal filter of
:math:`(1 - z^{-1})^{-\alpha/2}` with :math:`\alpha = 1` (rate flicker, PSD :math:`\propto
1/f`),

.. math:: h_0 = 1,\qquad h_k = h_{k-1}\,\frac{k - 1 + \alpha/2}{k}
          = \frac{\Gamma(k + 1/2)}{\Gamma(1/2)\,k!},\qquad
          x_n = \sum_{k=0}^{n} h_k\,w_{n-k},\quad n = 0 \ldots N-1,

the linear convolution being done with FFTs zero-padded to at least :math:`2N`. The process
starts from zero history (the filter is truncated at the record start), exactly as Kasdin
generates a record of known length :math:`N`; it is therefore for records of moderate length
(at most :data:`KASDIN_MAX_SAMPLES`), like the spectral method.

Scaling. Kasdin's one-sided discrete PSD is
:math:`S(f) = 2Q_d\Delta t/|2\sin(\pi f\Delta t)|^{\alpha}`, which for :math:`\alpha = 1` and
:math:`f \ll 1/\Delta t` is :math:`Q_d/(\pi f)`. Matching the flicker term's
:math:`B^2/(\pi f)` gives :math:`Q_d = B^2`, whatever :math:`\Delta t`.

Which law the samples follow
----------------------------
Because the filter starts from zero history, the samples are not the stationary-increment
Kasdin process but its truncation. :func:`kasdin_avar` gives both laws exactly, from the
filter itself. With the second difference of the cumulative filter
:math:`H(k) = \sum_{i<k} h_i = 2k\,h_k` (hockey-stick identity; :math:`H(k) = 0` for
:math:`k \le 0`),

.. math:: u_m(p) = \frac{H(p + 2m) - 2H(p + m) + H(p)}{m}

is the response of one Allan difference :math:`\bar x_{n+m} - \bar x_n` (means of ``m``
samples) to the innovation ``p`` samples before its start, so

* stationary (infinite history, ``n_samples=None``):
  :math:`\sigma^2(m\Delta t) = \tfrac{B^2}{2}\sum_{p=1-2m}^{\infty} u_m(p)^2`, which equals
  the PSD integral :math:`B^2\int_0^{1/2} 2\sin^4(\pi m\nu)/(m^2\sin^3(\pi\nu))\,d\nu`
  (at :math:`\tau = \Delta t` exactly :math:`2B^2/\pi`);
* the truncated record of ``N`` samples (``n_samples=N``): the expected *overlapping* Allan
  variance, averaged over its :math:`K = N - 2m + 1` windows (window ``n`` misses the
  innovations before the record start, :math:`p > n`), is
  :math:`\tfrac{B^2}{2K}\sum_{p=1-2m}^{K-1} u_m(p)^2\,(K - \max(p, 0))`. This is the law of
  :class:`KasdinStream` samples, used by the tests. It lies below the stationary law by
  :math:`0.035`-:math:`0.06\,\tau/T`, whatever the length: 0.053% at :math:`\tau = T/100`,
  0.59% at :math:`\tau = T/10` (:math:`T = N\Delta t`; ``benchmarks/sim_kasdin.py``).

Departure from the flicker term at short tau
--------------------------------------------
:class:`allanite.terms.Flicker` (cutoff at Nyquist) describes interval averages of
band-limited 1/f noise, whose sampled PSD :math:`B^2\mathrm{sinc}^2(f\Delta t)/(\pi f)` falls
to :math:`0.4\,B^2/(\pi f)` at Nyquist, whereas Kasdin's rises to :math:`B^2\Delta t` there
(:math:`\pi f\Delta t/\sin(\pi f\Delta t) \ge 1`). The stationary Kasdin Allan variance
exceeds the term's by

====================  ======  ======  ======  ======  ======
:math:`\tau/\Delta t`     1       2       4       10     100
====================  ======  ======  ======  ======  ======
Kasdin / term (AVAR)  1.704   1.182   1.0569  1.0116  1.0002
====================  ======  ======  ======  ======  ======

(:math:`2/\pi = 0.6366\,B^2` against :math:`0.3735\,B^2` at :math:`\tau = \Delta t`), and
holds the term's plateau :math:`(2\ln 2/\pi)B^2` (ADEV :math:`0.664B`) within 0.02% from
:math:`\tau = 100\Delta t` on. Use the spectral method when the first lags matter.

References
----------
N. J. Kasdin, "Discrete simulation of colored noise and stochastic processes and
:math:`1/f^\alpha` power law noise generation", Proc. IEEE 83(5) (1995) 802-827, eqs. (115),
(116) and Section IX; J. R. M. Hosking, "Fractional differencing", Biometrika 68 (1981).
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import fft, integrate

from allanite.simulation.spectral import WholeRecordStream
from allanite.terms._checks import averaging_factor

__all__ = [
    "KASDIN_MAX_SAMPLES",
    "KASDIN_MAX_VALUES",
    "KasdinStream",
    "kasdin_avar",
    "kasdin_coefficients",
]

#: longest record the Kasdin filter synthesises in one piece (as the spectral method); one
#: channel needs about 6 x 16 bytes per sample transiently for its FFT convolution
KASDIN_MAX_SAMPLES = 1 << 21
#: and at most this many values (samples x channels) held for all channels (128 MB)
KASDIN_MAX_VALUES = 1 << 24
#: flicker exponent of the filter (PSD ~ 1/f^alpha)
ALPHA = 1.0
#: the stationary law sums u_m(p)^2 exactly up to p = TAIL_FACTOR m + TAIL_START, then
#: integrates the asymptotic form of H (relative error of the tail below 1e-7)
TAIL_FACTOR = 4
TAIL_START = 4096


def kasdin_coefficients(n: int, alpha: float = ALPHA) -> NDArray[np.float64]:
    r"""Return the first ``n`` coefficients of Kasdin's :math:`1/f^\alpha` filter.

    :math:`h_0 = 1`, :math:`h_k = h_{k-1}(k - 1 + \alpha/2)/k` (Kasdin 1995, eq. 116), the
    power series of :math:`(1 - z^{-1})^{-\alpha/2}`; for :math:`\alpha = 1`,
    :math:`h_k = \Gamma(k + 1/2)/(\Gamma(1/2)\,k!)`.

    Raises
    ------
    ValueError
        If ``n < 1`` or ``alpha`` is not in ``(0, 2]``.
    """
    if isinstance(n, bool) or not isinstance(n, numbers.Integral):
        raise TypeError(f"n must be a whole number of coefficients, got {n!r}")
    if n < 1:
        raise ValueError(f"the filter needs at least one coefficient, got n = {n}")
    if not (0.0 < alpha <= 2.0):
        raise ValueError(f"alpha must lie in (0, 2] for a power-law filter, got {alpha!r}")
    k = np.arange(1, int(n), dtype=np.float64)
    h = np.empty(int(n))
    h[0] = 1.0
    h[1:] = np.cumprod((k - 1.0 + 0.5 * alpha) / k)
    return h


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
        a record of ``N`` samples from the truncated filter (what :class:`KasdinStream`
        produces), :math:`\tfrac{B^2}{2K}\sum_{p=1-2m}^{K-1} u_m(p)^2 (K - \max(p, 0))`,
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


class KasdinStream(WholeRecordStream):
    """Flicker rate samples ``B`` by Kasdin's fractional filter, one synthesis per record.

    The whole record (``n_samples`` rounded up to whole blocks) is filtered on the first
    request and then served block by block, so any chunking gives the same samples. Each
    channel draws its innovations ``N(0, B^2)`` in turn from the stream's generator and is
    convolved with :func:`kasdin_coefficients` by real FFTs of length at least twice the
    record.

    Raises
    ------
    ValueError
        If the record is longer than :data:`KASDIN_MAX_SAMPLES` or holds more than
        :data:`KASDIN_MAX_VALUES` values over all channels.
    """

    def __init__(
        self, B: float, n_samples: int, fs: float, n_channels: int, seed: Any = None
    ) -> None:
        if n_samples > KASDIN_MAX_SAMPLES or n_samples * n_channels > KASDIN_MAX_VALUES:
            raise ValueError(
                f"the kasdin flicker method synthesises the whole record at once and is limited "
                f"to {KASDIN_MAX_SAMPLES} samples and {KASDIN_MAX_VALUES} samples x channels; "
                f"got {n_samples} x {n_channels}: use flicker method 'bank' (streaming) or "
                "'auto' for longer records"
            )
        super().__init__(n_samples, fs, n_channels, seed)
        self.B = float(B)

    def _synthesise(self, padded: int) -> NDArray[np.float64]:
        length = fft.next_fast_len(2 * padded, real=True)
        gain = fft.rfft(kasdin_coefficients(padded), length)
        record = np.empty((padded, self.n_channels))
        for c in range(self.n_channels):
            w = self.rng.standard_normal(padded) * self.B
            record[:, c] = fft.irfft(fft.rfft(w, length) * gain, length)[:padded]
        return record
