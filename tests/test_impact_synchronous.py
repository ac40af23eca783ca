"""Synchronous error on an oscillating stand: harmonic amplitudes buried in gyro noise."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from allanite.impact import synchronous_error

FS = 200.0
F0 = 2.0  # Hz, the source's stand frequency
A_STAND = 200.0  # deg/s, the source's stand amplitude
REL = 0.00085  # the source's FFT result a1/A
SIGMA_N = 0.225  # deg/s white gyro noise: the time series then "shows" about 0.005 A
Z = 4.0


def _record(rng, n, harmonics, *, sigma=SIGMA_N, drift=0.0):
    t = np.arange(n) / FS
    x = sigma * rng.standard_normal(n) + drift * np.cumsum(rng.standard_normal(n)) / FS
    for k, (amp, ph) in harmonics.items():
        x += amp * np.cos(2 * np.pi * k * F0 * t + ph)
    return x


def test_source_example_fft_versus_time_series_peak():
    rng = np.random.default_rng(1)
    n = int(100.3 * FS)  # 200.6 periods: not an integer number
    a1 = REL * A_STAND
    x = _record(rng, n, {1: (a1, 0.7)}, drift=0.02)
    res = synchronous_error(x, fs=FS, amplitude=A_STAND, frequency=F0)
    expected_sigma = SIGMA_N * math.sqrt(2.0 / n)
    assert res.fundamental.uncertainty == pytest.approx(expected_sigma, rel=0.15)
    assert abs(res.a1 - a1) < Z * res.fundamental.uncertainty
    assert abs(res.relative_error - REL) < Z * res.relative_uncertainty
    assert res.fundamental.detected
    assert res.fundamental.phase == pytest.approx(0.7, abs=Z * expected_sigma / a1)
    # reading the amplitude off the noisy time series gives about 0.005, six times too much
    assert 0.004 < res.peak_relative_error < 0.007
    assert res.peak_relative_error > 4 * res.relative_error
    assert res.attenuation == pytest.approx(1 / REL, rel=Z * res.relative_uncertainty / REL)
    assert not res.dry_friction


@pytest.mark.parametrize("colored", [False, True])
def test_uncertainty_is_calibrated_by_monte_carlo(colored):
    # 300 records; the spread of the estimates must match the reported uncertainty, also for
    # coloured noise (white + Gauss-Markov with tau_c = 0.05 s: the PSD at f0 and 3 f0 differ)
    rng = np.random.default_rng(2 + colored)
    n, reps = 4000, 300
    a = {1: (0.3, 0.2), 3: (0.1, 1.0)}
    z1, z3, s1 = [], [], []
    phi = math.exp(-1 / (FS * 0.05))
    for _ in range(reps):
        x = _record(rng, n, a)
        if colored:
            e = 0.5 * math.sqrt(1 - phi**2) * rng.standard_normal(n)
            from scipy.signal import lfilter

            x += lfilter([1.0], [1.0, -phi], e)
        res = synchronous_error(x, fs=FS, amplitude=A_STAND, frequency=F0, harmonics=(3,))
        h3 = res.harmonics[0]
        z1.append((res.a1 - a[1][0]) / res.fundamental.uncertainty)
        z3.append((h3.amplitude - a[3][0]) / h3.uncertainty)
        s1.append(res.fundamental.uncertainty)
    for z in (np.array(z1), np.array(z3)):
        # unit variance: reps * var ~ chi2(reps - 1); mean 0
        lo, hi = stats.chi2.ppf([1e-4, 1 - 1e-4], reps - 1) / (reps - 1)
        assert lo < z.var(ddof=1) < hi, z.var(ddof=1)
        assert abs(z.mean()) < Z / math.sqrt(reps)


def test_dry_friction_odd_harmonics_are_found():
    rng = np.random.default_rng(4)
    n = int(60.7 * FS)
    true = {1: (0.4, 0.0), 3: (0.08, 0.5), 5: (0.05, 1.1), 7: (0.03, -0.4)}
    x = _record(rng, n, true)
    res = synchronous_error(x, fs=FS, amplitude=A_STAND, frequency=F0)
    assert [h.order for h in res.harmonics] == [3, 5, 7, 9]
    for h in res.harmonics:
        amp = true.get(h.order, (0.0, 0.0))[0]
        if amp:
            assert abs(h.amplitude - amp) < Z * h.uncertainty, h
            assert h.detected
        else:
            assert not h.detected
    assert res.dry_friction
    ratios = res.harmonic_ratios()
    assert ratios[3] == pytest.approx(0.2, abs=Z * res.harmonics[0].uncertainty / 0.4 * 1.5)


def test_no_leakage_for_a_non_integer_number_of_periods():
    n = int(50.25 * FS)  # 100.5 periods: worst case for an FFT bin reading
    t = np.arange(n) / FS
    x = 0.3 * np.sin(2 * np.pi * F0 * t) + 0.01 * np.sin(2 * np.pi * 3 * F0 * t) + 5.0
    x = x + 1e-9 * np.random.default_rng(5).standard_normal(n)
    res = synchronous_error(x, fs=FS, amplitude=A_STAND, frequency=F0)
    assert res.a1 == pytest.approx(0.3, rel=1e-7)
    assert res.harmonics[0].amplitude == pytest.approx(0.01, rel=1e-6)
    # the nearest rectangular-window FFT bin would lose about a third (scalloping)
    spec = np.abs(np.fft.rfft(x - x.mean())) * 2 / n
    naive = spec[round(F0 * n / FS)]
    assert naive < 0.7 * 0.3


def test_harmonics_above_nyquist_are_skipped():
    rng = np.random.default_rng(6)
    x = _record(rng, 4000, {1: (0.3, 0.0)})
    res = synchronous_error(x, fs=FS, amplitude=A_STAND, frequency=15.0)
    assert [h.order for h in res.harmonics] == [3, 5]  # 105 and 135 Hz exceed 100 Hz


def test_bad_input():
    x = np.zeros(4000)
    with pytest.raises(ValueError, match="1-D"):
        synchronous_error(np.zeros((10, 2)), fs=FS, amplitude=1.0, frequency=F0)
    with pytest.raises(ValueError, match="NaN"):
        synchronous_error(np.array([0.0, np.nan] * 2000), fs=FS, amplitude=1.0, frequency=F0)
    with pytest.raises(ValueError, match="amplitude"):
        synchronous_error(x, fs=FS, amplitude=0.0, frequency=F0)
    with pytest.raises(ValueError, match="Nyquist"):
        synchronous_error(x, fs=FS, amplitude=1.0, frequency=150.0)
    with pytest.raises(ValueError, match="periods"):
        synchronous_error(x[:200], fs=FS, amplitude=1.0, frequency=F0)
    with pytest.raises(ValueError, match="harmonic orders"):
        synchronous_error(x, fs=FS, amplitude=1.0, frequency=F0, harmonics=(1,))
    with pytest.raises(TypeError, match="fs"):
        synchronous_error(x, fs="200", amplitude=1.0, frequency=F0)
    with pytest.raises(
        TypeError, match=r"fs is keyword-only: synchronous_error\(rate, fs=\.\.\.\)"
    ):
        synchronous_error(x, FS, amplitude=1.0, frequency=F0)


def test_chunked_fit_equals_one_block(monkeypatch):
    import allanite.impact.synchronous as sync

    rng = np.random.default_rng(7)
    x = _record(rng, 20_071, {1: (0.3, 0.4), 5: (0.02, 0.0)}, drift=0.05)
    whole = synchronous_error(x, fs=FS, amplitude=A_STAND, frequency=F0)
    monkeypatch.setattr(sync, "_CHUNK", 997)
    chunked = synchronous_error(x, fs=FS, amplitude=A_STAND, frequency=F0)
    assert chunked.a1 == pytest.approx(whole.a1, rel=1e-10)
    assert chunked.harmonics[1].amplitude == pytest.approx(whole.harmonics[1].amplitude, rel=1e-9)
    assert chunked.peak_reading == pytest.approx(whole.peak_reading, rel=1e-12)
