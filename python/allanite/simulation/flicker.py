r"""Flicker (1/f) rate noise: spectral synthesis, a streaming bank + FIR, or Kasdin's filter.

* Records up to :data:`SPECTRAL_MAX_SAMPLES` samples (and :data:`SPECTRAL_MAX_VALUES` values
  over all channels): :class:`~allanite.simulation.spectral.SpectralStream` with the term's
  exact sampled PSD :math:`S(f) = B^2/(\pi f)\,\mathrm{sinc}^2(f\Delta t)` (interval averages
  of band-limited 1/f noise), so the samples have the exact Allan variance of
  :class:`allanite.terms.Flicker` down to :math:`\tau = \Delta t`.
* Longer records (or ``method="bank"``): :class:`FlickerStream`, in bounded memory and for any
  length, the sum of three independent parts whose sampled PSDs add up to :math:`S`:

  1. a bank of point-sampled stationary AR(1) processes with log-spaced correlation times
     :math:`T_j = T_0 r^j` (:data:`STREAM_PER_DECADE` per decade, :math:`T_0` =
     :data:`STREAM_FASTEST_TC` samples, up to :data:`STREAM_SLOWEST_RECORDS` record lengths)
     and the weights :math:`s_j^2 = B^2\ln r/\pi` of the log-spaced relaxation sum, which make
     :math:`\sum_j 4 s_j^2 T_j/(1 + (2\pi f T_j)^2) = B^2/(\pi f)` up to a relative ripple
     :math:`4 e^{-\pi^2/\ln r} = 1.4\times 10^{-7}` between the two ends (C++ core);
  2. a random walk standing for the components slower than the last one (their PSD, for
     :math:`f \gg 1/T_{max}`, is :math:`\sum s_j^2/(\pi^2 f^2 T_j)`, a random walk's);
  3. the rest, :math:`S - S_\text{bank}` (non-negative by design: the bank lacks the fast
     components, :math:`\approx 0.94 B^2 T_0` at low frequency), as white noise through a
     zero-phase FIR filter of :data:`STREAM_FIR_TAPS` taps (frequency sampling of
     :math:`\sqrt{(S - S_\text{bank})/2}` on :data:`STREAM_DESIGN_GRID` lines), applied by
     overlap-save in fixed blocks. Its correlation is short (:math:`\sim T_0`), so the
     truncated filter reproduces it, including the interval-average :math:`\mathrm{sinc}^2`
     factor and the band edge at the cutoff.

  Every part's law is exact and computed in
  :func:`allanite.terms.flicker_laws.bank_avar` (AR(1) and walk in closed form, the FIR from
  its taps' autocovariance). With ``f0`` unset it deviates from the term's
  :meth:`~allanite.terms.Flicker.avar` by at most :math:`2\times 10^{-12}` (relative) for
  :math:`\tau \le 1000\Delta t` and :math:`2\times 10^{-6}` up to half the record (the slow
  end, where the walk stands for the missing components), for records of :math:`2^{22}` to
  :math:`10^9` samples (``benchmarks/results/sim_flicker_stream.md``): far inside the
  chi-square band of any record (95% half-width :math:`9\times 10^{-5}` at
  :math:`\tau = \Delta t` for :math:`10^9` samples). With a cutoff ``f0`` below Nyquist the
  bank's output first goes through a FIR low-pass (pass band to :math:`0.9 f_0`, raised-cosine
  edge to :math:`f_0`), which removes its tails above ``f0``, and the residual (then with
  :math:`2^{15} \cdot 2^{\lceil\log_2(0.5/f_0\Delta t)\rceil}` taps, at most :math:`2^{18}`)
  takes the band edge; the law subtracts the low-pass's loss (a smooth integral). The
  remaining error is the truncated band edge: :math:`10^{-5}` for
  :math:`f_0 \ge 0.1/\Delta t`, :math:`8\times 10^{-5}` at :math:`0.01/\Delta t`.
  Cost: one normal number per AR(1) component (26 to 36) per sample and channel; memory: the
  FIR's last :data:`STREAM_FIR_TAPS` inputs and one :data:`STREAM_FFT` block per channel.
* ``method="kasdin"`` (on request only, records of known length up to
  :data:`~allanite.simulation.kasdin.KASDIN_MAX_SAMPLES`): Kasdin's fractional-difference
  filter of white noise, :class:`~allanite.simulation.kasdin.KasdinStream`; its own exact
  Allan variance is :func:`~allanite.terms.flicker_laws.kasdin_avar` (+70% over the term at
  :math:`\tau = \Delta t`, the 0.664 B plateau from about :math:`100\Delta t` on).

:func:`flicker_bank` (a point-sampled Gauss-Markov bank plus white noise fitted to the sampled
PSD; its exact law is -3.9% off the term at :math:`\tau = \Delta t` and up to 9% over the
first decades, tens of standard errors on long records) is no longer a simulation method: it
is the Gauss-Markov reading of a flicker term used by the error laws of
:mod:`allanite.impact`.

References
----------
J. A. Barnes, D. W. Allan, "A statistical model of flicker noise", Proc. IEEE 54 (1966);
sum-of-relaxation-processes approximation of 1/f noise.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import nnls

from allanite.simulation.gaussian import Ar1BankStream
from allanite.simulation.kasdin import KasdinStream
from allanite.simulation.spectral import SpectralStream
from allanite.simulation.streams import TermStream, seed_sequence
from allanite.terms.flicker_psd import flicker_psd_sampled

__all__ = [
    "FLICKER_METHODS",
    "SPECTRAL_MAX_SAMPLES",
    "FirStream",
    "FlickerDesign",
    "FlickerStream",
    "flicker_bank",
    "flicker_design",
    "flicker_stream",
]

#: ways to simulate flicker (see :func:`flicker_stream`)
FLICKER_METHODS: tuple[str, ...] = ("auto", "spectral", "kasdin", "bank")
#: longest record synthesised spectrally in one piece (longer ones use the streaming bank);
#: one channel's synthesis needs about 24 x 4 x 8 bytes per sample transiently (200 MB here)
SPECTRAL_MAX_SAMPLES = 1 << 21
#: and at most this many values (samples x channels) held for all channels (128 MB)
SPECTRAL_MAX_VALUES = 1 << 24
#: AR(1) components per decade of correlation time in the streaming generator (PSD ripple
#: 4 exp(-pi^2 / ln r) = 1.4e-7 for r = 10^(1/4))
STREAM_PER_DECADE = 4
#: its fastest AR(1) component, in samples (faster parts of the PSD are the FIR's)
STREAM_FASTEST_TC = 256.0
#: its slowest AR(1) component is at least this many record lengths (slower: a random walk)
STREAM_SLOWEST_RECORDS = 100.0
#: taps of its FIR residual filter (times 2^ceil(log2(0.5 / f0 dt)) below Nyquist, <= 2^18)
STREAM_FIR_TAPS = 1 << 15
#: frequency lines (over [0, 1/dt)) on which the FIR residual filter is designed
STREAM_DESIGN_GRID = 1 << 20
#: FFT length of the overlap-save FIR filtering (fixed, so the samples never depend on chunks)
STREAM_FFT = 1 << 17
#: Gauss-Markov components per decade of correlation time in :func:`flicker_bank`
PER_DECADE = 3
#: components up to this correlation time (in samples) are fitted, slower ones analytic
FITTED_TC = 300.0
#: record length assumed by the streaming bank when the caller does not say
DEFAULT_BANK_SAMPLES = 10**9


def _ar1_psd(u: NDArray[np.float64], tc: float) -> NDArray[np.float64]:
    """One-sided PSD of a unit-variance point-sampled AR(1) with Tc in samples (dt = 1)."""
    phi = math.exp(-1.0 / tc)
    one_minus = -math.expm1(-1.0 / tc)
    # |1 - phi e^{-2 pi i u}|^2 written without cancellation for phi -> 1 and u -> 0
    denominator = one_minus**2 + 4.0 * phi * np.sin(np.pi * u) ** 2
    return 2.0 * one_minus * (1.0 + phi) / denominator


@functools.lru_cache(maxsize=32)
def _unit_bank(decades: int, cutoff: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r"""Return the correlation times (samples) and variances (per B^2); last = white.

    Components slower than :data:`FITTED_TC` samples get the analytic weight of a
    log-spaced relaxation sum, :math:`s^2 = B^2\ln(r)/\pi` (ratio ``r`` of neighbouring
    correlation times), which makes :math:`\sum 4 s^2 T_c/(1 + (2\pi f T_c)^2) = B^2/(\pi f)`
    between them; the fast ones and a white part are fitted (non-negative least squares,
    relative error) to the rest of the sampled PSD over the top four decades of frequency.
    """
    ratio = 10.0 ** (1.0 / PER_DECADE)
    tcs = 0.25 * ratio ** np.arange(decades * PER_DECADE + 1)
    slow = tcs > FITTED_TC
    weights = np.zeros(tcs.size + 1)
    weights[:-1][slow] = math.log(ratio) / math.pi
    u = np.logspace(-4.0, math.log10(0.5), 1500)
    target = flicker_psd_sampled(u, 1.0, 1.0, cutoff)  # B = 1, dt = 1: u = f dt
    keep = target > 0
    u, target = u[keep], target[keep]
    analytic = sum(
        (w * _ar1_psd(u, tc) for tc, w in zip(tcs, weights[:-1], strict=False) if w),
        np.zeros_like(u),
    )
    columns = [_ar1_psd(u, tc) for tc in tcs[~slow]] + [np.full_like(u, 2.0)]
    fitted, _ = nnls(
        np.array(columns).T / target[:, None],
        np.clip(1.0 - analytic / target, 0.0, None),
        maxiter=100 * len(columns),
    )
    weights[:-1][~slow] = fitted[:-1]
    weights[-1] = fitted[-1]
    return tcs, weights


def flicker_bank(
    B: float, dt: float, *, cutoff_hz: float | None = None, n_samples: int | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Gauss-Markov bank plus white noise fitted to flicker ``B`` at period ``dt``.

    The Gauss-Markov reading of a flicker term for the error laws of :mod:`allanite.impact`
    (-3.9% in Allan variance at ``tau = dt``); simulation uses :class:`FlickerStream`.

    Returns
    -------
    tuple
        Correlation times (s), standard deviations of the AR(1) components, and the white
        part's ``N`` (rate sqrt(s)).
    """
    n = DEFAULT_BANK_SAMPLES if n_samples is None else max(int(n_samples), 10)
    decades = math.ceil(math.log10(n)) + 1
    cutoff = 0.5 if cutoff_hz is None else min(0.5, cutoff_hz * dt)
    tcs, weights = _unit_bank(decades, round(cutoff, 12))
    keep = weights[:-1] > 0
    sigma = np.sqrt(weights[:-1][keep]) * B
    white_n = math.sqrt(weights[-1]) * B * math.sqrt(dt)  # per-sample sd = N / sqrt(dt)
    return tcs[keep] * dt, sigma, white_n


