"""Excess (non-Gaussian) variance of the overlapping AVAR estimate: oracles and Monte Carlo.

(1) The O(n) site sums against the brute-force quadratic form: the estimator's matrix B is
    built from the reference implementation on unit vectors, the responses of the record to
    one innovation are written out sample by sample, the jump position is integrated on a fine
    Gauss-Legendre grid (n = 64, every averaging factor class, record edges included).
(2) The variance identity itself on an exhaustively enumerated record (3^8 spike patterns).
(3) Predicted variance of the estimate = exact Gaussian part (from the covariance matrix of the
    samples, an independent route) + excess, against the Monte Carlo variance of 1000 records
    of 2^14 samples, within 4 Monte Carlo standard errors of a variance,
    SE^2 = (mu_4 - s^4 (R-3)/(R-1)) / R.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import signal

import allanite
from allanite.model import NoiseModel
from allanite.terms import (
    BiasSteps,
    Flicker,
    GaussMarkov,
    Sine,
    Spikes,
    Telegraph,
    White,
)
from allanite.terms._estimator_kurtosis import (
    iid_excess_variance,
    step_excess_variance,
    telegraph_excess_variance,
)
from allanite.variance import oracle

DT = 0.01
GRID_X, GRID_W = np.polynomial.legendre.leggauss(32)
V, VW = (GRID_X + 1.0) / 2.0, GRID_W / 2.0  # jump position v in (0, 1), weights


def estimator_matrix(n: int, m: int) -> np.ndarray:
    """B with Q(y) = y' B y, from the reference overlapping variance of unit vectors."""
    columns = []
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1.0
        columns.append(oracle._d2(oracle.phase_from_record(e), m) / m)
    h = np.array(columns).T  # (M, n): second differences of window means
    b = h.T @ h / (2.0 * h.shape[0])
    y = np.random.default_rng(m).standard_normal(n)
    assert y @ b @ y == pytest.approx(
        oracle.overlapping_variance(oracle.phase_from_record(y), m), rel=1e-12
    )
    return b


N_SMALL = 64
FACTORS = [1, 3, 8, 20, 32]


@pytest.mark.parametrize("m", FACTORS)
def test_iid_against_quadratic_form(m):
    b = estimator_matrix(N_SMALL, m)
    kappa = 0.7
    brute = kappa * np.sum(np.diag(b) ** 2)
    got = iid_excess_variance(m * DT, DT, N_SMALL, kappa)
    assert got == pytest.approx(brute, rel=1e-12)


@pytest.mark.parametrize("m", FACTORS)
def test_steps_against_quadratic_form(m):
    b = estimator_matrix(N_SMALL, m)
    total = 0.0
    for i in range(N_SMALL):  # a step at fraction 1 - v of sample i: v in sample i, 1 after
        response = np.zeros((V.size, N_SMALL))
        response[:, i] = V
        response[:, i + 1 :] = 1.0
        d = np.einsum("kj,jl,kl->k", response, b, response)
        total += VW @ d**2
    rate, fourth = 3.0, 2.0
    got = step_excess_variance(m * DT, DT, N_SMALL, rate, fourth)
    assert got == pytest.approx(rate * DT * fourth * total, rel=1e-11)


@pytest.mark.parametrize("m", [1, 8, 32])
@pytest.mark.parametrize("tau_c", [0.004, 0.05, 0.5])
def test_telegraph_against_quadratic_form(m, tau_c):
    """-16 a^4 lambda sum_z D (D + 2E), D = g'Bg, E = g'Bf (forward / backward responses)."""
    b = estimator_matrix(N_SMALL, m)
    theta = DT / tau_c
    phi = math.exp(-theta)

    def own_and_next(v):
        return -np.expm1(-v * theta) / theta, np.exp(-v * theta) * -math.expm1(-theta) / theta

    alpha, beta = own_and_next(V)
    alpha_back, beta_back = own_and_next(1.0 - V)
    past = int(45.0 / theta)  # phi^past < 1e-19: earlier switches do not matter
    site = np.arange(-past, N_SMALL)[:, None, None]  # (sites, 1, 1) x (nodes) x (samples j)
    j = np.arange(N_SMALL)[None, None, :]
    lag = (j - site - 1).astype(float)
    # sample j's mean after a unit jump at (site, v), and before it (the mirror image)
    forward = np.where(j == site, alpha[:, None], 0.0) + np.where(
        j > site, beta[:, None] * phi ** np.maximum(lag, 0.0), 0.0
    )
    backward = np.where(j == site, alpha_back[:, None], 0.0) + np.where(
        j < site, beta_back[:, None] * phi ** np.maximum(-lag - 2.0, 0.0), 0.0
    )
    d = np.einsum("skj,jl,skl->sk", forward, b, forward)
    e = np.einsum("skj,jl,skl->sk", forward, b, backward)
    total = float(np.sum((d * (d + 2.0 * e)) @ VW))
    a = 0.3
    expected = -16.0 * a**4 * DT / (2.0 * tau_c) * total
    got = telegraph_excess_variance(m * DT, DT, N_SMALL, a, tau_c)
    assert got == pytest.approx(expected, rel=1e-10)


