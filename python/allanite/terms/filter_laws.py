r"""Exact laws of white noise seen through a sensor's digital output filter.

A digital filter with impulse response :math:`h_j` (unit DC gain) applied to the white
sample sequence of variance :math:`s^2 = N^2/\Delta t` gives a stationary sequence with the
autocovariance :math:`r(k) = s^2\sum_j h_j h_{j+k}`. The overlapping Allan variance of its
sample means over :math:`m` samples is the quadratic form of the difference kernel,

.. math:: \sigma^2(m\Delta t) = \frac{1}{2m^2}\sum_k r(k)\,[2b(k) - b(k-m) - b(k+m)],
          \qquad b(j) = \max(m - |j|, 0),

a sum over :math:`|k| < 2m` (exact, :math:`O(\min(2m, S))` for a support of :math:`S`
lags). When :math:`m \ge S` it reduces to the closed form

.. math:: \sigma^2(m\Delta t) = \frac{R_0}{m} - \frac{3R_1}{2m^2},\qquad
          R_0 = \sum_k r(k) = s^2,\quad R_1 = \sum_k |k|\,r(k),

white noise ``N^2/tau`` less a ``1/tau^2`` part (what a free quantization term reads as
:math:`Q^2 < 0`). An IIR filter's response is cut where its remaining energy is below
``1e-17`` of the total, so the sums are exact to that level.

Kinds (``bandwidth`` :math:`f_c` is the -3 dB frequency in Hz):

=================  ==========================================================================
kind               filter
=================  ==========================================================================
``one_pole``       :math:`y_k = \phi y_{k-1} + (1-\phi)x_k`, :math:`\phi = e^{-2\pi f_c\Delta t}`
``butterworth``    ``scipy.signal.butter(order, f_c, fs=1/dt)`` (bilinear, prewarped)
``moving_average`` a box of :math:`L = c_1/(f_c\Delta t)` samples, :math:`c_1 = 0.4429`
                   (the box's -3 dB point); a fractional ``L`` weights its last tap by the
                   fraction, so the law is continuous in ``L`` and exact at whole lengths
``bartlett``       two such boxes in cascade (a triangle of :math:`2L-1` taps),
                   :math:`L = c_2/(f_c\Delta t)`, :math:`c_2 = 0.3189`
=================  ==========================================================================
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray
from scipy import signal

__all__ = [
    "DIGITAL_KINDS",
    "FILTER_KINDS",
    "box_length",
    "filter_avar",
    "filter_coefficients",
    "filter_gain",
    "filter_gain_analog",
    "response_length",
]

#: the discrete output filters (the analog first-order ``rc`` has its continuous law)
DIGITAL_KINDS = ("one_pole", "butterworth", "moving_average", "bartlett")
#: every kind of :class:`~allanite.terms.transients.LowPassWhite`
FILTER_KINDS = ("rc", *DIGITAL_KINDS)
#: -3 dB point of a box of length L in units of fs/L: |sinc(x)|^2 = 1/2
_BOX_3DB = 0.44294647
#: the same for two boxes in cascade: |sinc(x)|^4 = 1/2
_BARTLETT_3DB = 0.31891670
#: relative energy left in the cut tail of an IIR response
_TAIL = 1e-17
#: longest response the exact law computes
MAX_SUPPORT = 1 << 22


def box_length(kind: str, bandwidth: float, dt: float) -> float:
    """Length ``L`` in samples of a ``moving_average`` or ``bartlett`` box (at least 1)."""
    c = _BOX_3DB if kind == "moving_average" else _BARTLETT_3DB
    return max(c / (bandwidth * dt), 1.0)


def _box(length: float) -> NDArray[np.float64]:
    whole = math.floor(length)
    taps = np.ones(whole + (length > whole))
    if length > whole:
        taps[-1] = length - whole
    return taps / length


def filter_coefficients(
    kind: str, bandwidth: float, dt: float, order: int = 2
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The digital filter with unit DC gain: FIR taps and ``[]``, or IIR second-order sections.

    Returns ``(taps, sos)``: a moving average or Bartlett box has ``taps`` and an empty
    ``sos``; a one-pole or Butterworth filter ``taps = [1]`` and its sections
    (``scipy.signal.sosfilt`` form, stable for cutoffs far below the sample rate). A
    Butterworth cutoff at or above the Nyquist frequency is no filter.
    """
    none = np.zeros((0, 6))
    if kind == "one_pole":
        phi = math.exp(-2.0 * math.pi * bandwidth * dt)
        return np.ones(1), np.array([[1.0 - phi, 0.0, 0.0, 1.0, -phi, 0.0]])
    if kind == "butterworth":
        if bandwidth * dt >= 0.5:
            return np.ones(1), none
        sos = signal.butter(order, bandwidth, fs=1.0 / dt, output="sos")
        return np.ones(1), np.asarray(sos, dtype=np.float64)
    if kind in ("moving_average", "bartlett"):
        taps = _box(box_length(kind, bandwidth, dt))
        if kind == "bartlett":
            taps = np.convolve(taps, taps)
        return taps, none
    raise ValueError(f"unknown filter kind {kind!r}; known: {', '.join(DIGITAL_KINDS)}")


