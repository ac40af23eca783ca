r"""Band excesses of the frequency view that are not lines: a resonance or a drifting line.

A significant broadband excess (the frequency view's band test) whose excess PSD
``P_real - P_sim`` rises to an interior peak and falls below half of it on *both* sides is a
band-pass shape; a monotone excess (more white noise, more flicker) or a flat one (bursts) is
not. Two effects make such a shape, and the time view tells them apart:

* **drifting line** -- in a spectrogram of the record (:data:`N_SEGMENTS` segments) the peak
  inside the band moves linearly with time: at least :data:`INLIER_SHARE` of the segments'
  peak frequencies lie within :data:`INLIER_BINS` bins of a robust (Theil-Sen) line, the
  least-squares line through those explains most of their scatter (``R^2 >= 0.8``) and
  moves by more than :data:`MIN_BINS` spectrogram bins over the record. ``f_start`` and
  ``f_end`` are that line at the start and end of the record, the amplitude comes from the
  band's excess power (``A^2 / 2``);
* **resonance** -- otherwise: a second-order band-pass (:class:`~allanite.terms.Resonance`)
  whose frequency, damping and level are fitted by least squares to the log PSD of the
  simulated sensor plus a flat local continuum plus the resonance against the real log PSD
  around the band (started from the peak, the half-power width ``2 zeta f0`` and ``N =
  sqrt(peak / 2)``); the continuum (e.g. more white noise) is left to the other candidates.
  The peak must earn its three parameters: an F test of the fit against the flat continuum
  alone at level :data:`PEAK_ALPHA` (a flat excess such as bursts has no resonance).

The candidates then fit only their amplitude on the tau view, like the sinusoid of a
detected line.

A record can hold two resonances (a gyro's own and one of its mount): :func:`band_shapes`
looks for a further resonance among the significant bands outside the first's band (its
half-power band widened by its width on each side), against the simulated sensor *plus* the
resonances found so far, under the same shape and F test; at most :data:`MAX_BANDS`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage, optimize, signal, stats

from allanite.diagnosis.frequency_view import FrequencyView
from allanite.terms import Resonance

__all__ = ["MAX_BANDS", "MIN_BINS", "N_SEGMENTS", "PEAK_ALPHA", "BandShape", "band_shape",
           "band_shapes"]  # fmt: skip

#: spectrogram segments of the drifting-line test
N_SEGMENTS = 16
#: a drifting line moves by more than this many spectrogram bins over the record
MIN_BINS = 3.0
#: segments whose peak lies within this many spectrogram bins of the robust line are on it
INLIER_BINS = 2.0
#: a drifting line: at least this share of the segments on the line
INLIER_SHARE = 0.75
#: level of the F test of a resonance peak against a flat excess on the log PSD
PEAK_ALPHA = 1e-3
#: at most this many band-pass excesses (resonances) per record
MAX_BANDS = 2


@dataclass(frozen=True)
class BandShape:
    """A band-pass shaped excess and what made it.

    Attributes
    ----------
    kind : {"resonance", "drifting_line"}
        Which effect the time view points to.
    band_hz : (float, float)
        Half-power edges of the excess.
    params : dict
        Starting / fixed parameters of the effect's Term (``N, frequency, damping`` or
        ``amplitude, f_start, f_end``).
    """

    kind: str
    band_hz: tuple[float, float]
    params: dict[str, float]


def _half_power(exc: NDArray[np.float64], k: int, run: int = 4) -> tuple[int, int] | None:
    """Nearest bins on both sides of ``k`` where ``run`` consecutive bins lie below half."""
    below = (exc < 0.5 * exc[k]).astype(np.int64)
    full = np.convolve(below, np.ones(run, dtype=np.int64), mode="valid") == run  # [i, i+run)
    left = np.flatnonzero(full[: max(k - run + 1, 0)])
    right = np.flatnonzero(full[k + 1 :])
    if left.size == 0 or right.size == 0:
        return None
    return int(left[-1] + run - 1), int(k + 1 + right[0])


def _ridge(
    x: NDArray[np.float64], fs: float, band: tuple[float, float]
) -> tuple[float, float] | None:
    """Frequencies at start and end of a peak that moves linearly in time, if one does."""
    seg = x.size // N_SEGMENTS
    if seg < 64:
        return None
    win = signal.get_window("hann", seg)
    f = np.fft.rfftfreq(seg, 1.0 / fs)
    lo, hi = band
    width = hi - lo
    sel = (f >= lo - 0.5 * width) & (f <= hi + 0.5 * width)
    if np.count_nonzero(sel) < 3:
        return None
    peaks = []
    for i in range(N_SEGMENTS):
        y = x[i * seg : (i + 1) * seg]
        p = np.abs(np.fft.rfft((y - y.mean()) * win)) ** 2
        peaks.append(f[sel][int(np.argmax(p[sel]))])
    t = (np.arange(N_SEGMENTS) + 0.5) * seg / fs
    pk = np.asarray(peaks)
    # a robust line (Theil-Sen), then least squares on the segments near it: a weak line
    # loses a few segments to noise peaks elsewhere in the band, which a plain least-squares
    # line with its R^2 does not survive (3 of 16 cost a drifting line at twice the clear level)
    slope, icpt = stats.theilslopes(pk, t, method="joint")[:2]
    near = np.abs(pk - (slope * t + icpt)) <= INLIER_BINS * fs / seg
    if np.count_nonzero(near) < INLIER_SHARE * N_SEGMENTS:
        return None
    slope, icpt = np.polyfit(t[near], pk[near], 1)
    resid = pk[near] - (slope * t[near] + icpt)
    total = float(np.sum((pk[near] - np.mean(pk[near])) ** 2))
    duration = x.size / fs
    if total <= 0 or 1.0 - float(np.sum(resid**2)) / total < 0.8:
        return None
    if abs(slope) * duration < MIN_BINS * fs / seg:
        return None
    f0, f1 = float(icpt), float(icpt + slope * duration)
    if min(f0, f1) <= 0:
        return None
    return f0, f1


def _fit_resonance(
    fv: FrequencyView, dt: float, k: int, edges: tuple[int, int]
) -> dict[str, float] | None:
    f = fv.f
    exc = fv.real_psd - fv.sim_psd
    a, b = edges
    f0 = float(f[k])
    zeta0 = float(np.clip((f[b] - f[a]) / (2.0 * f0), 0.01, 0.9))
    n0 = float(np.sqrt(max(exc[k], 1e-300) / 2.0))
    span = b - a + 1
    # the fit sees the continuum on both sides: at least f0/2 .. 3 f0/2
    lo = max(min(a - 2 * span, int(np.searchsorted(f, 0.5 * f0))), 0)
    hi = min(max(b + 2 * span, int(np.searchsorted(f, 1.5 * f0))), f.size - 1)
    fb = f[lo : hi + 1]
    target = np.log(fv.real_psd[lo : hi + 1])
    sim = fv.sim_psd[lo : hi + 1]

    def resid(p: NDArray[np.float64]) -> NDArray[np.float64]:
        term = Resonance(
            N=float(np.exp(p[0])),
            frequency=float(np.exp(p[1])),
            damping=float(1 / (1 + np.exp(-p[2]))),
        )
        return np.asarray(np.log(sim + np.exp(p[3]) + term.psd_sampled(fb, dt)) - target)

    # the fourth parameter is a flat excess under the peak (more white noise, say): the local
    # continuum, which must not pull the resonance's frequency and width
    floor = max(float(np.median(exc[lo : hi + 1])), 0.01 * float(np.median(sim)))
    start = np.array([np.log(n0), np.log(f0), np.log(zeta0 / (1 - zeta0)), np.log(floor)])
    try:
        with np.errstate(all="ignore"):
            res = optimize.least_squares(resid, start, method="lm", max_nfev=800)
    except (ValueError, FloatingPointError):
        return None
    # the peak must earn its three parameters over a flat excess alone (F test on the log PSD)
    flat = np.log(sim[:, None] + np.exp(np.linspace(-12.0, 2.0, 141))[None, :] * np.median(sim))
    rss0 = float(np.min(np.sum((flat - target[:, None]) ** 2, axis=0)))
    rss1 = float(np.sum(res.fun**2))
    dof = fb.size - 4
    if dof < 4 or rss1 <= 0:
        return None
    if stats.f.sf((rss0 - rss1) / 3.0 / (rss1 / dof), 3, dof) > PEAK_ALPHA:
        return None
    n, freq, zeta = np.exp(res.x[0]), np.exp(res.x[1]), 1 / (1 + np.exp(-res.x[2]))
    if not (np.isfinite(n) and f[0] <= freq <= 0.5 / dt and 0.005 <= zeta <= 0.7):
        return None
    return {"N": float(n), "frequency": float(freq), "damping": float(zeta)}


def band_shapes(
    x: NDArray[np.float64], fs: float, fv: FrequencyView, n_max: int = MAX_BANDS
) -> list[BandShape]:
    """The band-pass shaped excesses of a record, strongest first (see the module docstring).

    After a resonance, the next is sought outside its band against the simulated sensor plus
    it; a drifting line ends the search (one per record).
    """
    out: list[BandShape] = []
    cur = fv
    skip = np.zeros(fv.f.size, dtype=bool)
    while len(out) < n_max:
        found = _band_shape(x, fs, cur, skip)
        if found is None or (out and found.kind != "resonance"):
            break
        out.append(found)
        if found.kind != "resonance":
            break
        lo, hi = found.band_hz
        width = hi - lo
        skip |= (fv.f >= lo - width) & (fv.f <= hi + width)
        with np.errstate(all="ignore"):
            psd = Resonance(**found.params).psd_sampled(fv.f, 1.0 / fs)
        cur = replace(cur, sim_psd=cur.sim_psd + np.where(np.isfinite(psd), psd, 0.0))
    return out


def band_shape(x: NDArray[np.float64], fs: float, fv: FrequencyView) -> BandShape | None:
    """The band-pass shaped excess of a record, if its frequency view shows one.

    Parameters
    ----------
    x : numpy.ndarray
        The (fitted part of the) real record, rate samples.
    fs : float
        Sampling frequency in Hz.
    fv : FrequencyView
        Its frequency view against the simulated sensor.
    """
    return _band_shape(x, fs, fv, None)


def _band_shape(
    x: NDArray[np.float64], fs: float, fv: FrequencyView, skip: NDArray[np.bool_] | None
) -> BandShape | None:
    """The strongest band-pass shaped excess outside the bins ``skip``."""
    if fv.band_z.size == 0:
        return None
    up = np.flatnonzero(fv.band_z > fv.band_threshold)
    if up.size == 0:
        return None
    f = fv.f
    # a running median over 1/128 of the spectrum: Welch bins scatter by ~1/sqrt(nu) each
    size = max(5, f.size // 128)
    exc = ndimage.median_filter(fv.real_psd - fv.sim_psd, size=size, mode="nearest")
    # each run of adjacent significant bands on its own, the largest excess first: a
    # monotone excess elsewhere (rate random walk at the lowest frequencies) must not hide a
    # band-pass shape (it used to, as the spectrum's overall peak without half-power edges);
    # bins in ``skip`` (a resonance already found) are not searched again
    peaks = []
    for run in np.split(up, np.flatnonzero(np.diff(up) > 1) + 1):
        in_band = (f >= fv.band_edges_hz[run[0]]) & (f < fv.band_edges_hz[run[-1] + 1])
        if skip is not None:
            in_band &= ~skip
        if np.any(in_band & (exc > 0)):
            peaks.append(int(np.flatnonzero(in_band)[np.argmax(exc[in_band])]))
    for k in sorted(peaks, key=lambda i: -exc[i]):
        shape = _shape_at(x, fs, fv, exc, k)
        if shape is not None:
            return shape
    return None


def _shape_at(
    x: NDArray[np.float64], fs: float, fv: FrequencyView, exc: NDArray[np.float64], k: int
) -> BandShape | None:
    """The band-pass shape around the excess peak at bin ``k``, if it has one."""
    f = fv.f
    edges = _half_power(exc, k)
    if edges is None:
        return None
    band = (float(f[edges[0]]), float(f[edges[1]]))
    ridge = _ridge(x, fs, band)
    if ridge is not None:
        lo, hi = sorted(ridge)
        sel = (f >= lo) & (f <= hi)
        power = float(np.sum(np.clip(fv.real_psd - fv.sim_psd, 0, None)[sel])) * (f[1] - f[0])
        amp = float(np.sqrt(2.0 * max(power, 1e-300)))
        return BandShape("drifting_line", band, {"amplitude": amp, "f_start": ridge[0],
                                                 "f_end": ridge[1]})  # fmt: skip
    params = _fit_resonance(fv, 1.0 / fs, k, edges)
    if params is None:
        return None
    return BandShape("resonance", band, params)