@dataclass(frozen=True)
class FlickerDesign:
    """The streaming flicker generator for ``B = 1`` and ``dt = 1`` (scale by B and dt).

    Attributes
    ----------
    tcs : numpy.ndarray
        Correlation times of the AR(1) components, in samples.
    variance : float
        Variance of each AR(1) component (the same for all, ``ln r / pi``).
    walk : float
        Variance of the random walk's increment per sample.
    taps : numpy.ndarray
        FIR taps of the residual filter (zero-phase, centred), driven by unit white noise.
    lowpass : numpy.ndarray or None
        With a cutoff below Nyquist: zero-phase FIR low-pass applied to the bank's output
        (pass band up to ``0.9 f0``, raised-cosine edge, Kaiser window), so that the bank's
        tails above ``f0`` are gone and the residual can take the band edge; None otherwise.
    grid : int
        Frequency lines (over ``[0, 1/dt)``) of the design; 8 per residual tap at least.
    clipped : float
        Power of the negative residual PSD clipped to zero, as a share of the target's power on
        the design grid: 0 when the (low-passed) bank stays below the target everywhere, as
        it does without a cutoff ``f0``; below 1e-9 with one (the low-pass's stop band).
    """

    tcs: NDArray[np.float64]
    variance: float
    walk: float
    taps: NDArray[np.float64]
    clipped: float
    lowpass: NDArray[np.float64] | None = None
    grid: int = STREAM_DESIGN_GRID

    def bank_psd(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """One-sided sampled PSD (dt = 1) of the AR(1) components and the walk at u = f dt."""
        return _bank_psd(u, self.tcs, self.variance, self.walk)

    def lowpass_gain(self, grid: int) -> NDArray[np.float64]:
        """``|G(k/grid)|^2`` of the low-pass for ``k = 0 .. grid/2`` (ones without one)."""
        if self.lowpass is None:
            return np.ones(grid // 2 + 1)
        response = np.fft.rfft(self.lowpass, grid)
        return np.asarray(response.real**2 + response.imag**2)


def _bank_psd(
    u: NDArray[np.float64], tcs: NDArray[np.float64], variance: float, walk: float
) -> NDArray[np.float64]:
    """One-sided sampled PSD (dt = 1) of the AR(1) components and the walk at u = f dt."""
    total = walk / (2.0 * np.sin(np.pi * u) ** 2)
    for tc in tcs:
        total = total + variance * _ar1_psd(u, float(tc))
    return total


@functools.lru_cache(maxsize=16)
def _unit_design(n_components: int, cutoff: float) -> FlickerDesign:
    ratio = 10.0 ** (1.0 / STREAM_PER_DECADE)
    variance = math.log(ratio) / math.pi
    tcs = STREAM_FASTEST_TC * ratio ** np.arange(n_components)
    # the slower components' PSD sum_j s^2 / (pi^2 f^2 T_j) is a random walk's K^2/(2 pi^2 f^2)
    walk = 2.0 * variance / (tcs[-1] * (ratio - 1.0))
    # below Nyquist the residual holds the band edge: more taps, as many more as 0.5 / cutoff
    n_taps = min(STREAM_FIR_TAPS << max(0, math.ceil(math.log2(0.5 / cutoff))), 1 << 18)
    grid = max(STREAM_DESIGN_GRID, 8 * n_taps)
    u = np.arange(1, grid // 2 + 1) / grid
    target = flicker_psd_sampled(u, 1.0, 1.0, cutoff)  # B = 1, dt = 1: u = f dt
    lowpass = None if cutoff >= 0.5 else _lowpass(cutoff)
    design = FlickerDesign(tcs, variance, walk, np.zeros(1), 0.0, lowpass, grid)
    residual = target - design.lowpass_gain(grid)[1:] * design.bank_psd(u)
    clipped = float(np.sum(np.clip(-residual, 0.0, None)) / np.sum(target))
    amplitude = np.sqrt(np.clip(residual, 0.0, None) / 2.0)
    # the zero-frequency line: the residual's limit there (it is smooth, ~0.94 T0)
    amplitude = np.concatenate((amplitude[:1], amplitude))
    response = np.fft.irfft(amplitude, grid)
    half = n_taps // 2
    taps = np.concatenate((response[-half:], response[:half]))
    return FlickerDesign(tcs, variance, walk, taps, clipped, lowpass, grid)


def _lowpass(cutoff: float) -> NDArray[np.float64]:
    """Zero-phase low-pass: ``|G|^2`` = 1 up to ``0.9 cutoff``, raised cosine to 0 at cutoff."""
    width = 0.1 * cutoff
    n_taps = min(max(4096, 1 << math.ceil(math.log2(64.0 / width))), 1 << 16)
    lines = 8 * n_taps
    u = np.arange(lines // 2 + 1) / lines
    edge = np.clip((u - (cutoff - width)) / width, 0.0, 1.0)
    response = np.fft.irfft(np.cos(0.5 * np.pi * edge), lines)
    half = n_taps // 2
    return np.concatenate((response[-half:], response[:half])) * np.kaiser(n_taps, 14.0)


def flicker_design(n_samples: int | None = None, cutoff: float = 0.5) -> FlickerDesign:
    """Design the streaming generator (``B = 1``, ``dt = 1``) for a record of ``n_samples``.

    Parameters
    ----------
    n_samples : int, optional
        Record length (default :data:`DEFAULT_BANK_SAMPLES`); the slowest AR(1) component is
        at least :data:`STREAM_SLOWEST_RECORDS` times longer.
    cutoff : float
        Cutoff ``f0 dt`` of the term (at most 1/2, the Nyquist frequency).
    """
    n = DEFAULT_BANK_SAMPLES if n_samples is None else max(int(n_samples), 10)
    ratio = 10.0 ** (1.0 / STREAM_PER_DECADE)
    slowest = STREAM_SLOWEST_RECORDS * n / STREAM_FASTEST_TC
    n_components = max(1, math.ceil(math.log(slowest) / math.log(ratio)) + 1)
    return _unit_design(n_components, round(min(cutoff, 0.5), 12))


def _child(seed: Any, index: int) -> np.random.SeedSequence:
    """The ``index``-th child of ``seed`` without mutating it (as ``spawn`` would make it)."""
    parent = seed_sequence(seed)
    return np.random.SeedSequence(parent.entropy, spawn_key=(*parent.spawn_key, index))


class FirStream(TermStream):
    """Unit white noise (or a ``source`` stream) through the FIR filter ``taps``.

    Output ``y_k = sum_i taps_i w_{k-i}``, by overlap-save with a fixed FFT length
    (:data:`STREAM_FFT`), so the samples depend on the seed alone; it holds the last
    ``len(taps) - 1`` inputs per channel, drawn up front (stationary from the first sample).
    """

    def __init__(
        self,
        taps: NDArray[np.float64],
        fs: float,
        n_channels: int,
        seed: Any = None,
        *,
        source: TermStream | None = None,
    ) -> None:
        super().__init__(fs, n_channels, seed)
        self.source = source
        self.taps = np.asarray(taps, dtype=np.float64)
        self.n_fft = max(STREAM_FFT, 1 << math.ceil(math.log2(4 * self.taps.size)))
        self.step = self.n_fft - self.taps.size + 1
        self._kernel = np.fft.rfft(self.taps, self.n_fft)[:, None]
        self._inputs = self._draw(self.taps.size - 1)
        self._pending = np.empty((0, self.n_channels))

    def _draw(self, n: int) -> NDArray[np.float64]:
        if self.source is not None:
            return self.source.next(n)
        return self.rng.standard_normal((n, self.n_channels))

    def _filter(self) -> NDArray[np.float64]:
        x = np.concatenate((self._inputs, self._draw(self.step)))
        spectrum = np.fft.rfft(x, axis=0) * self._kernel
        y = np.fft.irfft(spectrum, self.n_fft, axis=0)[self.taps.size - 1 :]
        self._inputs = x[self.step :]
        return y

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        parts = [self._pending]
        have = self._pending.shape[0]
        while have < n:
            parts.append(self._filter())
            have += parts[-1].shape[0]
        pending = np.concatenate(parts) if len(parts) > 1 else self._pending
        self._pending = pending[n:]
        return pending[:n]


class FlickerStream(TermStream):
    """Streaming flicker noise for records of any length (see the module docstring).

    The AR(1) bank with its random walk and the FIR residual have their own generators,
    children 0 and 1 of ``seed``.

    Parameters
    ----------
    B : float
        Flicker coefficient (rate).
    design : FlickerDesign
        From :func:`flicker_design`.
    fs, n_channels, seed
        See :class:`~allanite.simulation.streams.TermStream`.
    """

    def __init__(
        self, B: float, design: FlickerDesign, fs: float, n_channels: int, seed: Any = None
    ) -> None:
        super().__init__(fs, n_channels, seed)
        self.design = design
        theta = 1.0 / design.tcs
        phi = np.append(np.exp(-theta), 1.0)
        sd = B * math.sqrt(design.variance)
        q = np.append(
            sd * np.sqrt(-np.expm1(-theta) * (1.0 + phi[:-1])), B * math.sqrt(design.walk)
        )
        initial = np.append(np.full(design.tcs.size, sd), 0.0)
        self.bank: TermStream = Ar1BankStream(
            phi, q, phi, 1.0, fs=fs, n_channels=n_channels, seed=_child(seed, 0),
            initial_sd=initial,
        )  # fmt: skip
        if design.lowpass is not None:
            self.bank = FirStream(design.lowpass, fs, n_channels, source=self.bank)
        self.fir = FirStream(B * design.taps, fs, n_channels, _child(seed, 1))

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        return self.bank.next(n) + self.fir.next(n)


def flicker_stream(
    term: Any,
    fs: float,
    n_channels: int,
    seed: Any = None,
    *,
    n_samples: int | None = None,
    method: str = "auto",
) -> TermStream:
    """Stream of flicker rate noise for a :class:`allanite.terms.Flicker` term.

    Parameters
    ----------
    term : Flicker
        The term (``B`` and optional cutoff ``f0``).
    fs, n_channels, seed
        See :class:`~allanite.simulation.streams.TermStream`.
    n_samples : int, optional
        Record length, if known (needed by the spectral method).
    method : {"auto", "spectral", "kasdin", "bank"}
        ``auto`` = spectral when ``n_samples`` is known, at most
        :data:`SPECTRAL_MAX_SAMPLES` and ``n_samples * n_channels`` at most
        :data:`SPECTRAL_MAX_VALUES`, else the streaming bank + FIR generator
        (:class:`FlickerStream`, the term's Allan variance to 2e-6, any length);
        ``bank`` forces it. ``kasdin`` = Kasdin's
        fractional filter (needs ``n_samples``; no cutoff ``f0``).

    Raises
    ------
    ValueError
        For an unknown method, ``f0`` above Nyquist, or a method that cannot serve the record
        (spectral or kasdin without ``n_samples``, kasdin with ``f0`` or too long a record).
    """
    if method not in FLICKER_METHODS:
        raise ValueError(
            f"unknown flicker method {method!r}; use one of {', '.join(map(repr, FLICKER_METHODS))}"
        )
    dt = 1.0 / fs
    if term.f0 is not None and term.f0 > 0.5 * fs:
        raise ValueError(
            f"flicker cutoff f0 = {term.f0} Hz lies above the Nyquist frequency {0.5 * fs} Hz; "
            "its aliased part is not simulated: omit f0 (cutoff at Nyquist) or set f0 <= fs/2"
        )
    if method == "kasdin":
        if n_samples is None:
            raise ValueError(
                "the kasdin flicker method needs the record length n_samples (it filters the "
                "whole record at once); give it, or use flicker method 'bank' to stream"
            )
        if term.f0 is not None:
            raise ValueError(
                f"the kasdin flicker filter has no cutoff but the term sets f0 = {term.f0} Hz; "
                "use flicker method 'spectral' or 'bank', or drop f0"
            )
        return KasdinStream(term.B, n_samples, fs, n_channels, seed)
    spectral = method == "spectral" or (
        method == "auto"
        and n_samples is not None
        and n_samples <= SPECTRAL_MAX_SAMPLES
        and n_samples * n_channels <= SPECTRAL_MAX_VALUES
    )
    if spectral:
        if n_samples is None:
            raise ValueError("the spectral flicker method needs the record length n_samples")
        return SpectralStream(lambda f: term.psd_sampled(f, dt), n_samples, fs, n_channels, seed)
    design = flicker_design(n_samples, 0.5 if term.f0 is None else term.f0 * dt)
    return FlickerStream(term.B, design, fs, n_channels, seed)
