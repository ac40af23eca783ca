"""An exact, test-only generator of the sampled noise terms (independent of allanite.simulation).

Each term is generated exactly as its ``avar`` assumes: white samples of variance N^2/dt;
angle quantization e ~ U(+-sqrt(3) Q) differenced; a discrete random walk with increments
K sqrt(dt); a ramp R t; a stationary AR(1) with phi = exp(-dt/Tc); a sinusoid with a random
phase; flicker by circulant FFT synthesis of the interval-averaged spectrum
B^2/(pi f) sinc^2(f dt) (f <= f0) on a grid eight times the record length.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from allanite.model import NoiseModel
from allanite.terms import Flicker, GaussMarkov, Quantization, RateRamp, RateRandomWalk, Sine, White


def _flicker(term: Flicker, n: int, c: int, dt: float, rng: np.random.Generator) -> np.ndarray:
    size = 8 * n
    f = np.fft.rfftfreq(size, dt)
    psd = np.zeros_like(f)
    cutoff = term.cutoff(dt)
    keep = (f > 0) & (f <= cutoff)
    psd[keep] = term.B**2 / (np.pi * f[keep]) * np.sinc(f[keep] * dt) ** 2
    # one-sided psd -> variance of each real Fourier coefficient
    amp = np.sqrt(psd * size / (4.0 * dt))
    out = np.empty((n, c))
    for start in range(0, c, 16):
        k = min(16, c - start)
        z = rng.standard_normal((f.size, k)) + 1j * rng.standard_normal((f.size, k))
        z *= amp[:, None]
        z[-1] = z[-1].real * math.sqrt(2.0)  # Nyquist bin is real
        out[:, start : start + k] = (
            np.fft.irfft(z, n=size, axis=0)[:n] * math.sqrt(size) / math.sqrt(size)
        )
    return out


def simulate(model: NoiseModel, n: int, dt: float, channels: int = 1, seed: int = 0) -> np.ndarray:
    """Rate samples ``(n, channels)`` of ``model`` sampled at period ``dt``."""
    rng = np.random.default_rng(seed)
    x = np.zeros((n, channels))
    t = np.arange(n)[:, None] * dt
    for term in model.terms:
        if isinstance(term, White):
            x += term.N / math.sqrt(dt) * rng.standard_normal((n, channels))
        elif isinstance(term, Quantization):
            e = rng.uniform(-math.sqrt(3.0) * term.Q, math.sqrt(3.0) * term.Q, (n + 1, channels))
            x += np.diff(e, axis=0) / dt
        elif isinstance(term, RateRandomWalk):
            x += np.cumsum(term.K * math.sqrt(dt) * rng.standard_normal((n, channels)), axis=0)
        elif isinstance(term, RateRamp):
            x += term.R * t
        elif isinstance(term, GaussMarkov):
            phi = math.exp(-dt / term.tau_c)
            w = rng.standard_normal((n, channels)) * term.sigma * math.sqrt(1.0 - phi**2)
            w[0] = rng.standard_normal(channels) * term.sigma
            x += signal.lfilter([1.0], [1.0, -phi], w, axis=0)
        elif isinstance(term, Sine):
            phase = rng.uniform(0, 2 * np.pi, channels)
            x += term.amplitude * np.sin(2 * np.pi * term.frequency * t + phase)
        elif isinstance(term, Flicker):
            x += _flicker(term, n, channels, dt, rng)
        else:  # pragma: no cover - only the terms above exist in the tests
            raise TypeError(f"no test generator for {term!r}")
    return x
