"""Resonance and drifting-line terms and candidates; two effects at once (issue 14).

Exact forms against brute force and against their own sampled PSD; simulations against the
exact Allan variance with the spread of independent channels as the tolerance; the frequency
view's band-shape detector on a resonance, a drifting line, a null record and bursts; the
joint attribution naming both effects of a pair (fixed seeds).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import integrate

import allanite
from allanite.diagnosis import diagnose
from allanite.diagnosis.analysis import analyze
from allanite.diagnosis.band_shape import band_shape
from allanite.diagnosis.inputs import SimSource
from allanite.model import NoiseModel
from allanite.terms import DriftingLine, RateRandomWalk, Resonance, Sine, White, term_from_dict
from test_diagnosis_pairs import fit_half

FS = 100.0
DT = 1.0 / FS
UNITS = {"rate": "deg/s", "time": "s"}
BASE = NoiseModel((White(N=0.05), RateRandomWalk(K=0.0008)), UNITS)


def _avar_from_autocovariance(acov, m: int) -> float:
    lags = np.arange(-(m - 1), m)
    w = m - np.abs(lags)
    return float(np.sum(w * (acov(np.abs(lags)) - acov(np.abs(m + lags)))) / m**2)


def _sampled_psd_integral(term, m: int, breaks=()) -> float:
    def integrand(f):
        h2 = 2 * np.sin(np.pi * f * m * DT) ** 4 / (m * np.sin(np.pi * f * DT)) ** 2
        return h2 * term.psd_sampled(f, DT)

    pts = np.unique(np.concatenate([np.linspace(0, 0.5 / DT, 8 * m + 1), breaks]))
    return sum(
        integrate.quad(integrand, a, b, limit=400, epsabs=0, epsrel=1e-11)[0]
        for a, b in itertools.pairwise(pts)
    )


def _channel_ratio(term, n: int, taus: np.ndarray, channels: int = 8, seed: int = 5):
    """Mean over channels of measured / exact AVAR and its standard error."""
    x = NoiseModel((term,), UNITS).simulate(n, fs=FS, seed=seed, n_channels=channels)
    x = np.asarray(x).reshape(n, channels)
    exact = term.avar(taus, DT)
    r = np.array([allanite.avar(x[:, c], fs=FS, taus=taus).var / exact for c in range(channels)])
    return r.mean(axis=0), r.std(axis=0, ddof=1) / np.sqrt(channels)


# --- Resonance ---------------------------------------------------------------------------------

RES = Resonance(N=0.05, frequency=20.0, damping=0.1)


def test_resonance_avar_matches_its_autocovariance():
    alpha = RES.damping * RES.omega0
    wd = RES.omega0 * math.sqrt(1 - RES.damping**2)

    def acov(lag):
        t = lag * DT
        return RES.variance * np.exp(-alpha * t) * (np.cos(wd * t) - alpha / wd * np.sin(wd * t))

    for m in (1, 2, 3, 5, 8, 50, 400):
        brute = _avar_from_autocovariance(acov, m)
        assert math.isclose(RES.avar(m * DT, DT)[()], brute, rel_tol=1e-9), m


@pytest.mark.parametrize(
    "term",
    [
        RES,
        Resonance(N=0.2, frequency=3.0, damping=0.4),
        Resonance(N=1.0, frequency=45.0, damping=0.02),
    ],
    ids=repr,
)
def test_resonance_avar_is_integral_of_its_sampled_psd(term):
    for m in (1, 2, 7, 20):
        total = _sampled_psd_integral(term, m, breaks=[term.frequency])
        assert math.isclose(term.avar(m * DT, DT)[()], total, rel_tol=1e-6), m


def test_resonance_psd_peaks_at_the_white_level_and_continuous_limit():
    assert RES.psd(20.0) == pytest.approx(2 * 0.05**2)
    # far below the Nyquist frequency the sampled PSD is the continuous one plus small aliases
    f = np.array([15.0, 20.0, 25.0])
    fine = 1e-4
    np.testing.assert_allclose(RES.psd_sampled(f, fine), RES.psd(f), rtol=1e-3)


def test_resonance_simulation_matches_exact_avar():
    taus = np.array([0.01, 0.02, 0.05, 0.2, 1.0])
    mean, se = _channel_ratio(RES, 2**16, taus)
    assert np.all(np.abs(mean - 1.0) < 4 * se + 1e-3), (mean, se)


def test_resonance_checks_and_json():
    assert term_from_dict(RES.to_dict()) == RES
    with pytest.raises(ValueError, match="damping must lie in"):
        Resonance(N=0.1, frequency=5.0, damping=1.2)


# --- DriftingLine ------------------------------------------------------------------------------

DRIFT = DriftingLine(amplitude=0.3, f_start=5.0, f_end=8.0, duration=655.36)


def test_drifting_line_avar_is_integral_of_its_sampled_psd():
    for m in (1, 3, 16, 40):
        total = _sampled_psd_integral(DRIFT, m, breaks=[5.0, 8.0])
        assert math.isclose(DRIFT.avar(m * DT, DT)[()], total, rel_tol=1e-7), m


def test_drifting_line_is_the_frequency_average_of_sines():
    freqs = np.linspace(5.0, 8.0, 20001)
    taus = np.array([0.01, 0.37, 3.0])
    brute = np.trapezoid([Sine(amplitude=0.3, frequency=f).avar(taus, DT) for f in freqs],
                         freqs, axis=0) / 3.0  # fmt: skip
    np.testing.assert_allclose(DRIFT.avar(taus, DT), brute, rtol=1e-5)


def test_drifting_line_simulation_matches_exact_avar():
    """Quasi-static: |f_end - f_start| tau^2 / D <= 3e-4 at the largest tau below."""
    taus = np.array([0.01, 0.05, 0.1, 0.3, 1.0])
    mean, se = _channel_ratio(DRIFT, 2**16, taus, channels=4)
    assert np.all(np.abs(mean - 1.0) < 4 * se + 5e-3), (mean, se)


def test_drifting_line_checks_and_json():
    assert term_from_dict(DRIFT.to_dict()) == DRIFT
    with pytest.raises(ValueError, match="does not drift"):
        DriftingLine(amplitude=0.1, f_start=5.0, f_end=5.0, duration=10.0)


# --- the band-shape detector -------------------------------------------------------------------

N = 2**15


def _view(x: np.ndarray, lines: list | None = None):
    a = analyze(x, SimSource(fs=FS, model=BASE), n_mc=30, seed=2, alpha=0.05)
    if lines is not None:
        lines.extend(a.frequency.lines)
    return band_shape(x, FS, a.frequency)


def test_band_shape_finds_a_resonance():
    x = BASE.plus(Resonance(N=0.1, frequency=20.0, damping=0.1)).simulate(N, fs=FS, seed=11)
    shape = _view(np.asarray(x, dtype=float))
    assert shape is not None
    assert shape.kind == "resonance"
    assert shape.params["frequency"] == pytest.approx(20.0, rel=0.05)
    assert shape.params["damping"] == pytest.approx(0.1, rel=0.5)


def test_band_shape_finds_a_drifting_line():
    line = DriftingLine(amplitude=0.3, f_start=5.0, f_end=8.0, duration=N / FS)
    x = BASE.plus(line).simulate(N, fs=FS, seed=12)
    shape = _view(np.asarray(x, dtype=float))
    assert shape is not None
    assert shape.kind == "drifting_line"
    # spectrogram bins are FS / (N / 16) = 0.05 Hz wide
    assert shape.params["f_start"] == pytest.approx(5.0, abs=0.2)
    assert shape.params["f_end"] == pytest.approx(8.0, abs=0.2)


def test_band_shape_finds_a_resonance_next_to_a_rate_random_walk():
    # the random walk's excess at the lowest frequencies is the spectrum's largest and has no
    # half-power edge below it: it used to hide the resonance (band_shape returned None)
    real = BASE.plus(Resonance(N=0.047, frequency=20.0, damping=0.1))
    x = np.asarray(real.plus(RateRandomWalk(K=0.032)).simulate(N, fs=FS, seed=14), dtype=float)
    a = analyze(x, SimSource(fs=FS, model=BASE), n_mc=30, seed=2, alpha=0.05)
    fv = a.frequency
    up = np.flatnonzero(fv.band_z > fv.band_threshold)
    assert fv.band_edges_hz[up[0] + 1] < 1.0  # a significant band of the random walk
    assert fv.band_edges_hz[up[-1]] < 20.0 < fv.band_edges_hz[up[-1] + 1]  # the resonance's
    exc = fv.real_psd - fv.sim_psd
    assert fv.f[int(np.argmax(exc))] < 1.0  # the random walk's excess is the larger
    shape = band_shape(x, FS, fv)
    assert shape is not None
    assert shape.kind == "resonance"
    assert shape.params["frequency"] == pytest.approx(20.0, rel=0.05)


def test_drifting_line_ridge_survives_noise_peaks_in_a_few_segments():
    # a weak line loses a few of the 16 spectrogram segments to a stronger peak elsewhere in
    # the band; the plain least-squares line's R^2 dropped below 0.8 there (returned None)
    from allanite.diagnosis.band_shape import N_SEGMENTS, _ridge

    rng = np.random.default_rng(15)
    t = np.arange(N) / FS
    f0, f1 = 5.0, 6.5
    phase = 2 * np.pi * (f0 * t + 0.5 * (f1 - f0) * t**2 / t[-1])
    x = 0.5 * rng.standard_normal(N) + 0.3 * np.sin(phase)
    seg = N // N_SEGMENTS
    for i, f in ((5, 7.0), (11, 4.3), (13, 7.2)):  # three segments with another, stronger peak
        x[i * seg : (i + 1) * seg] += 1.0 * np.sin(2 * np.pi * f * t[i * seg : (i + 1) * seg])
    ridge = _ridge(x, FS, (4.93, 6.59))
    assert ridge is not None
    # spectrogram bins are FS / seg = 0.05 Hz wide
    assert ridge[0] == pytest.approx(f0, abs=0.1)
    assert ridge[1] == pytest.approx(f1, abs=0.1)
    # a resonance's peaks scatter over its band without a line through them
    res = NoiseModel((Resonance(N=0.3, frequency=5.7, damping=0.1),), UNITS).simulate(
        N, fs=FS, seed=16
    )
    assert (
        _ridge(np.asarray(res, dtype=float) + 0.5 * rng.standard_normal(N), FS, (5.1, 6.3)) is None
    )


def test_band_shape_none_on_null_and_on_bursts():
    x = np.asarray(BASE.simulate(N, fs=FS, seed=13), dtype=float)
    assert _view(x) is None
    y = x.copy()
    rng = np.random.default_rng(3)
    for a in (3000, 15000, 25000):  # white x3 in three 30-s bursts: a flat excess, no peak
        y[a : a + 3000] += rng.standard_normal(3000) * math.sqrt(8) * 0.05 * math.sqrt(FS)
    lines: list = []
    assert _view(y, lines) is None
    assert lines == []  # and no spurious spectral line in the non-stationary record


# --- two effects at once -----------------------------------------------------------------------


def test_resonance_and_more_white_are_both_named():
    real = BASE.plus(Resonance(N=0.1, frequency=20.0, damping=0.1)).plus(White(N=0.08))
    x = real.simulate(2 * N, fs=FS, seed=21)
    d = diagnose(x, BASE, fs=FS, units="deg/s", n_mc=30, seed=4)
    assert d.explanation is not None
    named = {a.effect for a in d.explanation.effects}
    assert "resonance" in named
    assert named & {"white", "rescale:white"}
    res = next(a for a in d.explanation.effects if a.effect == "resonance")
    assert res.params["frequency"] == pytest.approx(20.0, rel=0.05)


def test_warmup_under_gauss_markov_noise_is_named_with_it():
    """The level shape is judged against the Gauss-Markov noise already in the set.

    Without the chosen effect's slow noise in the window-mean spreads, a rate random walk
    (which explains the level wander by itself) was chosen instead of the warm-up.
    """
    from allanite.terms import Flicker, GaussMarkov, Quantization, WarmUp

    n = 2**16
    base = NoiseModel(
        (White(N=0.05), Quantization(Q=0.002), Flicker(B=0.01), RateRandomWalk(K=0.0008)), UNITS
    )
    warm = WarmUp(amplitude=0.5553, tau_w=16.384, duration=n / FS)
    real = base.simulate(n, fs=FS, seed=1153)
    real = real + NoiseModel((warm,), UNITS).simulate(n, fs=FS, seed=1160, allow_aliasing=True)
    gm = GaussMarkov(sigma=0.04524, tau_c=2.0)
    real = real + NoiseModel((gm,), UNITS).simulate(n, fs=FS, seed=1166, allow_aliasing=True)
    d = diagnose(fit_half(np.ravel(real)), base, fs=FS, units="deg/s", n_mc=40, seed=1154)
    assert d.explanation is not None
    named = {a.effect for a in d.explanation.effects}
    assert {"warmup", "markov"} <= named
