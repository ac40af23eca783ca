r"""Synchronous error of a stabilised platform on an oscillating stand.

The stand oscillates with rate amplitude ``A`` at frequency ``f0``; the gyro on the stabilised
platform records the residual rate. Its component at ``f0`` (amplitude ``a1``) is the
synchronous error: relative error ``a1 / A``, attenuation ``A / a1``. Odd harmonics at
``3 f0, 5 f0, 7 f0, 9 f0`` reveal dry friction (a friction torque that flips sign with the
motion is a square-like wave whose Fourier series has odd harmonics only).

Estimator. The amplitudes are the least-squares fit of

.. math:: r(t) = c_0 + c_1 t' + \sum_k \big(a_k \cos 2\pi k f_0 t + b_k \sin 2\pi k f_0 t\big)

(``t'`` the centred time, for a slow drift), i.e. the discrete Fourier transform evaluated at
exactly ``k f0`` with the harmonics fitted jointly, so a record that does not hold an integer
number of periods leaks neither into the amplitude (no scalloping loss) nor between
harmonics. The amplitude is ``sqrt(a_k^2 + b_k^2)``. Its standard uncertainty follows from the
noise floor: for noise with one-sided PSD ``S(f)`` (locally flat) and record length ``T_r``,
each of ``a_k, b_k`` has variance ``S(k f0) / T_r`` (for white noise of variance ``s^2`` at
rate ``fs``: ``2 s^2 / N``). ``S`` is estimated from the Hann-windowed periodogram of the fit
residual in a band of +-f0/2 around each harmonic (median / ln 2, robust to stray lines). For
pure noise the amplitude is Rayleigh distributed, so the probability that noise alone reaches
the fitted amplitude is ``p = exp(-amp^2 / (2 sigma^2))``.

Reading the amplitude from the noisy time series (half its peak-to-peak) measures mostly the
noise: in the source's example (2 Hz, 200 deg/s stand) the FFT gives ``a1/A = 0.00085``
where the time series suggests about 0.005. :attr:`SynchronousError.peak_reading` reports that
naive number for comparison.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite._deprecation import keyword_only_fs
from allanite.impact._checks import positive as _check_positive

__all__ = ["HarmonicAmplitude", "SynchronousError", "synchronous_error"]

_MIN_PERIODS = 4
_EXCLUDE_BINS = 3
_CHUNK = 1 << 18


def _design(
    start: int, stop: int, n: int, fs: float, freqs: Sequence[float]
) -> NDArray[np.float64]:
    """Columns ``1, t', cos, sin, ...`` of the harmonic fit for samples ``start:stop``.

    ``t'`` is the time centred on the record and scaled to [-1, 1].
    """
    idx = np.arange(start, stop, dtype=np.float64)
    t = idx / fs
    cols = [np.ones(stop - start), (idx - (n - 1) / 2.0) / (n / 2.0)]
    for f in freqs:
        phase = 2.0 * np.pi * f * t
        cols += [np.cos(phase), np.sin(phase)]
    return np.column_stack(cols)


@dataclass(frozen=True)
class HarmonicAmplitude:
    """Fitted amplitude of one harmonic of the stand frequency.

    Attributes
    ----------
    order : int
        Harmonic number k (1 = the stand frequency).
    frequency : float
        ``k f0`` in Hz.
    amplitude : float
        Fitted amplitude in the record's rate unit.
    uncertainty : float
        Standard uncertainty of each quadrature component ``sqrt(S(k f0) / T_r)``, which is
        the standard uncertainty of the amplitude when it is well above the noise.
    phase : float
        Phase in rad of ``amplitude * cos(2 pi k f0 t + phase)``, t from the first sample.
    noise_psd : float
        Estimated one-sided noise PSD at ``k f0`` in unit^2/Hz.
    p_value : float
        Probability that noise alone gives at least this amplitude (Rayleigh tail).
    detected : bool
        ``p_value < significance``.
    """

    order: int
    frequency: float
    amplitude: float
    uncertainty: float
    phase: float
    noise_psd: float
    p_value: float
    detected: bool


@dataclass(frozen=True)
class SynchronousError:
    """Synchronous error of a platform on an oscillating stand.

    Attributes
    ----------
    stand_amplitude : float
        Stand rate amplitude ``A`` (same unit as the record).
    frequency : float
        Stand frequency ``f0`` in Hz.
    fundamental : HarmonicAmplitude
        The component at ``f0`` (``a1``).
    harmonics : tuple of HarmonicAmplitude
        The odd harmonics examined for dry friction (3, 5, 7, 9 by default, those below the
        Nyquist frequency).
    peak_reading : float
        Half the peak-to-peak of the (mean- and drift-removed) record: what the time-series
        plot suggests as the amplitude; mostly noise when ``a1`` is small.
    n_samples : int
        Record length.
    fs : float
        Sampling frequency in Hz.
    """

    stand_amplitude: float
    frequency: float
    fundamental: HarmonicAmplitude
    harmonics: tuple[HarmonicAmplitude, ...]
    peak_reading: float
    n_samples: int
    fs: float

    @property
    def a1(self) -> float:
        """Amplitude of the synchronous error at ``f0``."""
        return self.fundamental.amplitude

    @property
    def relative_error(self) -> float:
        """``a1 / A``."""
        return self.fundamental.amplitude / self.stand_amplitude

    @property
    def relative_uncertainty(self) -> float:
        """Standard uncertainty of ``a1 / A``."""
        return self.fundamental.uncertainty / self.stand_amplitude

    @property
    def attenuation(self) -> float:
        """``A / a1`` (inf if ``a1`` is 0)."""
        a1 = self.fundamental.amplitude
        return self.stand_amplitude / a1 if a1 > 0 else math.inf

    @property
    def attenuation_uncertainty(self) -> float:
        """First-order standard uncertainty ``A sigma / a1^2`` of the attenuation."""
        a1 = self.fundamental.amplitude
        return self.stand_amplitude * self.fundamental.uncertainty / a1**2 if a1 > 0 else math.inf

    @property
    def peak_relative_error(self) -> float:
        """The naive ``peak_reading / A``, for comparison with :attr:`relative_error`."""
        return self.peak_reading / self.stand_amplitude

    @property
    def dry_friction(self) -> bool:
        """Whether any odd harmonic stands out of the noise (sign of dry friction)."""
        return any(h.detected for h in self.harmonics)

    def harmonic_ratios(self) -> dict[int, float]:
        """Amplitude of each odd harmonic relative to ``a1``."""
        a1 = self.fundamental.amplitude
        return {h.order: (h.amplitude / a1 if a1 > 0 else math.inf) for h in self.harmonics}


def _noise_psd(
    residual: NDArray[np.float64], fs: float, centres: Sequence[float], band: float
) -> list[float]:
    """One-sided PSD of the residual near each centre: median of Hann periodogram bins / ln 2."""
    n = residual.size
    win = np.hanning(n)
    spec = np.abs(np.fft.rfft(residual * win)) ** 2 * 2.0 / (fs * np.sum(win**2))
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    df = fs / n
    near_line = np.zeros(freqs.size, dtype=bool)
    for fc in centres:
        near_line |= np.abs(freqs - fc) <= _EXCLUDE_BINS * df
    out = []
    for fc in centres:
        sel = (np.abs(freqs - fc) <= band) & (freqs > 0)
        bins = spec[sel & ~near_line]
        if bins.size < 8:
            raise ValueError(
                f"too few spectral bins near {fc:.4g} Hz to estimate the noise floor; record "
                "at least 20 periods of the stand frequency"
            )
        out.append(float(np.median(bins) / math.log(2.0)))
    return out


@keyword_only_fs
def synchronous_error(
    rate: ArrayLike,
    *,
    fs: float,
    amplitude: float,
    frequency: float,
    harmonics: Sequence[int] = (3, 5, 7, 9),
    significance: float = 0.01,
) -> SynchronousError:
    """Estimate the synchronous error ``a1 / A`` and odd harmonics on an oscillating stand.

    Parameters
    ----------
    rate : array_like
        Recorded rate of the platform gyro, 1-D, any rate unit.
    fs : float
        Sampling frequency in Hz.
    amplitude : float
        Stand rate amplitude ``A`` in the same unit as ``rate``.
    frequency : float
        Stand frequency ``f0`` in Hz.
    harmonics : sequence of int
        Harmonic orders to examine for dry friction (> 1); orders at or above the Nyquist
        frequency are skipped.
    significance : float
        Level of the noise-only test that flags a harmonic as detected.

    Returns
    -------
    SynchronousError

    References
    ----------
    Least-squares harmonic estimation: S. M. Kay, *Fundamentals of Statistical Signal
    Processing: Estimation Theory* (1993), example 4.2; Rayleigh detection of a sinusoid of
    known frequency: ibid., *Detection Theory* (1998), sec. 7.6.
    """
    x = np.asarray(rate, dtype=np.float64)
    if x.ndim != 1:
        raise ValueError(f"rate must be a 1-D record, got shape {x.shape}; pass one axis")
    if not np.all(np.isfinite(x)):
        raise ValueError("rate contains NaN or inf; remove or fill the gaps first")
    fs = _check_positive("fs", fs)
    a_stand = _check_positive("amplitude", amplitude)
    f0 = _check_positive("frequency", frequency)
    if not 0.0 < significance < 1.0:
        raise ValueError(f"significance must lie in (0, 1), got {significance}")
    orders = [1]
    for k in harmonics:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 2:
            raise ValueError(f"harmonic orders must be integers >= 2, got {k!r}")
        if k * f0 < fs / 2.0 and int(k) not in orders:
            orders.append(int(k))
    if f0 >= fs / 2.0:
        raise ValueError(f"frequency {f0} Hz must lie below the Nyquist frequency {fs / 2} Hz")
    n = x.size
    duration = n / fs
    if duration * f0 < _MIN_PERIODS:
        raise ValueError(
            f"the record holds {duration * f0:.3g} periods of {f0} Hz; record at least "
            f"{_MIN_PERIODS} (better 20 or more)"
        )

    freqs = [k * f0 for k in orders]
    # normal equations accumulated in chunks (bounded memory for long records): the columns
    # are nearly orthogonal (>= 4 periods), so the Gram matrix is well conditioned
    n_col = 2 + 2 * len(orders)
    gram = np.zeros((n_col, n_col))
    rhs = np.zeros(n_col)
    for start in range(0, n, _CHUNK):
        block = _design(start, min(n, start + _CHUNK), n, fs, freqs)
        gram += block.T @ block
        rhs += block.T @ x[start : start + _CHUNK]
    coef = np.linalg.solve(gram, rhs)
    residual = np.empty(n)
    detrended = np.empty(n)
    for start in range(0, n, _CHUNK):
        stop = min(n, start + _CHUNK)
        block = _design(start, stop, n, fs, freqs)
        residual[start:stop] = x[start:stop] - block @ coef
        detrended[start:stop] = x[start:stop] - block[:, :2] @ coef[:2]
    psd = _noise_psd(residual, fs, [k * f0 for k in orders], band=f0 / 2.0)

    fitted = []
    for i, k in enumerate(orders):
        a, b = coef[2 + 2 * i], coef[3 + 2 * i]
        amp = float(math.hypot(a, b))
        sigma = math.sqrt(psd[i] / duration)
        p = math.exp(-(amp**2) / (2.0 * sigma**2)) if sigma > 0 else 0.0
        fitted.append(
            HarmonicAmplitude(
                order=k,
                frequency=k * f0,
                amplitude=amp,
                uncertainty=sigma,
                phase=float(math.atan2(-b, a)),
                noise_psd=psd[i],
                p_value=p,
                detected=p < significance,
            )
        )
    peak = float((detrended.max() - detrended.min()) / 2.0)
    return SynchronousError(
        stand_amplitude=a_stand,
        frequency=f0,
        fundamental=fitted[0],
        harmonics=tuple(fitted[1:]),
        peak_reading=peak,
        n_samples=n,
        fs=fs,
    )
