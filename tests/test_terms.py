"""Noise terms: exact sampled Allan variances against brute force, PSD consistency, JSON."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import integrate

import allanite
from allanite.terms import (
    TERM_TYPES,
    Flicker,
    GaussMarkov,
    Quantization,
    RateRamp,
    RateRandomWalk,
    Sine,
    White,
    term_from_dict,
)

DT = 0.01
M = np.array([1, 2, 3, 5, 8, 16, 50, 128])


def avar_from_autocovariance(acov, m: int) -> float:
    """Allan variance of a stationary sequence from its autocovariance R(l), l = 0..2m."""
    lags = np.arange(-(m - 1), m)
    w = m - np.abs(lags)
    return float(np.sum(w * (acov(np.abs(lags)) - acov(np.abs(m + lags)))) / m**2)


def test_white_quantization_ramp_closed_forms():
    tau = M * DT
    assert np.allclose(White(N=0.3).avar(tau, DT), 0.09 / tau)
    assert np.allclose(Quantization(Q=0.2).avar(tau, DT), 3 * 0.04 / tau**2)
    assert np.allclose(RateRamp(R=0.5).avar(tau, DT), 0.125 * tau**2)


def test_quantization_matches_brute_force_second_difference():
    # rate = (e_k - e_{k-1})/dt: the block-mean difference is (e_{k+2m} - 2 e_{k+m} + e_k)/tau
    q = 0.2
    for m in M:
        weights = np.array([1.0, -2.0, 1.0]) / (m * DT)
        expected = 0.5 * q**2 * float(np.sum(weights**2))
        assert math.isclose(Quantization(Q=q).avar(m * DT, DT)[()], expected, rel_tol=1e-12)


def test_rrw_exact_sampled_form_matches_triangle_weights():
    k = 0.7
    for m in M:
        w = np.concatenate([np.arange(1, m + 1), np.arange(m - 1, 0, -1)]) / m
        expected = 0.5 * k**2 * DT * float(np.sum(w**2))
        assert math.isclose(RateRandomWalk(K=k).avar(m * DT, DT)[()], expected, rel_tol=1e-12)
    tau = np.array([10.0, 100.0])
    assert np.allclose(RateRandomWalk(K=k).avar(tau, DT), k**2 * tau / 3, rtol=1e-4)


def test_markov_exact_sampled_form_matches_autocovariance():
    gm = GaussMarkov(sigma=1.3, tau_c=0.07)
    phi = math.exp(-DT / gm.tau_c)
    for m in M:
        expected = avar_from_autocovariance(lambda lag: gm.sigma**2 * phi**lag, int(m))
        assert math.isclose(gm.avar(m * DT, DT)[()], expected, rel_tol=1e-9)


def test_markov_peak_and_ar1_constructor():
    gm = GaussMarkov(sigma=1.0, tau_c=10.0)
    tau = np.geomspace(1, 100, 4001)
    adev = np.sqrt(gm.avar(tau, 0.001))
    assert math.isclose(tau[np.argmax(adev)] / gm.tau_c, 1.89, rel_tol=0.01)
    assert math.isclose(adev.max(), 0.617, rel_tol=0.01)
    back = GaussMarkov.from_ar1(0.99, 1e-4, 0.01)
    assert math.isclose(math.exp(-0.01 / back.tau_c), 0.99)
    assert math.isclose(back.sigma**2 * (1 - 0.99**2), 1e-4)


def test_sine_exact_sampled_form_matches_phase_average():
    s = Sine(amplitude=2.0, frequency=3.3)
    phases = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    for m in M:
        k = np.arange(2 * m)
        y = s.amplitude * np.sin(2 * np.pi * s.frequency * k[None, :] * DT + phases[:, None])
        d = y[:, m:].mean(axis=1) - y[:, :m].mean(axis=1)
        expected = 0.5 * float(np.mean(d**2))
        assert math.isclose(s.avar(m * DT, DT)[()], expected, rel_tol=1e-9, abs_tol=1e-15)


def test_sine_aliasing_is_included():
    fs = 1 / DT
    a = Sine(1.0, 3.3).avar(M * DT, DT)
    assert np.allclose(Sine(1.0, 3.3 + fs).avar(M * DT, DT), a)
    assert np.allclose(Sine(1.0, fs - 3.3).avar(M * DT, DT), a)
    assert np.all(Sine(1.0, fs).avar(M * DT, DT) == 0.0)


def test_flicker_plateau_and_cutoff():
    fl = Flicker(B=1.0, f0=5.0)
    assert math.isclose(fl.avar(1e4, DT)[()], 2 * math.log(2) / math.pi, rel_tol=1e-4)
    assert math.isclose(math.sqrt(fl.avar(1e4, DT)[()]), 0.664, rel_tol=1e-3)
    assert Flicker(B=1.0).cutoff(DT) == 50.0


@pytest.mark.parametrize(
    "term",
    [
        White(N=0.3),
        Quantization(Q=0.01),
        Flicker(B=0.2),
        Flicker(B=0.2, f0=10.0),
        RateRandomWalk(K=0.05),
        GaussMarkov(sigma=0.4, tau_c=0.05),
    ],
    ids=lambda t: repr(t),
)
def test_avar_is_integral_of_sampled_psd(term):
    """avar(m dt) = int_0^{fs/2} 2 sin^4(pi f m dt)/(m sin(pi f dt))^2 S(f) df."""
    for m in (1, 2, 7, 20):

        def integrand(f, m=m):
            h2 = 2 * np.sin(np.pi * f * m * DT) ** 4 / (m * np.sin(np.pi * f * DT)) ** 2
            return h2 * term.psd_sampled(f, DT)

        edges = np.linspace(0, 0.5 / DT, 8 * m + 1)
        brk = [] if not isinstance(term, Flicker) or term.f0 is None else [term.f0]
        pts = np.unique(np.concatenate([edges, brk]))
        total = sum(
            integrate.quad(integrand, a, b, limit=200, epsabs=0, epsrel=1e-10)[0]
            for a, b in itertools.pairwise(pts)
        )
        assert math.isclose(term.avar(m * DT, DT)[()], total, rel_tol=1e-6), m


def test_continuous_psd_limits():
    f = np.array([0.01, 0.1])
    assert np.allclose(White(1.0).psd(f), 2.0)
    assert np.allclose(RateRandomWalk(1.0).psd(f), 1 / (2 * np.pi**2 * f**2))
    gm = GaussMarkov(1.0, 2.0)
    assert np.allclose(gm.psd_sampled(f, 1e-4), gm.psd(f), rtol=1e-3)
    with pytest.raises(NotImplementedError):
        RateRamp(1.0).psd(f)


def test_json_round_trip_and_registry():
    for kind in ("white", "quantization", "flicker", "rrw", "ramp", "markov", "sine"):
        assert kind in TERM_TYPES
    t = term_from_dict({"type": "flicker", "B": 0.1, "f0": 3.0})
    assert t == Flicker(0.1, 3.0)
    assert term_from_dict(t.to_dict()) == t
    assert Flicker(0.1).to_dict() == {"type": "flicker", "B": 0.1}


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ({"type": "pink", "B": 1}, "unknown term type"),
        ({"type": "white"}, "missing"),
        ({"type": "white", "N": 1, "Q": 2}, "unexpected"),
        ({"B": 1}, "'type' field"),
    ],
)
def test_bad_term_dicts(data, match):
    with pytest.raises(ValueError, match=match):
        term_from_dict(data)


def test_bad_parameter_values():
    with pytest.raises(ValueError, match="non-negative"):
        White(N=-1.0)
    with pytest.raises(ValueError, match="non-negative"):
        RateRandomWalk(K=float("nan"))
    with pytest.raises(ValueError, match="positive"):
        GaussMarkov(sigma=1.0, tau_c=0.0)
    with pytest.raises(TypeError, match="number"):
        term_from_dict({"type": "white", "N": "big"})
    with pytest.raises(ValueError, match="dt"):
        White(1.0).avar([1.0], 0.0)
    with pytest.raises(ValueError, match="tau"):
        White(1.0).avar([-1.0], 0.1)


def test_guesses_from_a_curve():
    rng = np.random.default_rng(1)
    x = rng.standard_normal(20000) * 0.5 / math.sqrt(DT)
    res = allanite.avar(x, fs=1 / DT, taus="octave")
    g = White.guess(res)
    assert g is not None
    assert 0.4 < g.N <= 0.6
    assert GaussMarkov.guess(res) is None or GaussMarkov.guess(res).sigma > 0
    gm = GaussMarkov(sigma=1.0, tau_c=1.0)
    tau = np.geomspace(0.01, 100, 60)
    fake = res.__class__(
        tau=tau,
        m=np.round(tau / DT).astype(np.int64),
        var=gm.avar(tau, DT),
        kind="overlapping",
        n_terms=np.ones(60, dtype=np.int64),
        edf=np.ones(60),
        alpha=np.zeros(60, dtype=np.int64),
        fs=1 / DT,
        input="rate",
        n_samples=10**6,
    )
    guess = GaussMarkov.guess(fake)
    assert guess is not None
    assert math.isclose(guess.tau_c, 1.0, rel_tol=0.1)
    assert math.isclose(guess.sigma, 1.0, rel_tol=0.05)