def test_variance_identity_by_enumeration():
    """Var Q = 2 s^4 tr(B^2) + kappa_4 sum B_ii^2, exactly, over all 3^8 spike records."""
    n, amplitude, p = 8, 1.5, 0.2
    for m in (1, 2, 3):
        b = estimator_matrix(n, m)
        values = np.array([-amplitude, 0.0, amplitude])
        probs = np.array([p / 2, 1 - p, p / 2])
        records = np.array(list(itertools.product(range(3), repeat=n)))
        y = values[records]
        weight = np.prod(probs[records], axis=1)
        q = np.einsum("rj,jl,rl->r", y, b, y)
        mean = weight @ q
        variance = weight @ (q - mean) ** 2
        s2 = p * amplitude**2
        gaussian = 2.0 * s2**2 * np.trace(b @ b)
        excess = Spikes(amplitude=amplitude, rate=-math.log(1 - p) / DT).avar_excess_variance(
            m * DT, DT, n
        )
        assert mean == pytest.approx(s2 * np.trace(b), rel=1e-12)
        assert variance == pytest.approx(gaussian + excess, rel=1e-10)


# --- Monte Carlo: predicted variance of the estimate --------------------------------------------
FS, N, RECORDS = 1.0 / DT, 1 << 14, 1000


def gaussian_part(m: int, n: int, sigma_h0) -> float:
    """2 c^2 sum_{h,k} Cov(d_h, d_k)^2 for stationary differences; sigma_h0 = Sigma h_0."""
    terms = n - 2 * m + 1
    w = np.r_[np.full(m, -1.0 / m), np.full(m, 1.0 / m)]
    cov = signal.correlate(sigma_h0(n, m, w), w, mode="valid", method="fft")[:terms]
    k = np.arange(1, terms)
    return (
        2.0 / (2.0 * terms) ** 2 * (terms * cov[0] ** 2 + 2.0 * np.sum((terms - k) * cov[1:] ** 2))
    )


def white_h0(variance):
    return lambda n, m, w: variance * np.r_[w, np.zeros(n - 2 * m)]


def steps_h0(increment_variance):
    """Sample means of a compound-Poisson walk from 0.

    Cov(y_i, y_j) = q (min(i, j) + 1/2 - [i = j]/6).
    """

    def product(n, m, w):
        s = np.arange(2 * m)
        j = np.arange(2 * m)[:, None]  # rows j >= 2m equal row 2m - 1 minus the diagonal term
        sigma = np.minimum(j, s[None, :]) + 0.5 - (j == s[None, :]) / 6.0
        head = sigma @ w
        tail = np.full(n - 2 * m, (np.minimum(2 * m, s) + 0.5) @ w)
        return increment_variance * np.r_[head, tail]

    return product


def telegraph_h0(amplitude, tau_c):
    """Autocovariance of sample means of exp(-|t|/Tc): r_0 = 2a^2(theta-1+phi)/theta^2, ..."""
    theta = DT / tau_c
    phi = math.exp(-theta)

    def product(n, m, w):
        lag = np.abs(np.arange(-(2 * m - 1), n))  # lags j - s of rows j, columns s < 2m
        r0 = 2.0 * amplitude**2 * (theta - 1.0 + phi) / theta**2
        rk = amplitude**2 * (1.0 - phi) ** 2 * phi ** (np.maximum(lag, 1) - 1.0) / theta**2
        covariance = np.where(lag == 0, r0, rk)
        return signal.fftconvolve(covariance, w)[2 * m - 1 : 2 * m - 1 + n]

    return product


