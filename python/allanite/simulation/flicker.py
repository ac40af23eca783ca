r"""Flicker (1/f) rate noise: spectral synthesis, Kasdin's filter, or a streaming bank.

* Records up to :data:`SPECTRAL_MAX_SAMPLES` samples (and :data:`SPECTRAL_MAX_VALUES` values
  over all channels): :class:`~allanite.simulation.spectral.
  SpectralStream` with the term's exact sampled PSD :math:`B^2/(\pi f)\,\mathrm{sinc}^2(f
  \Delta t)` (interval averages of band-limited 1/f noise), so the samples have the exact
  Allan variance of :class:`allanite.terms.Flicker` down to :math:`\tau = \Delta t`.
* Longer records (or ``method="bank"``): a sum of point-sampled AR(1) processes with
  log-spaced correlation times (three per decade from :math:`\Delta t/4` to beyond the record
  length) plus a white part, run in the C++ core in bounded memory. The variances are fitted
  (non-negative least squares, relative error on a log-frequency grid) to the sampled PSD.
  Its exact Allan variance (:func:`allanite.terms.flicker_laws.bank_avar`) holds the flicker
  plateau :math:`0.664 B` within about 0.5% from :math:`\tau \approx 30\Delta t` up to about
  a tenth of the longest correlation time, but it is not the band-limited flicker shape at the
  first few lags (about -30% at :math:`\tau = \Delta t`).
* ``method="kasdin"`` (on request only, records of known length up to
  :data:`~allanite.simulation.kasdin.KASDIN_MAX_SAMPLES`): Kasdin's fractional-difference
  filter of white noise, :class:`~allanite.simulation.kasdin.KasdinStream`; its own exact
  Allan variance is :func:`~allanite.terms.flicker_laws.kasdin_avar` (+70% over the term at
  :math:`\tau = \Delta t`, the 0.664 B plateau from about :math:`100\Delta t` on).

References
----------
J. A. Barnes, D. W. Allan, "A statistical model of flicker noise", Proc. IEEE 54 (1966);
sum-of-relaxation-processes approximation of 1/f noise.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import nnls

from allanite.simulation.gaussian import Ar1BankStream
from allanite.simulation.kasdin import KasdinStream
from allanite.simulation.spectral import SpectralStream
from allanite.simulation.streams import TermStream

__all__ = [
    "FLICKER_METHODS",
    "SPECTRAL_MAX_SAMPLES",
    "flicker_bank",
    "flicker_stream",
]

#: ways to simulate flicker (see :func:`flicker_stream`)
FLICKER_METHODS: tuple[str, ...] = ("auto", "spectral", "kasdin", "bank")
#: longest record synthesised spectrally in one piece (longer ones use the streaming bank);
#: one channel's synthesis needs about 24 x 4 x 8 bytes per sample transiently (200 MB here)
SPECTRAL_MAX_SAMPLES = 1 << 21
#: and at most this many values (samples x channels) held for all channels (128 MB)
SPECTRAL_MAX_VALUES = 1 << 24
#: Gauss-Markov components per decade of correlation time in the streaming bank
PER_DECADE = 3
#: components up to this correlation time (in samples) are fitted, slower ones analytic
FITTED_TC = 300.0
#: record length assumed by the streaming bank when the caller does not say
DEFAULT_BANK_SAMPLES = 10**9


def _unit_psd(u: NDArray[np.float64], cutoff: float) -> NDArray[np.float64]:
    """Return the sampled flicker PSD for B = 1, dt = 1 at u = f dt (<= 1/2)."""
    return np.where(u <= cutoff, np.sinc(u) ** 2 / (np.pi * u), 0.0)


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
    target = _unit_psd(u, cutoff)
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
    """Design the streaming bank for flicker ``B`` at period ``dt``.

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
        :data:`SPECTRAL_MAX_VALUES`, else the streaming bank. ``kasdin`` = Kasdin's
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
    tcs, sigma, white_n = flicker_bank(term.B, dt, cutoff_hz=term.f0, n_samples=n_samples)
    theta = dt / tcs
    phi = np.exp(-theta)
    q = sigma * np.sqrt(-np.expm1(-theta) * (1.0 + phi))
    return Ar1BankStream(
        phi,
        q,
        phi,
        1.0,
        g=white_n / math.sqrt(dt),
        fs=fs,
        n_channels=n_channels,
        seed=seed,
        initial_sd=sigma,
    )
