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
Kasdin process but its truncation. :func:`allanite.terms.flicker_laws.kasdin_avar` gives both
laws exactly, from the filter itself. With the second difference of the cumulative filter
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

import numbers
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import fft

from allanite.simulation.spectral import WholeRecordStream

__all__ = [
    "KASDIN_MAX_SAMPLES",
    "KASDIN_MAX_VALUES",
    "KasdinStream",
    "kasdin_coefficients",
]

#: longest record the Kasdin filter synthesises in one piece (as the spectral method); one
#: channel needs about 6 x 16 bytes per sample transiently for its FFT convolution
KASDIN_MAX_SAMPLES = 1 << 21
#: and at most this many values (samples x channels) held for all channels (128 MB)
KASDIN_MAX_VALUES = 1 << 24
#: flicker exponent of the filter (PSD ~ 1/f^alpha)
ALPHA = 1.0


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
