"""Streaming: chunked and one-shot generation agree bit for bit; flicker streams exactly."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import allanite
from allanite.model import NoiseModel
from allanite.simulation import simulate, simulate_chunks
from allanite.simulation.flicker import flicker_stream
from allanite.simulation.spectral import expected_avar
from allanite.simulation.streams import block_length
from allanite.terms import (
    BiasSteps,
    Flicker,
    GaussMarkov,
    LowPassWhite,
    Quantization,
    RateRamp,
    RateRandomWalk,
    Sine,
    Spikes,
    Telegraph,
    TurnOnBias,
    WarmUp,
    White,
)
from allanite.terms.flicker import PLATEAU
from allanite.terms.flicker_laws import bank_avar

EVERY_TERM = NoiseModel(
    (
        White(N=0.01),
        Quantization(Q=1e-3),
        Flicker(B=1e-3),
        RateRandomWalk(K=1e-4),
        GaussMarkov(sigma=0.01, tau_c=1.0),
        Sine(amplitude=0.01, frequency=3.0),
        RateRamp(R=1e-6),
        TurnOnBias(sigma=0.1),
        WarmUp(amplitude=0.1, tau_w=10.0, duration=100.0),
        BiasSteps(size=0.01, interval=50.0),
        Spikes(amplitude=1.0, rate=0.1),
        Telegraph(amplitude=0.01, tau_c=2.0),
        LowPassWhite(N=0.01, bandwidth=5.0),
    )
)
CHANNELS = 64
BLOCK = block_length(CHANNELS)
N = BLOCK + 123


@pytest.mark.parametrize("output", ["rate", "angle", "increment"])
@pytest.mark.parametrize("chunk", [1000, BLOCK + 1])
def test_chunked_equals_one_shot(output, chunk):
    whole = EVERY_TERM.simulate(N, fs=100.0, output=output, n_channels=CHANNELS, seed=11)
    pieces = list(
        simulate_chunks(
            EVERY_TERM, N, fs=100.0, output=output, n_channels=CHANNELS, seed=11, chunk=chunk
        )
    )
    assert all(p.shape[0] <= chunk for p in pieces)
    assert np.array_equal(np.concatenate(pieces), whole)


def test_one_sample_chunks_equal_one_shot():
    whole = EVERY_TERM.simulate(500, fs=100.0, output="angle", n_channels=2, seed=3)
    pieces = list(
        simulate_chunks(EVERY_TERM, 500, fs=100.0, output="angle", n_channels=2, seed=3, chunk=1)
    )
    assert np.array_equal(np.concatenate(pieces), whole)


def test_seed_reproducible_and_terms_independent():
    a = EVERY_TERM.simulate(2000, fs=100.0, seed=5)
    assert np.array_equal(a, EVERY_TERM.simulate(2000, fs=100.0, seed=5))
    assert not np.array_equal(a, EVERY_TERM.simulate(2000, fs=100.0, seed=6))
    # appending a term leaves the earlier terms' samples unchanged (one child seed per term)
    base = NoiseModel((White(N=0.01),)).simulate(2000, fs=100.0, seed=5)
    extra = NoiseModel((White(N=0.01), White(N=0.0))).simulate(2000, fs=100.0, seed=5)
    assert np.array_equal(base, extra)


def test_output_kinds_are_consistent():
    rate = EVERY_TERM.simulate(3000, fs=50.0, seed=2, n_channels=2)
    inc = EVERY_TERM.simulate(3000, fs=50.0, seed=2, n_channels=2, output="increment")
    angle = EVERY_TERM.simulate(3000, fs=50.0, seed=2, n_channels=2, output="angle")
    np.testing.assert_allclose(inc, rate / 50.0, rtol=1e-15)
    np.testing.assert_allclose(angle, np.cumsum(rate, axis=0) / 50.0, rtol=1e-9, atol=1e-12)


def test_angle_is_summed_without_rounding_drift():
    # a large turn-on bias under small white noise: the naive running sum drifts, the
    # compensated one stays within one rounding of the exact (math.fsum) sum
    import math

    model = NoiseModel((TurnOnBias(sigma=1e3), White(N=1e-4)))
    rate = model.simulate(20_000, fs=100.0, seed=4)
    angle = model.simulate(20_000, fs=100.0, seed=4, output="angle")
    exact = np.array([math.fsum(rate[: k + 1]) for k in range(0, 20_000, 997)]) / 100.0
    np.testing.assert_allclose(angle[::997], exact, rtol=2.3e-16, atol=0)


def test_duration_and_single_channel_shape():
    x = simulate([White(N=1.0)], fs=10.0, duration="1.5min", seed=1)
    assert x.shape == (900,)


def test_spectral_synthesis_reproduces_the_exact_flicker_avar():
    term = Flicker(B=1.0)
    n = 1 << 15
    m = np.unique(np.round(np.logspace(0, np.log10(n / 10), 25)))
    expected = expected_avar(lambda f: term.psd_sampled(f, 1.0), m, 1.0, n)
    # the line sum is the exact integral up to the missing lowest lines (< 0.1% at T/10)
    np.testing.assert_allclose(expected, term.avar(m, 1.0), rtol=1e-3)


def test_streamed_flicker_holds_its_plateau_over_three_decades():
    fs, n, channels, B = 100.0, (1 << 21) + 1, 2, 1e-3
    stream = flicker_stream(Flicker(B=B), fs, channels, seed=9, n_samples=n, method="bank")
    x = np.concatenate([stream.next(1 << 20) for _ in range(n >> 20)] + [stream.next(1)])
    m = np.unique(np.round(np.logspace(np.log10(30), np.log10(30_000), 13))).astype(np.int64)
    result = allanite.avar(x, fs=fs, m=m, alpha=-1)
    tau = result.tau
    # the bank's exact Allan variance is the 0.664 B plateau within 1% over these 3 decades
    exact = bank_avar(tau, 1.0 / fs, B, n_samples=n)
    np.testing.assert_allclose(exact / (PLATEAU * B**2), 1.0, atol=0.01)
    # and the streamed record agrees with it within the pooled 99% chi-square band
    edf = result.edf.sum(axis=1)
    pooled = (result.var * result.edf).sum(axis=1) / edf
    lo = pooled * edf / stats.chi2.ppf(0.995, edf)
    hi = pooled * edf / stats.chi2.ppf(0.005, edf)
    assert np.all((lo <= exact) & (exact <= hi)), np.sqrt(pooled / PLATEAU) / B


@pytest.mark.parametrize(("f0", "n", "method"), [(None, 1 << 22, "auto"), (2.5, 1 << 20, "bank")])
def test_long_streamed_flicker_has_the_term_avar_from_the_first_tau(f0, n, method):
    # 2^22 samples (> SPECTRAL_MAX_SAMPLES: auto streams the bank + FIR generator; with a
    # cutoff f0 = fs/4 the bank also goes through its low-pass); every tau from dt to n/16
    # inside the 99.9% chi-square band (EDF of the estimate) of Flicker.avar, which the law of
    # the generator equals (test_sim_terms); the band at tau = dt is +-0.3% (2^22 samples)
    fs, B = 10.0, 2e-3
    term = Flicker(B=B, f0=f0)
    stream = flicker_stream(term, fs, 1, seed=2024, n_samples=n, method=method)
    x = np.concatenate([stream.next(1 << 20) for _ in range(n >> 20)])
    m = np.unique(np.round(np.logspace(0, np.log10(n / 16), 16))).astype(np.int64)
    result = allanite.avar(x, fs=fs, m=m, alpha=-1)
    edf = result.edf[:, 0]
    exact = term.avar(result.tau, 1.0 / fs)
    lo = result.var[:, 0] * edf / stats.chi2.ppf(0.9995, edf)
    hi = result.var[:, 0] * edf / stats.chi2.ppf(0.0005, edf)
    assert np.all((lo <= exact) & (exact <= hi)), result.var[:, 0] / exact


@pytest.mark.parametrize("f0", [None, 20.0])
def test_streaming_flicker_bank_is_chunk_independent(f0):
    def make():
        return flicker_stream(Flicker(B=1.0, f0=f0), 100.0, 3, seed=21, method="bank")

    whole = make().next(3 * 70_001)
    stream = make()
    pieces = [stream.next(size) for size in (1, 65_535, 70_000, 3 * 70_001 - 135_536)]
    assert np.array_equal(np.concatenate(pieces), whole)