def _monte_carlo(term, seed):
    model = NoiseModel((term,))
    est = []
    for block in range(RECORDS // 50):
        x = model.simulate(N, fs=FS, n_channels=50, seed=1000 * seed + block)
        result = allanite.avar(x, fs=FS, taus="octave", alpha=0)
        est.append(result.var)
    keep = result.tau <= N * DT / 10.0
    return result.m[keep], result.tau[keep], np.concatenate(est, axis=1)[keep]


CASES = {
    "spikes": (
        Spikes(amplitude=1.0, rate=0.5),
        white_h0(Spikes(amplitude=1.0, rate=0.5).probability(DT)),
    ),
    "steps": (BiasSteps(size=0.01, interval=5.0), steps_h0(0.01**2 * DT / 5.0)),
    "telegraph": (Telegraph(amplitude=0.01, tau_c=0.3), telegraph_h0(0.01, 0.3)),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CASES))
def test_predicted_variance_against_monte_carlo(name):
    term, sigma_h0 = CASES[name]
    m, tau, est = _monte_carlo(term, seed=sum(map(ord, name)))
    predicted = np.array([gaussian_part(int(k), N, sigma_h0) for k in m])
    predicted += term.avar_excess_variance(tau, DT, N)
    records = est.shape[1]
    variance = est.var(axis=1, ddof=1)
    mu4 = np.mean((est - est.mean(axis=1, keepdims=True)) ** 4, axis=1)
    se = np.sqrt((mu4 - variance**2 * (records - 3) / (records - 1)) / records)
    z = (variance - predicted) / se
    assert np.all(np.abs(z) < 4.0), f"{name}: z = {np.round(z, 2)}"
    # the Gaussian part alone is far off where the events are few (the test can fail)
    gaussian_only = predicted - term.avar_excess_variance(tau, DT, N)
    assert np.abs((variance[0] - gaussian_only[0]) / se[0]) > 10.0


# --- the public pieces ----------------------------------------------------------------------------
def test_gaussian_terms_have_no_excess():
    tau = np.array([0.01, 0.1, 1.0])
    for term in (
        White(N=1e-3),
        Flicker(B=1e-3),
        GaussMarkov(sigma=1e-2, tau_c=1.0),
        Sine(1e-3, 3.0),
    ):
        np.testing.assert_array_equal(term.avar_excess_variance(tau, DT, 1000), 0.0)


def test_model_sums_terms():
    terms = (White(N=1e-3), Spikes(amplitude=0.5, rate=1.0), Telegraph(amplitude=0.01, tau_c=0.2))
    tau = np.array([0.01, 0.04, 0.32])
    total = NoiseModel(terms).avar_excess_variance(tau, DT, 4096)
    parts = sum(t.avar_excess_variance(tau, DT, 4096) for t in terms)
    np.testing.assert_allclose(total, parts, rtol=1e-15)


def test_telegraph_excess_sign():
    """A Poisson count of switches at tau << Tc; lighter than Gaussian at tau >> Tc."""
    term = Telegraph(amplitude=1.0, tau_c=1.0)
    excess = term.avar_excess_variance(np.array([0.01, 20.0]), DT, 100_000)
    assert excess[0] > 0 > excess[1]


def test_with_excess_variance_formula():
    rng = np.random.default_rng(3)
    result = allanite.avar(rng.standard_normal((4096, 3)), fs=FS, taus="octave", alpha=0)
    gaussian = np.full(result.tau.shape, 2.0)
    excess = np.linspace(0.0, 1.0, result.tau.size)
    corrected = result.with_excess_variance(excess, gaussian)
    want = result.edf * (gaussian / (gaussian + excess))[:, None]
    np.testing.assert_allclose(corrected.edf, want, rtol=1e-14)
    assert corrected.edf[0, 0] == result.edf[0, 0]  # zero excess: Greenhall unchanged
    lo, hi = corrected.var_ci(0.95)
    lo0, hi0 = result.var_ci(0.95)
    assert np.all(hi[1:] - lo[1:] > hi0[1:] - lo0[1:])  # wider bands
    single = result.channel(1).with_excess_variance(excess, gaussian)
    np.testing.assert_allclose(single.edf, want[:, 1], rtol=1e-14)
    negative = result.with_excess_variance(-0.5 * gaussian, gaussian)  # lighter than Gaussian
    np.testing.assert_allclose(negative.edf, 2.0 * result.edf, rtol=1e-14)


