r"""Stationary Gaussian noise of a given sampled PSD by frequency-domain synthesis.

The record of ``n`` samples is cut from one period of a circulant process of length
:math:`L \ge 4n` (a power of two): with :math:`f_k = k/(L\Delta t)` and independent standard
normal :math:`a_k, b_k`,

.. math:: y_j = \sum_{k=1}^{L/2} \sqrt{S(f_k)\,\Delta f}\,(a_k\cos 2\pi f_k j\Delta t
          - b_k \sin 2\pi f_k j\Delta t),\qquad \Delta f = 1/(L\Delta t),

so every line carries the power :math:`S(f_k)\Delta f` of the one-sided sampled PSD ``S`` and
the expected Allan variance is the Riemann sum
:math:`\sum_k S(f_k)\Delta f\,|H_m(f_k)|^2` of the exact integral
(:func:`expected_avar`). This is the frequency-domain filtering of white noise of
Kasdin & Walter (1992), with the filter's squared gain set to the term's exact sampled PSD
(for flicker: :math:`B^2/(\pi f)\,\mathrm{sinc}^2(f\Delta t)` below the cutoff) instead of the
fractional-difference filter, so that the samples have the term's exact sampled Allan
variance. The lines below :math:`1/(L\Delta t)` are missing; their share of the Allan
variance at :math:`\tau \le T/10` is below :math:`7(\tau/L\Delta t)^2 < 0.05\%` for flicker.

References
----------
N. J. Kasdin, T. Walter, "Discrete simulation of power law noise", Proc. IEEE Frequency
Control Symposium (1992) 274-283; J. Timmer, M. Koenig, "On generating power law noise",
Astron. Astrophys. 300 (1995) 707-710.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.simulation.streams import TermStream, block_length
from allanite.variance.transfer import avar_transfer

__all__ = ["SpectralStream", "WholeRecordStream", "expected_avar", "synthesis_length"]

PsdFunction = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def _padded(n_samples: int, n_channels: int) -> int:
    block = block_length(n_channels)
    return -(-n_samples // block) * block


def synthesis_length(n_samples: int, n_channels: int = 1) -> int:
    """Circulant length ``L``: the smallest power of two >= 4 x the padded record length."""
    padded = _padded(n_samples, n_channels)
    return 1 << int(np.ceil(np.log2(4 * padded)))


def _line_powers(psd: PsdFunction, length: int, dt: float) -> NDArray[np.float64]:
    f = np.arange(1, length // 2 + 1) / (length * dt)
    power = np.asarray(psd(f), dtype=np.float64) / (length * dt)
    if np.any(~np.isfinite(power)) or np.any(power < 0):
        raise ValueError("the PSD must be finite and non-negative on (0, Nyquist]")
    return power


def expected_avar(
    psd: PsdFunction, m: ArrayLike, dt: float, n_samples: int, n_channels: int = 1
) -> NDArray[np.float64]:
    r"""Return the expected Allan variance of :class:`SpectralStream` samples.

    It is the line sum
    :math:`\sum_k S(f_k)\Delta f\,2\sin^4(\pi f_k m\Delta t)/(m\sin(\pi f_k\Delta t))^2`.
    """
    length = synthesis_length(n_samples, n_channels)
    power = _line_powers(psd, length, dt)
    f = np.arange(1, length // 2 + 1) / (length * dt)
    # one factor at a time: the synthesis grid can hold millions of lines
    factors = np.atleast_1d(np.asarray(m, dtype=np.float64))
    return np.array([float(np.sum(power * avar_transfer(f, [mm], dt)[0])) for mm in factors])


class WholeRecordStream(TermStream):
    """A stream whose whole record is synthesised at once, then served block by block.

    Subclasses implement :meth:`_synthesise`, called once on the first request with the record
    length rounded up to whole blocks; the samples therefore never depend on the chunking.
    It holds ``8 n_samples C`` bytes: for records of moderate length.
    """

    def __init__(self, n_samples: int, fs: float, n_channels: int, seed: Any = None) -> None:
        super().__init__(fs, n_channels, seed)
        if n_samples < 1:
            raise ValueError(f"n_samples must be positive, got {n_samples}")
        self.n_samples = int(n_samples)
        self._record: NDArray[np.float64] | None = None

    @abstractmethod
    def _synthesise(self, padded: int) -> NDArray[np.float64]:
        """Return the whole record, shape ``(padded, C)``."""

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        if self._record is None:
            self._record = self._synthesise(_padded(self.n_samples, self.n_channels))
        if start + n > self._record.shape[0]:
            raise ValueError(
                f"this {type(self).__name__} was built for {self.n_samples} samples; ask the "
                "model for the full length up front (or use the streaming flicker generator)"
            )
        return self._record[start : start + n]


class SpectralStream(WholeRecordStream):
    """Samples of a stationary Gaussian process with one-sided sampled PSD ``psd(f)``.

    The whole record (``n_samples`` rounded up to whole blocks, per channel) is synthesised on
    the first request and then served block by block, so it needs ``8 n_samples C`` bytes;
    use it for records of moderate length (the streaming flicker generator serves longer ones).
    """

    def __init__(
        self, psd: PsdFunction, n_samples: int, fs: float, n_channels: int, seed: Any = None
    ) -> None:
        super().__init__(n_samples, fs, n_channels, seed)
        self.length = synthesis_length(self.n_samples, self.n_channels)
        self._amplitude = np.sqrt(_line_powers(psd, self.length, self.dt))

    def _synthesise(self, padded: int) -> NDArray[np.float64]:
        record = np.empty((padded, self.n_channels))
        half = self.length // 2
        for c in range(self.n_channels):
            z = self.rng.standard_normal((2, half))
            spectrum = np.zeros(half + 1, dtype=np.complex128)
            spectrum[1:] = (z[0] + 1j * z[1]) * self._amplitude * (0.5 * self.length)
            # the Nyquist line is real: all of its power goes into the cosine
            spectrum[half] = z[0, -1] * self._amplitude[-1] * self.length
            record[:, c] = np.fft.irfft(spectrum, n=self.length)[:padded]
        return record
