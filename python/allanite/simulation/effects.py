r"""Streams of deterministic, per-run and event-driven effects.

Each sample is the exact mean of the continuous rate over its sample period unless the term
is defined on point samples (the sinusoid, like :class:`allanite.terms.Sine`).

* :class:`SineStream` -- :math:`A\sin(2\pi f_0 t_k + \varphi)` at the sample instants, a random
  phase per channel and run unless given.
* :class:`RampStream` -- :math:`R t`, sample means :math:`R(k + 1/2)\Delta t`.
* :class:`ConstantStream` -- a random constant per channel and run (turn-on bias).
* :class:`WarmUpStream` -- :math:`A e^{-t/T_w}`, sample means
  :math:`A (T_w/\Delta t) e^{-k\Delta t/T_w}(1 - e^{-\Delta t/T_w})`.
* :class:`StepStream` -- bias steps at the events of a Poisson process (rate
  :math:`1/T_s`), Gaussian sizes; a step at fraction :math:`u` of a sample period enters that
  sample with weight :math:`1-u`.
* :class:`SpikeStream` -- isolated outliers: a sample is hit with probability
  :math:`p = 1 - e^{-\lambda\Delta t}` and then carries :math:`\pm a`.
* :class:`TelegraphStream` -- the symmetric random telegraph signal :math:`\pm a`, switching
  at rate :math:`\lambda = 1/(2T_c)`; the sample mean over a period that starts in state
  :math:`s` and has switches at fractions :math:`u_1 < \dots < u_k` is
  :math:`s[(-1)^k + 2\sum_i (-1)^{i-1}u_i]`.
* :class:`FilteredWhiteStream` -- white samples through a sensor's digital output filter
  ``(b, a)`` (:class:`allanite.terms.LowPassWhite`), the filter state carried across blocks.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite import _core
from allanite.simulation.streams import TermStream

#: most events (steps, switches) expected per sample: beyond it a sample averages so many that
#: the effect is Gaussian noise (use GaussMarkov / RateRandomWalk terms instead)
MAX_EVENTS_PER_SAMPLE = 100.0

__all__ = [
    "ConstantStream",
    "FilteredWhiteStream",
    "RampStream",
    "SineStream",
    "SpikeStream",
    "StepStream",
    "TelegraphStream",
    "WarmUpStream",
]


def _events_per_sample(mean: float, what: str, parameter: str) -> float:
    if mean > MAX_EVENTS_PER_SAMPLE:
        raise ValueError(
            f"{what}: {mean:.3g} events per sample period; with so many the samples are "
            f"Gaussian noise: raise {parameter} or the sampling rate, or model the effect as "
            "a Gauss-Markov or rate random walk term"
        )
    return mean


class SineStream(TermStream):
    """Point samples of a sinusoid (random phase per channel unless ``phase`` is given)."""

    def __init__(
        self,
        amplitude: float,
        frequency: float,
        fs: float,
        n_channels: int,
        seed: Any = None,
        *,
        phase: float | None = None,
    ) -> None:
        super().__init__(fs, n_channels, seed)
        self.amplitude = float(amplitude)
        self.cycles_per_sample = float(frequency) / self.fs
        drawn = self.rng.uniform(0.0, 2.0 * np.pi, self.n_channels)
        self.phase = drawn if phase is None else np.full(self.n_channels, float(phase))

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        k = start + np.arange(n, dtype=np.float64)
        cycles = np.mod(self.cycles_per_sample * k, 1.0)[:, None]
        return self.amplitude * np.sin(2.0 * np.pi * cycles + self.phase[None, :])


class RampStream(TermStream):
    """Sample means of the rate ramp ``R t``: ``R (k + 1/2) dt``."""

    def __init__(self, R: float, fs: float, n_channels: int, seed: Any = None) -> None:
        super().__init__(fs, n_channels, seed)
        self.R = float(R)

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        t = self.times(start, n) + 0.5 * self.dt
        return np.repeat(self.R * t, self.n_channels, axis=1)


class ConstantStream(TermStream):
    """A constant per channel drawn once per run from ``N(0, sigma^2)`` (turn-on bias)."""

    def __init__(self, sigma: float, fs: float, n_channels: int, seed: Any = None) -> None:
        super().__init__(fs, n_channels, seed)
        self.value = float(sigma) * self.rng.standard_normal(self.n_channels)

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        return np.asarray(
            np.broadcast_to(self.value, (n, self.n_channels)).copy(), dtype=np.float64
        )


class FilteredWhiteStream(TermStream):
    """White samples of standard deviation ``sigma`` through a digital filter.

    The filter is FIR ``taps`` followed by the IIR second-order sections ``sos``
    (:func:`allanite.terms.filter_laws.filter_coefficients`). It starts in its stationary
    state: the state reached after a burn-in of white input as long as its response (to a
    relative energy of 1e-17), so the first sample already has the stationary law; the state
    is then carried from block to block, so the samples depend on the seed alone.
    """

    def __init__(
        self,
        sigma: float,
        taps: NDArray[np.float64],
        sos: NDArray[np.float64],
        fs: float,
        n_channels: int,
        seed: Any = None,
    ) -> None:
        from scipy import signal

        from allanite.terms.filter_laws import response_length

        super().__init__(fs, n_channels, seed)
        self._signal = signal
        self.sigma = float(sigma)
        self.taps, self.sos = np.asarray(taps, dtype=np.float64), np.asarray(sos)
        self._fir_state = np.zeros((self.taps.size - 1, self.n_channels))
        self._iir_state = np.zeros((len(self.sos), 2, self.n_channels))
        burn = self.taps.size + (response_length(self.sos) if len(self.sos) else 0)
        for begin in range(0, burn, 1 << 16):
            self._generate(0, min(1 << 16, burn - begin))

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        y = self.sigma * self.rng.standard_normal((n, self.n_channels))
        if self.taps.size > 1:
            y, self._fir_state = self._signal.lfilter(
                self.taps, [1.0], y, axis=0, zi=self._fir_state
            )
        if len(self.sos):
            y, self._iir_state = self._signal.sosfilt(self.sos, y, axis=0, zi=self._iir_state)
        return np.asarray(y, dtype=np.float64)


class WarmUpStream(TermStream):
    """Sample means of the warm-up transient ``A exp(-t / Tw)``."""

    def __init__(
        self, amplitude: float, tau_w: float, fs: float, n_channels: int, seed: Any = None
    ) -> None:
        super().__init__(fs, n_channels, seed)
        self.amplitude = float(amplitude)
        self.tau_w = float(tau_w)
        self._first = self.amplitude * (self.tau_w / self.dt) * -math.expm1(-self.dt / self.tau_w)

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        t = self.times(start, n)
        values = self._first * np.exp(-t / self.tau_w)
        return np.repeat(values, self.n_channels, axis=1)


class StepStream(TermStream):
    """Bias steps: Poisson events of mean interval ``interval`` (s), sizes ``N(0, size^2)``."""

    def __init__(
        self, size: float, interval: float, fs: float, n_channels: int, seed: Any = None
    ) -> None:
        super().__init__(fs, n_channels, seed)
        self.size = float(size)
        self.mean_events = _events_per_sample(self.dt / float(interval), "bias steps", "interval")
        self.level = np.zeros((1, self.n_channels))

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        c = self.n_channels
        counts = self.rng.poisson(self.mean_events, (n, c)).ravel()
        total = int(counts.sum())
        sizes = self.size * self.rng.standard_normal(total)
        where = self.rng.random(total)
        sample = np.repeat(np.arange(n * c), counts)
        jumps = np.bincount(sample, weights=sizes, minlength=n * c).reshape(n, c)
        partial = np.bincount(sample, weights=sizes * (1.0 - where), minlength=n * c)
        one = np.ones(1)
        # the level is a random walk of the jumps: level before sample k, in the C++ core
        before = _core.ar1_bank(self.level, one, one, one, np.zeros(1), jumps[:, None, :])
        return before + partial.reshape(n, c)


class SpikeStream(TermStream):
    """Isolated outliers ``+-amplitude``, each sample hit with probability ``1 - exp(-rate dt)``."""

    def __init__(
        self, amplitude: float, rate: float, fs: float, n_channels: int, seed: Any = None
    ) -> None:
        super().__init__(fs, n_channels, seed)
        self.amplitude = float(amplitude)
        self.probability = -math.expm1(-float(rate) * self.dt)

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        hit = self.rng.random((n, self.n_channels)) < self.probability
        sign = np.where(self.rng.random((n, self.n_channels)) < 0.5, -1.0, 1.0)
        return np.where(hit, self.amplitude * sign, 0.0)


class TelegraphStream(TermStream):
    """Sample means of a symmetric random telegraph signal ``+-amplitude``, corr. time ``tau_c``.

    The state switches at rate ``1 / (2 tau_c)``, so the autocovariance is
    ``amplitude^2 exp(-|t| / tau_c)``, that of a Gauss-Markov process.
    """

    def __init__(
        self, amplitude: float, tau_c: float, fs: float, n_channels: int, seed: Any = None
    ) -> None:
        super().__init__(fs, n_channels, seed)
        self.amplitude = float(amplitude)
        self.mean_switches = _events_per_sample(
            self.dt / (2.0 * float(tau_c)), "telegraph", "tau_c"
        )
        self.state = np.where(self.rng.random(self.n_channels) < 0.5, -1.0, 1.0)

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        c = self.n_channels
        counts = self.rng.poisson(self.mean_switches, (n, c))
        flat = counts.ravel()
        total = int(flat.sum())
        where = self.rng.random(total)
        sample = np.repeat(np.arange(n * c), flat)
        order = np.lexsort((where, sample))
        where = where[order]
        first = np.cumsum(flat) - flat
        rank = np.arange(total) - np.repeat(first, flat)
        signed = np.where(rank % 2 == 0, where, -where)
        sums = np.bincount(sample, weights=signed, minlength=n * c).reshape(n, c)
        before = np.cumsum(counts, axis=0) - counts
        state = self.state[None, :] * np.where(before % 2 == 0, 1.0, -1.0)
        parity = np.where(counts % 2 == 0, 1.0, -1.0)
        self.state = self.state * np.where(counts.sum(axis=0) % 2 == 0, 1.0, -1.0)
        return np.asarray(self.amplitude * state * (parity + 2.0 * sums), dtype=np.float64)