def test_with_model_edf():
    """The model's excess and Gaussian variance; a Gaussian model leaves the EDF as it is."""
    model = NoiseModel((White(N=1e-3), Telegraph(amplitude=1e-3, tau_c=0.2)))
    x = model.simulate(4096, fs=FS, n_channels=2, seed=8)
    result = allanite.avar(x, fs=FS, taus="octave")
    corrected = result.with_model_edf(model)
    excess = model.avar_excess_variance(result.tau, DT, 4096)
    gaussian = model.avar_gaussian_variance(result.tau, DT, 4096)
    np.testing.assert_allclose(
        corrected.edf, result.edf * (gaussian / (gaussian + excess))[:, None], rtol=1e-14
    )
    plain = result.with_model_edf(NoiseModel((White(N=1e-3),)))
    np.testing.assert_array_equal(plain.edf, result.edf)
    # angle input: n_samples angle points are n_samples - 1 rate samples
    angle = allanite.avar(np.cumsum(x, axis=0) * DT, fs=FS, input="angle", taus="octave")
    excess_angle = model.avar_excess_variance(angle.tau, DT, 4095)
    gaussian_angle = model.avar_gaussian_variance(angle.tau, DT, 4095)
    np.testing.assert_allclose(
        angle.with_model_edf(model).edf,
        angle.edf * (gaussian_angle / (gaussian_angle + excess_angle))[:, None],
        rtol=1e-14,
    )


@pytest.mark.parametrize("name", sorted(CASES))
def test_gaussian_variance_against_covariance_oracle(name):
    """FFT of the sampled PSD vs the covariance matrix of the samples (independent routes)."""
    term, sigma_h0 = CASES[name]
    m = np.array([1, 4, 64, 1024])
    got = NoiseModel((term,)).avar_gaussian_variance(m * DT, DT, N)
    want = [gaussian_part(int(k), N, sigma_h0) for k in m]
    np.testing.assert_allclose(got, want, rtol=1e-9)


def test_gaussian_variance_needs_spectra():
    from allanite.terms import WarmUp

    model = NoiseModel((White(N=1e-3), WarmUp(amplitude=0.1, tau_w=10.0, duration=40.0)))
    with pytest.raises(ValueError, match="warmup"):
        model.avar_gaussian_variance([0.01], DT, 4000)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"excess": np.zeros(3)}, "shape"),
        ({"gaussian": -1.0}, "positive"),
        ({"excess": -2.0}, "positive"),
        ({"excess": np.nan}, "finite"),
    ],
)
def test_with_excess_variance_bad_input(kwargs, message):
    result = allanite.avar(
        np.random.default_rng(5).standard_normal(2048), fs=FS, taus="octave", alpha=0
    )
    args = {"excess": np.zeros(result.tau.size), "gaussian": np.ones(result.tau.size), **kwargs}
    with pytest.raises(ValueError, match=message):
        result.with_excess_variance(**args)


def test_with_excess_variance_needs_overlapping():
    result = allanite.avar(np.random.default_rng(6).standard_normal(2048), fs=FS, kind="modified")
    with pytest.raises(ValueError, match="overlapping"):
        result.with_excess_variance(np.zeros(result.tau.size), np.ones(result.tau.size))


@pytest.mark.parametrize(
    ("tau", "n", "message"),
    [(0.015, 1000, "whole multiples"), (0.01, 1.5, "integer"), (-0.01, 1000, "positive")],
)
def test_excess_bad_input(tau, n, message):
    with pytest.raises(ValueError, match=message):
        Spikes(amplitude=1.0, rate=1.0).avar_excess_variance(tau, DT, n)


def test_excess_nan_beyond_half_record():
    got = BiasSteps(size=1.0, interval=1.0).avar_excess_variance([0.01, 0.6], DT, 100)
    assert np.isfinite(got[0])
    assert np.isnan(got[1])


@pytest.mark.filterwarnings("error")
def test_long_windows_fast_relaxation_finite():
    """m dt >> Tc (phi^m underflows, no overflow on the way) and Tc >> record."""
    tau = np.array([0.01, 10.0, 50.0])
    for tau_c in (0.01, 1e4):
        term = Telegraph(amplitude=1.0, tau_c=tau_c)
        excess = term.avar_excess_variance(tau, DT, 20_000)
        gaussian = NoiseModel((term,)).avar_gaussian_variance(tau, DT, 20_000)
        assert np.all(np.isfinite(excess))
        assert np.all(gaussian + excess > 0)


def test_telegraph_slow_switching_limit_is_poisson_steps():
    """Tc -> inf: the backward response is minus the forward one, the excess that of steps of
    +-2a at rate 1/(2 Tc); the difference shrinks like tau / Tc (about 3 tau / Tc)."""
    tau = np.array([0.01, 0.1, 1.0, 10.0])
    for tau_c in (1e4, 1e6):
        telegraph = telegraph_excess_variance(tau, DT, 20_000, 1.0, tau_c)
        steps = step_excess_variance(tau, DT, 20_000, 1.0 / (2.0 * tau_c), 16.0)
        assert np.all(np.abs(telegraph / steps - 1.0) < 4.0 * tau / tau_c)
