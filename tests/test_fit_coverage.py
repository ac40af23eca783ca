"""Coverage of the fitted 95 % intervals and false inclusions of ``terms="auto"``, 200 seeds.

Each scenario simulates 200 independent records (200 channels of one array, exact test
generator in ``fit_generator.py``), fits every channel and counts how often the nominal 95 %
interval contains the true coefficient. With 200 seeds the count of a calibrated interval is
Binomial(200, 0.95) (sd 1.5 %): the judged band 91-99 % is about +-2.7 sd.
"""

from __future__ import annotations

import pytest

import allanite
from allanite.model import NoiseModel
from allanite.terms import Flicker, GaussMarkov, Quantization, RateRamp, RateRandomWalk, White
from fit_generator import simulate

SEEDS = 200
DT = 0.01
UNITS = {"rate": "deg/s", "time": "s"}


def coverage(model: NoiseModel, terms: list[str], n: int, seed: int) -> dict[str, float]:
    truth = model.coefficients()
    x = simulate(model, n, DT, SEEDS, seed=seed)
    res = allanite.avar(x, fs=1 / DT, taus="octave", alpha=0, units="deg/s")
    hits = dict.fromkeys(truth, 0)
    for c in range(SEEDS):
        fitted = allanite.fit(res.channel(c), terms)
        for name, value in truth.items():
            lo, hi = fitted[name].ci(0.95)
            hits[name] += lo <= value <= hi
    return {k: v / SEEDS for k, v in hits.items()}


@pytest.mark.slow
def test_coverage_quantization_white_flicker_rrw():
    model = NoiseModel(
        (Quantization(Q=1e-3), White(N=0.02), Flicker(B=0.01), RateRandomWalk(K=2e-3)), UNITS
    )
    cov = coverage(model, ["Q", "N", "B", "K"], 2**13, seed=11)
    for name, frac in cov.items():
        assert 0.91 <= frac <= 0.99, (name, cov)


@pytest.mark.slow
def test_coverage_rate_ramp():
    model = NoiseModel((White(N=0.02), RateRamp(R=2e-4)), UNITS)
    cov = coverage(model, ["N", "R"], 2**13, seed=12)
    for name, frac in cov.items():
        assert 0.91 <= frac <= 0.99, (name, cov)


@pytest.mark.slow
def test_coverage_gauss_markov_sigma_and_correlation_time():
    model = NoiseModel((White(N=0.05), GaussMarkov(sigma=0.5, tau_c=1.0)), UNITS)
    cov = coverage(model, ["white", "markov"], 2**13, seed=13)
    for name, frac in cov.items():
        assert 0.91 <= frac <= 0.99, (name, cov)


@pytest.mark.slow
def test_auto_does_not_invent_absent_terms():
    """Quantization + white noise: B, K and R must stay out in >= 95 % of the records."""
    model = NoiseModel((Quantization(Q=1e-3), White(N=0.02)), UNITS)
    x = simulate(model, 2**13, DT, SEEDS, seed=14)
    res = allanite.avar(x, fs=1 / DT, taus="octave", alpha=0, units="deg/s")
    clean = found = 0
    for c in range(SEEDS):
        types = {t.type for t in allanite.fit(res.channel(c), "auto").model.terms}
        clean += types <= {"white", "quantization"}
        found += types >= {"white", "quantization"}
    assert clean / SEEDS >= 0.95
    assert found == SEEDS  # both present terms are strong here and always found
