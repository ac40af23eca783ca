"""Simulated records match each term's exact sampled Allan variance (50 seeds at once).

Every stochastic term alone and mixtures: the 95% chi-square band of every (channel, tau)
estimate must contain the theory for 90-99% of the pairs (tau from dt to T/10). The EDF is the
one allanite.avar attaches (Greenhall-Riley with identified noise type), scaled by the model's
ratio of the Gaussian to the full variance of the estimate (AllanResult.with_model_edf, from
NoiseModel.avar_gaussian_variance and avar_excess_variance): one for Gaussian terms; for the
heavy-tailed ones (spikes, bias steps, telegraph noise) the excess from their fourth cumulants,
as their estimate at short tau is essentially a Poisson count of events. Their parameters give
about 80 spikes, 33 steps and 270 switches per record: enough events for a chi-square band to
describe the estimate (with fewer than ~10 events per record the estimate has an atom at zero
and no chi-square band can cover it). A deterministic sine: the Monte Carlo mean over the 50
channels must agree with the theory within its standard error (|z| < 4 at every tau); ramp and
warm-up exactly.
"""

from __future__ import annotations

import numpy as np
import pytest

import allanite
from allanite.model import NoiseModel
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

FS = 100.0
DT = 1.0 / FS
N = 1 << 14
CHANNELS = 50


def _estimate(terms, seed, *, n=N, alpha=None):
    model = NoiseModel(tuple(terms))
    x = model.simulate(n, fs=FS, n_channels=CHANNELS, seed=seed)
    result = allanite.avar(x, fs=FS, taus="octave", alpha=alpha)
    keep = result.tau <= n * DT / 10.0
    return model, result, keep


def _coverage(model, result, keep):
    theory = model.avar(result.tau[keep], DT)[:, None]
    lo, hi = result.var_ci(0.95)
    return ((lo[keep] <= theory) & (theory <= hi[keep])).mean()


GAUSSIAN = {
    "white": [White(N=0.01)],
    "quantization": [Quantization(Q=1e-3)],
    "flicker": [Flicker(B=1e-3)],
    "rrw": [RateRandomWalk(K=1e-3)],
    "markov": [GaussMarkov(sigma=0.01, tau_c=0.5)],
    "lowpass_narrow": [LowPassWhite(N=0.01, bandwidth=2.0)],
    "lowpass_wide": [LowPassWhite(N=0.01, bandwidth=200.0)],
    "ieee_mix": [Quantization(Q=2e-4), White(N=3e-3), Flicker(B=1e-3), RateRandomWalk(K=2e-4)],
    "markov_sine_mix": [White(N=2e-3), GaussMarkov(sigma=5e-3, tau_c=2.0), Sine(1e-3, 7.0)],
}


NON_GAUSSIAN = {
    "telegraph": [Telegraph(amplitude=0.01, tau_c=0.3)],
    "steps": [BiasSteps(size=0.01, interval=5.0)],
    "spikes": [Spikes(amplitude=1.0, rate=0.5)],
    "transient_mix": [
        White(N=2e-3),
        Telegraph(amplitude=5e-3, tau_c=1.0),
        Spikes(amplitude=0.2, rate=0.5),
    ],
}


@pytest.mark.parametrize("name", sorted(GAUSSIAN) + sorted(NON_GAUSSIAN))
def test_chi_square_coverage(name):
    terms = GAUSSIAN[name] if name in GAUSSIAN else NON_GAUSSIAN[name]
    model, result, keep = _estimate(terms, seed=sum(map(ord, name)))
    corrected = result.with_model_edf(model)
    coverage = _coverage(model, corrected, keep)
    assert 0.90 <= coverage <= 0.99, f"{name}: coverage {coverage:.3f}"
    if name in GAUSSIAN:  # no excess: the Greenhall-Riley EDF as it is
        np.testing.assert_array_equal(corrected.edf, result.edf)
    else:  # the Gaussian EDF alone does not describe these estimates
        assert _coverage(model, result, keep) < 0.90


def test_monte_carlo_mean_sine():
    # deterministic up to the phase: its estimates are not chi-square; alpha given, not used
    model, result, keep = _estimate([Sine(amplitude=0.01, frequency=3.3)], seed=431, alpha=0)
    theory = model.avar(result.tau[keep], DT)
    est = result.var[keep]
    z = (est.mean(axis=1) - theory) / (est.std(axis=1, ddof=1) / np.sqrt(CHANNELS))
    assert np.all(np.abs(z) < 4.0), f"sine: z = {np.round(z, 2)}"


def test_ramp_is_exact():
    model, result, keep = _estimate([RateRamp(R=1e-3)], seed=1, alpha=0)
    np.testing.assert_allclose(
        result.var[keep],
        np.repeat(model.avar(result.tau[keep], DT)[:, None], CHANNELS, 1),
        rtol=1e-6,
    )


def test_warmup_is_exact():
    term = WarmUp(amplitude=0.5, tau_w=20.0, duration=N * DT)
    _, result, keep = _estimate([term], seed=1, alpha=0)
    np.testing.assert_allclose(result.var[keep, 0], term.avar(result.tau[keep], DT), rtol=1e-6)


def test_turn_on_bias_constant_per_run():
    sigma = 0.2
    x = NoiseModel((TurnOnBias(sigma=sigma),)).simulate(1000, fs=FS, n_channels=400, seed=5)
    assert np.all(x == x[0])  # constant within each run
    sample_var = x[0].var(ddof=1)
    # chi-square 99.9% band of the sample variance of 400 normal draws
    from scipy import stats

    lo, hi = stats.chi2.ppf([0.0005, 0.9995], 399) / 399
    assert lo * sigma**2 <= sample_var <= hi * sigma**2
    result = allanite.avar(x[:, :3], fs=FS, taus="octave", alpha=0)
    assert np.all(result.var < 1e-20)
