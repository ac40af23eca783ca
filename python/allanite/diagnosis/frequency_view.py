r"""The frequency view: the real/sim PSD ratio, its confidence band, and spectral lines.

Feature: the log Welch PSD (Hann window, 50 % overlap, ``nperseg = min(4096, 2^floor(log2
(N/16)))``, so at least about 31 averaged segments) at every bin above DC. The residual
``r(f) = log P_real(f) - log P_sim(f)`` is the log PSD ratio; its per-bin band comes from the
quantiles of the null residuals of the Monte Carlo replicates (for a Welch estimate with ``nu``
degrees of freedom the ratio follows an F law; the Monte Carlo band needs no ``nu``).

Spectral lines (vibration, mains pickup, stand oscillation) are narrow: the line contrast

.. math:: c(f) = r(f) - \operatorname{median}_{|g - f| \le 8\,\Delta f}\; r(g)

removes any broadband excess, and a line is a local maximum of ``c`` above the ``1 - alpha``
quantile of ``max_f c(f)`` under the null (Gumbel fit). Its frequency is refined on the
Hann-windowed periodogram of the whole record (parabolic interpolation of the log magnitude),
far finer than the 2 % the diagnosis promises. A line above the Nyquist frequency ``fs/2``
appears at its alias ``|f - k fs|``; every line reports the frequencies it may alias from.

Broadband departures are tested in log-spaced bands (four per decade): the band means of ``r``
are normalised by their null spread and flagged with a simultaneous threshold.

References
----------
P. D. Welch, "The use of fast Fourier transform for the estimation of power spectra", IEEE
Trans. Audio Electroacoust. 15 (1967) 70-73. D. B. Percival, A. T. Walden, *Spectral Analysis
for Physical Applications* (1993), ch. 6 (periodogram and line detection).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage, signal

from allanite.diagnosis.null import NullEnsemble, gumbel_isf, gumbel_sf, runs

__all__ = ["FrequencyView", "SpectralLine", "frequency_features", "frequency_view", "welch_size"]

#: half-width (bins) of the running median that defines the local continuum of a line
LINE_HALF_WIDTH = 8
#: bands per decade of the broadband test
BANDS_PER_DECADE = 4
#: at most this many lines are reported
MAX_LINES = 10


def welch_size(n: int) -> int:
    """Welch segment length for a record of ``n`` samples."""
    return int(min(4096, 2 ** int(np.floor(np.log2(max(n / 16, 16))))))


def frequency_features(
    x: NDArray[np.float64], fs: float, nperseg: int
) -> dict[str, NDArray[np.float64]]:
    """Log Welch PSD and log segment-normalised PSD of a rate record at every bin above DC.

    ``log_psd`` is the Welch estimate (Hann window, 50 % overlap, per-segment mean removed,
    the average of the segment periodograms ``P_i``). ``log_line_psd`` averages
    ``P_i / median_f P_i`` instead: every segment counts with the same broadband level, so a
    noise level that changes over the record (bursts) does not lower the effective degrees of
    freedom of the average (which raises the scatter of the line contrast and makes spurious
    lines), while a line present throughout the record keeps its contrast. The segments are
    processed in blocks, so memory stays at a few blocks of ``nperseg`` samples.
    """
    step = nperseg // 2
    n_seg = (x.size - nperseg) // step + 1
    win = signal.get_window("hann", nperseg)
    scale = 1.0 / (fs * float(np.sum(win * win)))
    frames = np.lib.stride_tricks.sliding_window_view(x, nperseg)[::step][:n_seg]
    total = np.zeros(nperseg // 2)
    total_norm = np.zeros(nperseg // 2)
    for a in range(0, n_seg, 256):
        seg = frames[a : a + 256]
        seg = (seg - seg.mean(axis=1, keepdims=True)) * win
        p = np.abs(np.fft.rfft(seg, axis=1)[:, 1:]) ** 2 * scale
        p[:, :-1] *= 2.0  # one-sided; the Nyquist bin (nperseg even) is not doubled
        total += p.sum(axis=0)
        level = np.median(p, axis=1, keepdims=True)
        total_norm += (p / np.where(level > 0, level, 1.0)).sum(axis=0)
    return {
        "log_psd": np.asarray(np.log(np.maximum(total / n_seg, 1e-300)), dtype=np.float64),
        "log_line_psd": np.asarray(
            np.log(np.maximum(total_norm / n_seg, 1e-300)), dtype=np.float64
        ),
    }


def _contrast(r: NDArray[np.float64]) -> NDArray[np.float64]:
    size = (1,) * (r.ndim - 1) + (2 * LINE_HALF_WIDTH + 1,)
    return np.asarray(r - ndimage.median_filter(r, size=size, mode="nearest"))


@dataclass(frozen=True)
class SpectralLine:
    """A detected spectral line.

    Attributes
    ----------
    frequency_hz : float
        Apparent frequency in ``(0, fs/2]``, refined on the full-record periodogram.
    amplitude : float
        Estimated sine amplitude in rate units (``4 |X(f)| / N`` for the Hann window).
    contrast : float
        Line contrast ``c`` (log power ratio above the local continuum).
    p_value : float
        Probability that the null produces a contrast this high anywhere in the spectrum.
    aliases_hz : list of float
        Frequencies above Nyquist that alias to this line: ``k fs - f`` and ``k fs + f``,
        ``k = 1, 2``.
    """

    frequency_hz: float
    amplitude: float
    contrast: float
    p_value: float
    aliases_hz: list[float]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "frequency_hz": self.frequency_hz,
            "amplitude": self.amplitude,
            "contrast": self.contrast,
            "p_value": self.p_value,
            "aliases_hz": self.aliases_hz,
        }


@dataclass(frozen=True)
class FrequencyView:
    """Result of the frequency view (plotting-ready arrays).

    Attributes
    ----------
    f : numpy.ndarray
        Frequencies of the Welch bins in Hz (DC excluded).
    real_psd, sim_psd : numpy.ndarray
        One-sided PSDs in rate^2/Hz.
    ratio, ratio_low, ratio_high : numpy.ndarray
        PSD ratio real/sim and its per-bin ``1 - alpha`` band under the null.
    lines : list of SpectralLine
        Detected lines, strongest first.
    line_threshold : float
        Contrast threshold of the line detector.
    line_p_value : float
        p-value of the largest contrast.
    band_edges_hz : numpy.ndarray
        Edges of the broadband test bands.
    band_z : numpy.ndarray
        Normalised band-mean log ratios.
    band_threshold : float
        Simultaneous threshold on ``|band_z|``.
    band_p_value : float
        p-value of ``max |band_z|``.
    bands_hz : list of (float, float)
        Frequency ranges with a significant broadband departure.
    line_residual, line_null_max : numpy.ndarray
        The line detector's log ratio (segment-normalised spectrum) and the null's maximum
        contrasts, for :meth:`lines_beyond`.
    """

    f: NDArray[np.float64]
    real_psd: NDArray[np.float64]
    sim_psd: NDArray[np.float64]
    ratio: NDArray[np.float64]
    ratio_low: NDArray[np.float64]
    ratio_high: NDArray[np.float64]
    lines: list[SpectralLine]
    line_threshold: float
    line_p_value: float
    band_edges_hz: NDArray[np.float64]
    band_z: NDArray[np.float64]
    band_threshold: float
    band_p_value: float
    bands_hz: list[tuple[float, float]]
    band_sd: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)
    band_null_max: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)
    line_residual: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)
    line_null_max: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)

    def lines_beyond(self, extra_psd: NDArray[np.float64]) -> FrequencyView:
        """The view whose lines stand out once a smooth excess ``extra_psd`` is expected.

        A narrow resonance (Q ~ 15 or more) is narrower than the line contrast's running
        median (``2 LINE_HALF_WIDTH + 1`` bins) on a short record: its own peak has a contrast
        near the line threshold, and noise on it crosses it. With the resonance's one-sided
        PSD ``extra_psd`` (on :attr:`f`) added to the simulated sensor the contrast is
        ``c'(f) = contrast(r(f) - log(1 + extra_psd / sim_psd))``; a line is kept when ``c'``
        within a bin of it still exceeds :attr:`line_threshold` (a sinusoid inside the band
        does: its power sits in one or two bins), and :attr:`line_p_value` becomes that of
        ``max c'``. Without the detector's arrays the view is returned as it is.
        """
        if self.line_residual.size != self.f.size or self.line_null_max.size == 0:
            return self
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.log1p(np.clip(extra_psd, 0.0, None) / self.sim_psd)
        g = np.where(np.isfinite(g), g, 0.0)
        c = _contrast(self.line_residual - g)
        df = float(self.f[1] - self.f[0]) if self.f.size > 1 else 1.0
        kept = []
        for line in self.lines:
            near = np.abs(self.f - line.frequency_hz) <= 1.5 * df
            if not near.any() or float(c[near].max()) > self.line_threshold:
                kept.append(line)
        return replace(self, lines=kept, line_p_value=gumbel_sf(float(c.max()), self.line_null_max))

    def band_test(
        self, extra_psd: NDArray[np.float64]
    ) -> tuple[float, list[tuple[float, float]], NDArray[np.float64]]:
        """Broadband test after adding an effect of one-sided PSD ``extra_psd`` (on ``f``).

        The simulated PSD becomes ``sim_psd + extra_psd``, so the per-bin log ratio drops by
        ``log(1 + extra_psd / sim_psd)``; the band means are normalised by the same null
        spreads and judged against the same null maxima as before.

        Returns
        -------
        p_value : float
            p-value of ``max |band_z|`` after the effect.
        bands_hz : list of (float, float)
            Bands still above the simultaneous threshold.
        band_z : numpy.ndarray
            Normalised band means after the effect.
        """
        fs = 2.0 * float(self.f[-1])
        edges, groups = _band_index(self.f, fs)
        shift = np.log(np.maximum(1.0 + np.asarray(extra_psd) / self.sim_psd, 1e-12))
        r = np.log(self.ratio) - shift
        z = np.array([r[g].mean() for g in groups]) / self.band_sd
        p = gumbel_sf(float(np.abs(z).max()), self.band_null_max)
        bands = [
            (float(edges[a]), float(edges[b + 1])) for a, b in runs(np.abs(z) > self.band_threshold)
        ]
        return p, bands, np.asarray(z, dtype=np.float64)

    def shape_misfit(self, extra_psd: NDArray[np.float64]) -> float:
        r"""Misfit of the spectrum's shape after adding an effect of one-sided PSD ``extra_psd``.

        The band means of the log ratio ``r(f) - log(1 + extra(f) / sim(f))`` over the
        broadband test bands, each normalised by its null spread, summed in squares:

        .. math:: F = \sum_b z_b^2, \qquad z_b = \frac{\overline{r_b}}{s_b},

        which is ``chi2`` with as many degrees of freedom as bands when the effect is right
        (nearly independent bands of nearly Gaussian means). Bins within ``LINE_HALF_WIDTH``
        of a detected line are left out (lines are the line detector's business; a sinusoid has
        no PSD), and the spread of a band that loses bins grows as ``sqrt(n / n_kept)``. ``F``
        compares look-alikes that the tau view cannot tell apart: a Gauss-Markov knee (a flat
        spectrum below ``1 / (2 pi tau_c)``) against a ``1/f`` line, a random walk's ``1/f^2``
        against a flicker's ``1/f``.
        """
        fs = 2.0 * float(self.f[-1])
        _, groups = _band_index(self.f, fs)
        if len(groups) != self.band_sd.size:
            raise ValueError("the frequency view has no band spreads; run frequency_view first")
        keep = np.ones(self.f.size, dtype=bool)
        df = float(self.f[1] - self.f[0]) if self.f.size > 1 else 1.0
        for line in self.lines:
            keep &= np.abs(self.f - line.frequency_hz) > LINE_HALF_WIDTH * df
        shift = np.log(np.maximum(1.0 + np.asarray(extra_psd) / self.sim_psd, 1e-12))
        r = np.log(self.ratio) - shift
        total = 0.0
        for g, sd in zip(groups, self.band_sd, strict=True):
            kept = g[keep[g]]
            if kept.size == 0:
                continue
            total += (float(r[kept].mean()) / (sd * np.sqrt(g.size / kept.size))) ** 2
        return total

    @property
    def p_value(self) -> float:
        """Bonferroni combination of the line and broadband tests."""
        return min(1.0, 2.0 * min(self.line_p_value, self.band_p_value))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "f_hz": self.f.tolist(),
            "real_psd": self.real_psd.tolist(),
            "sim_psd": self.sim_psd.tolist(),
            "ratio": self.ratio.tolist(),
            "ratio_low": self.ratio_low.tolist(),
            "ratio_high": self.ratio_high.tolist(),
            "lines": [line.to_dict() for line in self.lines],
            "line_threshold": self.line_threshold,
            "line_p_value": self.line_p_value,
            "band_edges_hz": self.band_edges_hz.tolist(),
            "band_z": self.band_z.tolist(),
            "band_threshold": self.band_threshold,
            "band_p_value": self.band_p_value,
            "bands_hz": [list(b) for b in self.bands_hz],
            "p_value": self.p_value,
        }


def _band_index(
    f: NDArray[np.float64], fs: float
) -> tuple[NDArray[np.float64], list[NDArray[Any]]]:
    lo, hi = np.log10(f[0]), np.log10(fs / 2.0)
    n_bands = max(int(np.ceil((hi - lo) * BANDS_PER_DECADE)), 1)
    edges = np.logspace(lo, hi, n_bands + 1)
    edges[-1] *= 1.0 + 1e-12
    groups = []
    kept = [edges[0]]
    current: list[int] = []
    for i in range(n_bands):
        idx = np.flatnonzero((f >= edges[i]) & (f < edges[i + 1]))
        current.extend(idx.tolist())
        if len(current) >= 2:
            groups.append(np.array(current))
            kept.append(edges[i + 1])
            current = []
    if current and groups:
        groups[-1] = np.concatenate([groups[-1], current])
        kept[-1] = edges[-1]
    return np.asarray(kept), groups


def _refine(x: NDArray[np.float64], fs: float, f0: float, df: float) -> tuple[float, float]:
    """Frequency and amplitude of the strongest peak of the full periodogram near ``f0``."""
    n = x.size
    nfft = 1 << int(np.ceil(np.log2(2 * n)))
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(n), nfft))
    freqs = np.fft.rfftfreq(nfft, 1.0 / fs)
    sel = np.flatnonzero((freqs >= f0 - 2 * df) & (freqs <= f0 + 2 * df))
    if sel.size == 0:
        return f0, 0.0
    k = int(sel[np.argmax(spec[sel])])
    if 0 < k < spec.size - 1:
        a, b, c = np.log(spec[k - 1 : k + 2] + 1e-300)
        den = a - 2 * b + c
        delta = 0.5 * (a - c) / den if den != 0 else 0.0
    else:
        delta = 0.0
    freq = float(freqs[k] + delta * (freqs[1] - freqs[0]))
    return freq, float(4.0 * spec[k] / n)


def frequency_view(
    x: NDArray[np.float64],
    fs: float,
    real: dict[str, NDArray[np.float64]],
    ens: NullEnsemble,
    nperseg: int,
    alpha: float,
) -> FrequencyView:
    """Ratio, band, lines and broadband test of the frequency view."""
    f = np.asarray(np.fft.rfftfreq(nperseg, 1.0 / fs)[1:], dtype=np.float64)
    df = fs / nperseg
    null = ens.null["log_psd"]
    r = ens.residual(real, "log_psd")
    lo_q, hi_q = np.quantile(null, [alpha / 2, 1 - alpha / 2], axis=0)
    alpha = alpha / 2.0  # two tests (lines, broadband) share the view's level
    # lines, on the segment-normalised spectrum (robust to a noise level changing in time)
    r_line = ens.residual(real, "log_line_psd")
    c = _contrast(r_line)
    c_null = _contrast(ens.null["log_line_psd"])
    cmax_null = c_null.max(axis=1)
    thr = gumbel_isf(alpha, cmax_null)
    lines: list[SpectralLine] = []
    peaks, _ = signal.find_peaks(c, height=thr, distance=4)
    for k in peaks[np.argsort(c[peaks])[::-1]][:MAX_LINES]:
        freq, amp = _refine(x, fs, float(f[k]), df)
        aliases = sorted({q * fs + s * freq for q in (1, 2) for s in (-1, 1)})
        lines.append(
            SpectralLine(
                frequency_hz=freq,
                amplitude=amp,
                contrast=float(c[k]),
                p_value=gumbel_sf(float(c[k]), cmax_null),
                aliases_hz=[float(a) for a in aliases],
            )
        )
    # broadband
    edges, groups = _band_index(f, fs)
    band_r = np.array([r[g].mean() for g in groups])
    band_null = np.stack([null[:, g].mean(axis=1) for g in groups], axis=1)
    band_sd = band_null.std(axis=0, ddof=1)
    band_z = band_r / band_sd
    zmax_null = np.abs(band_null / band_sd).max(axis=1)
    band_thr = gumbel_isf(alpha, zmax_null)
    bands = [(float(edges[a]), float(edges[b + 1])) for a, b in runs(np.abs(band_z) > band_thr)]
    ref_psd = np.exp(ens.ref["log_psd"])
    return FrequencyView(
        f=f,
        real_psd=np.exp(real["log_psd"]),
        sim_psd=ref_psd,
        ratio=np.exp(r),
        ratio_low=np.exp(lo_q),
        ratio_high=np.exp(hi_q),
        lines=lines,
        line_threshold=thr,
        line_p_value=gumbel_sf(float(c.max()), cmax_null),
        band_edges_hz=edges,
        band_z=band_z,
        band_threshold=band_thr,
        band_p_value=gumbel_sf(float(np.abs(band_z).max()), zmax_null),
        bands_hz=bands,
        band_sd=band_sd,
        band_null_max=zmax_null,
        line_residual=np.asarray(r_line, dtype=np.float64),
        line_null_max=cmax_null,
    )