def pole_radius(sos: NDArray[np.float64]) -> float:
    """Largest pole modulus of second-order sections (0 for none)."""
    radius = 0.0
    for section in sos:
        radius = max(radius, float(np.max(np.abs(np.roots(section[3:])), initial=0.0)))
    return radius


def response_length(sos: NDArray[np.float64], tail: float = _TAIL) -> int:
    """Samples after which the response's remaining energy is below ``tail`` of the total."""
    radius = pole_radius(sos)
    if radius <= 0.0:
        return 3 * len(sos) + 1
    return math.ceil(math.log(tail) / (2.0 * math.log(radius))) + 16 * len(sos)


def _autocovariance(
    kind: str, bandwidth: float, dt: float, order: int
) -> tuple[NDArray[np.float64], float, float]:
    """Autocovariance ``r(0..S-1)`` of unit-variance white input, with ``R0`` and ``R1``."""
    h, sos = filter_coefficients(kind, bandwidth, dt, order)
    if len(sos):
        n = response_length(sos)
        if n > MAX_SUPPORT:
            raise ValueError(
                f"a {kind} filter of bandwidth {bandwidth:g} Hz at {1 / dt:g} Hz responds for "
                f"more than {MAX_SUPPORT} samples; use a bandwidth above {bandwidth * 10:g} Hz"
            )
        impulse = np.zeros(n)
        impulse[0] = 1.0
        h = signal.sosfilt(sos, impulse)
    n_fft = 1 << math.ceil(math.log2(2 * h.size))
    spectrum = np.fft.rfft(h, n_fft)
    r = np.fft.irfft(np.abs(spectrum) ** 2, n_fft)[: h.size]
    k = np.arange(h.size, dtype=np.float64)
    r0 = float(r[0] + 2.0 * r[1:].sum())
    r1 = float(2.0 * (k[1:] * r[1:]).sum())
    r.setflags(write=False)
    return r, r0, r1


def filter_avar(
    kind: str, bandwidth: float, order: int, m: NDArray[np.float64], dt: float
) -> NDArray[np.float64]:
    r"""Exact Allan variance at factors ``m`` of unit-density white (``N = 1``) through the filter.

    The input samples have variance ``1/dt``; see the module docstring for the sums. The
    kernel is :math:`2m - 3k` for :math:`0 \le k \le m` and :math:`-(2m - k)` for
    :math:`m < k < 2m`, so the sums are differences of prefix sums of :math:`r(k)` and
    :math:`k\,r(k)` (lags beyond the response contribute nothing).
    """
    r, _, _, p0, p1 = _prefix(kind, float(bandwidth), float(dt), int(order))
    last = r.size  # prefix sums have last + 1 entries
    mm = np.round(np.asarray(m, dtype=np.float64))
    mid = np.minimum(mm, last - 1).astype(np.int64) + 1  # lags 0..m
    end = np.minimum(2 * mm - 1, last - 1).astype(np.int64) + 1  # lags up to 2m - 1
    end = np.maximum(end, mid)
    near = 2.0 * mm * p0[mid] - 3.0 * p1[mid]
    far = 2.0 * mm * (p0[end] - p0[mid]) - (p1[end] - p1[mid])
    return np.asarray((near - far) / (2.0 * mm**2) / dt, dtype=np.float64)


@lru_cache(maxsize=256)
def _prefix(
    kind: str, bandwidth: float, dt: float, order: int
) -> tuple[NDArray[np.float64], float, float, NDArray[np.float64], NDArray[np.float64]]:
    r, r0, r1 = _autocovariance(kind, bandwidth, dt, order)
    k = np.arange(r.size, dtype=np.float64)
    w = np.where(k == 0, 1.0, 2.0) * r
    p0 = np.concatenate(([0.0], np.cumsum(w)))
    p1 = np.concatenate(([0.0], np.cumsum(w * k)))
    return r, r0, r1, p0, p1


def filter_gain(
    kind: str, bandwidth: float, order: int, f: NDArray[np.float64], dt: float
) -> NDArray[np.float64]:
    """Power gain ``|H(e^{2 pi i f dt})|^2`` of the digital filter."""
    taps, sos = filter_coefficients(kind, bandwidth, dt, order)
    w = 2.0 * np.pi * np.asarray(f, dtype=np.float64) * dt
    _, h = signal.freqz(taps, [1.0], worN=w)
    gain = np.abs(h) ** 2
    if len(sos):
        _, hs = signal.sosfreqz(sos, worN=w)
        gain = gain * np.abs(hs) ** 2
    return np.asarray(gain, dtype=np.float64)


def filter_gain_analog(
    kind: str, bandwidth: float, order: int, f: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Power gain of the filter's continuous-time equivalent (its shape far below Nyquist)."""
    x = np.asarray(f, dtype=np.float64) / bandwidth
    if kind in ("rc", "one_pole"):
        return 1.0 / (1.0 + x**2)
    if kind == "butterworth":
        return 1.0 / (1.0 + x ** (2 * order))
    power = 2 if kind == "moving_average" else 4
    c = _BOX_3DB if kind == "moving_average" else _BARTLETT_3DB
    return np.asarray(np.sinc(c * x) ** power, dtype=np.float64)
