"""The non-stationary/non-Gaussian terms and the generator building blocks, without Monte Carlo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

import allanite
from allanite.simulation.flicker import (
    SPECTRAL_MAX_SAMPLES,
    FlickerStream,
    flicker_design,
    flicker_stream,
)
from allanite.simulation.gaussian import _residual_variance
from allanite.simulation.spectral import SpectralStream
from allanite.terms import (
    BiasSteps,
    Flicker,
    LowPassWhite,
    Spikes,
    Telegraph,
    TurnOnBias,
    WarmUp,
    term_from_dict,
)
from allanite.terms.flicker import PLATEAU
from allanite.terms.flicker_laws import _fir_avar, bank_avar
from allanite.terms.markov import sampled_ar1_avar
from allanite.terms.transients import markov_avar_continuous

NEW_TERMS = [
    TurnOnBias(sigma=0.1),
    WarmUp(amplitude=0.2, tau_w=30.0, duration=600.0),
    BiasSteps(size=0.01, interval=100.0),
    Spikes(amplitude=2.0, rate=0.3),
    Telegraph(amplitude=0.05, tau_c=0.7),
    LowPassWhite(N=0.01, bandwidth=8.0),
]


@pytest.mark.parametrize("term", NEW_TERMS, ids=lambda t: t.type)
def test_json_round_trip(term):
    assert term_from_dict(term.to_dict()) == term


@pytest.mark.parametrize(
    "term",
    [
        Telegraph(0.3, 0.05),
        Telegraph(1.0, 0.001),
        LowPassWhite(0.1, 5.0),
        LowPassWhite(0.1, 200.0),
        Spikes(1.0, 3.0),
    ],
    ids=lambda t: f"{t.type}",
)
def test_sampled_psd_integrates_to_the_avar(term):
    # avar(m dt) = integral_0^{1/(2dt)} 2 sin^4(pi f m dt)/(m sin(pi f dt))^2 S(f) df
    dt = 0.01
    f = np.linspace(1e-9, 0.5 / dt, 200_001)
    for m in (1, 3, 40):
        gain = 2.0 * np.sin(np.pi * f * m * dt) ** 4 / (m * np.sin(np.pi * f * dt)) ** 2
        value = integrate.trapezoid(gain * term.psd_sampled(f, dt), f)
        assert value == pytest.approx(float(term.avar(m * dt, dt)), rel=1e-6)


def test_markov_continuous_avar_is_smooth_across_its_series_switch():
    x = np.array([0.0999999, 0.1, 0.1000001])
    values = markov_avar_continuous(1.0, 1.0, x)
    slope = np.diff(values) / np.diff(x)
    assert slope[0] == pytest.approx(slope[1], rel=1e-5)
    # small-tau limit: 2 s^2 tau / (3 Tc) (a random walk of intensity 2 s^2 / Tc)
    assert markov_avar_continuous(2.0, 5.0, np.array([1e-6]))[0] == pytest.approx(
        2.0 * 2.0 * 1e-6 / (3.0 * 5.0), rel=1e-6
    )


def test_residual_variance_series_meets_the_direct_form():
    below = _residual_variance(0.1 - 1e-12)
    above = _residual_variance(0.1)
    assert below == pytest.approx(above, rel=1e-12)
    assert _residual_variance(1e-9) == pytest.approx(1e-9 / 6.0, rel=1e-12)


def test_warmup_avar_equals_the_direct_sum():
    term = WarmUp(amplitude=0.5, tau_w=3.0, duration=50.0)
    dt = 0.1
    k = np.arange(500)
    samples = term.amplitude * (term.tau_w / dt) * -np.expm1(-dt / term.tau_w)
    samples = samples * np.exp(-k * dt / term.tau_w)
    for m in (1, 7, 100, 249):
        means = np.convolve(samples, np.ones(m) / m, mode="valid")
        direct = 0.5 * np.mean((means[m:] - means[:-m]) ** 2)
        assert float(term.avar(m * dt, dt)) == pytest.approx(direct, rel=1e-10)
    assert np.isnan(term.avar(300 * dt, dt))  # no difference term left


def test_simple_laws():
    tau = np.array([0.1, 1.0, 10.0])
    np.testing.assert_allclose(BiasSteps(0.2, 50.0).avar(tau, 0.01), 0.04 * tau / 150.0)
    p = -math.expm1(-0.3 * 0.01)
    np.testing.assert_allclose(Spikes(2.0, 0.3).avar(tau, 0.01), p * 4.0 * 0.01 / tau)
    np.testing.assert_array_equal(TurnOnBias(0.1).avar(tau, 0.01), 0.0)
    lp = LowPassWhite(N=0.01, bandwidth=1.0)
    # far above the filter time constant: N^2/tau - 3 N^2 Tf / (2 tau^2)
    big = np.array([100.0, 1000.0])
    np.testing.assert_allclose(
        lp.avar(big, 0.01), 1e-4 / big - 1.5e-4 * lp.tau_f / big**2, rtol=1e-9
    )


def test_flicker_method_choice():
    term = Flicker(B=1.0)
    assert isinstance(flicker_stream(term, 100.0, 1, 1, n_samples=1000), SpectralStream)
    assert isinstance(
        flicker_stream(term, 100.0, 1, 1, n_samples=SPECTRAL_MAX_SAMPLES + 1), FlickerStream
    )
    assert isinstance(flicker_stream(term, 100.0, 1, 1), FlickerStream)
    with pytest.raises(ValueError, match="unknown flicker method"):
        flicker_stream(term, 100.0, 1, 1, method="fft")


@pytest.mark.parametrize("n", [24 * 3600 * 2000, 10**9])
def test_streaming_flicker_law_is_the_term_at_every_tau(n):
    # a day at 2 kHz and 1e9 samples: the generator's exact law is Flicker.avar from tau = dt
    # to half the record within 1e-5, far inside the chi-square band (>= 1e-4 at tau = dt)
    dt = 1.0 / 2000.0
    m = np.unique(np.round(np.logspace(0, np.log10(n / 2), 60)))
    law = bank_avar(m * dt, dt, 1.0, n_samples=n)
    np.testing.assert_allclose(law, Flicker(B=1.0).avar(m * dt, dt), rtol=1e-5, atol=0)
    # the three parts sum to the sampled PSD without clipping anything
    assert flicker_design(n).clipped == 0.0
    # (the old point-sampled bank was -30% at tau = dt; the plateau holds as before)
    plateau = m >= 30
    np.testing.assert_allclose(law[plateau] / PLATEAU, 1.0, atol=0.01)


@pytest.mark.parametrize(("cutoff", "rtol"), [(0.25, 2e-5), (0.1, 1e-5)])
def test_streaming_flicker_law_with_a_cutoff_below_nyquist(cutoff, rtol):
    # the low-pass on the bank removes its tails above f0 (nothing clipped) and the residual
    # takes the band edge: the law is the band-limited term's within rtol (measured 7e-6, 5e-6)
    dt, n = 1.0 / 100.0, 10**8
    m = np.unique(np.round(np.logspace(0, np.log10(n / 2), 25)))
    term = Flicker(B=1.0, f0=cutoff / dt)
    law = bank_avar(m * dt, dt, 1.0, cutoff_hz=term.f0, n_samples=n)
    np.testing.assert_allclose(law, term.avar(m * dt, dt), rtol=rtol, atol=0)
    assert flicker_design(n, cutoff).clipped < 1e-10


def test_bank_law_needs_tau_on_the_sample_grid():
    with pytest.raises(ValueError, match="whole multiples"):
        bank_avar([1.5e-3], 1e-3, 1.0)


@pytest.mark.parametrize("theta", [1e-9, 1e-4, 0.09, 0.11, 3.0])
def test_sampled_ar1_avar_is_the_autocovariance_sum(theta):
    # brute force: AVAR = -(1/2m^2) sum_k (1 - phi^|k|) w_k (the constant part of R cancels)
    for m in (1, 2, 9, 150):
        k = np.arange(-2 * m + 1, 2 * m)
        tri = np.clip(m - np.abs(k), 0, None)
        w = 2 * tri - np.clip(m - np.abs(k - m), 0, None) - np.clip(m - np.abs(k + m), 0, None)
        brute = -np.sum(-np.expm1(-np.abs(k) * theta) * w) / (2.0 * m * m)
        assert sampled_ar1_avar(2.0, theta, m) == pytest.approx(2.0 * brute, rel=1e-12)


def test_fir_avar_is_the_filtered_difference_variance():
    # AVAR = |g|^2 / 2 with g = taps * c, c = (-1 x m, +1 x m) / m: white input, both branches
    taps = np.random.default_rng(3).standard_normal(50)
    for m in (1, 7, 49, 50, 120):
        c = np.concatenate((-np.ones(m), np.ones(m))) / m
        g = np.convolve(taps, c)
        expected = 0.5 * float(np.sum(g * g))
        assert _fir_avar(taps, np.array([m]))[0] == pytest.approx(expected, rel=1e-12)


def test_spectral_stream_rejects_overrun():
    stream = SpectralStream(lambda f: np.ones_like(f), 10, 1.0, 1, 1)
    stream.next(stream.block)
    with pytest.raises(ValueError, match="built for 10 samples"):
        stream.next(1)


def test_ar1_bank_core_is_thread_count_independent():
    from allanite import _core

    rng = np.random.default_rng(1)
    z = rng.standard_normal((500, 3, 8))
    args = (np.array([0.9, 0.5, 1.0]), np.ones(3), np.array([0.9, 0.5, 1.0]), np.ones(3), z)
    one = _core.ar1_bank(np.zeros((3, 8)), *args, 1)
    two = _core.ar1_bank(np.zeros((3, 8)), *args, 2)
    assert np.array_equal(one, two)
    # reference recursion
    x = np.zeros((3, 8))
    ref = np.empty((500, 8))
    for k in range(500):
        e = z[k]
        ref[k] = (args[2][:, None] * x + e).sum(axis=0)
        x = args[0][:, None] * x + e
    np.testing.assert_allclose(one, ref, rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="phi"):
        _core.ar1_bank(np.zeros((3, 8)), np.array([1.5, 0, 0]), *args[1:], 1)


def test_simulated_lowpass_has_the_negative_quantization_signature():
    # a white + quantization fit of a low-pass record's AVAR returns Q^2 < 0 (docs/architecture.md)
    term = LowPassWhite(N=0.01, bandwidth=2.0)
    x = allanite.model.NoiseModel((term,)).simulate(1 << 16, fs=100.0, seed=3)
    r = allanite.avar(x, fs=100.0, taus="octave", alpha=0)
    keep = (r.tau > 0.15) & (r.tau < 6.0)
    weight = 1.0 / r.var[keep]  # relative errors
    design = np.column_stack([3.0 / r.tau[keep] ** 2, 1.0 / r.tau[keep]]) * weight[:, None]
    q2, n2 = np.linalg.lstsq(design, r.var[keep] * weight, rcond=None)[0]
    assert q2 < 0
    assert n2 == pytest.approx(term.N**2, rel=0.1)


def test_fir_stream_is_the_direct_convolution_across_overlap_save_steps():
    from allanite.simulation.flicker import FirStream
    from allanite.simulation.streams import make_generator

    taps = np.random.default_rng(4).standard_normal(40)
    stream = FirStream(taps, 10.0, 2, seed=11)
    n = stream.step + 1000  # two overlap-save steps
    y = stream.next(n)
    # the same normal numbers in the same order: the history, then whole steps
    rng = make_generator(11)
    inputs = np.concatenate(
        [rng.standard_normal((taps.size - 1, 2))]
        + [rng.standard_normal((stream.step, 2)) for _ in range(2)]
    )
    for c in range(2):
        direct = np.convolve(inputs[:, c], taps, mode="valid")[:n]
        np.testing.assert_allclose(y[:, c], direct, rtol=0, atol=1e-12 * np.abs(direct).max())
