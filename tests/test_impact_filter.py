"""Gyro-vertical complementary filter: design formulas and the Allan deviation of its output.

The simulated filter runs on K independent channels of white gyro and accelerometer noise;
Monte Carlo standard errors come from the spread over the channels (fixed seed).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import allanite
from allanite.impact import (
    ComplementaryFilter,
    complementary_filter_sigma,
    optimal_complementary_filter,
)
from allanite.model import NoiseModel
from allanite.terms import White

G = 9.80665
ARW = 2e-3  # rad/sqrt(s)
T_OPT = 1.0  # s
VRW = G * ARW * T_OPT  # m/s/sqrt(s)
FS = 100.0
DT = 1.0 / FS
N, K = 200_000, 8
Z = 4.0  # acceptance in Monte Carlo standard errors


@pytest.fixture(scope="module")
def simulated():
    filt = optimal_complementary_filter(ARW, VRW, dt=DT, g=G)
    # static stand (true rate and tilt 0): white gyro and accelerometer noise from the
    # simulation package (the accelerometer model's "rad/s" stands for m/s^2: only numbers)
    si = {"rate": "rad/s", "time": "s"}
    rate = NoiseModel((White(N=ARW),), si).simulate(N, fs=FS, n_channels=K, seed=20261121)
    accel = NoiseModel((White(N=VRW),), si).simulate(N, fs=FS, n_channels=K, seed=20261122)
    return filt, filt.apply(rate, accel)


def _mean_se(x):
    x = np.asarray(x)
    return x.mean(axis=-1), x.std(axis=-1, ddof=1) / math.sqrt(x.shape[-1])


def test_design_formulas():
    filt = optimal_complementary_filter(ARW, VRW, dt=DT, g=G)
    assert filt.time_constant == pytest.approx(VRW / (G * ARW))
    assert filt.sigma == pytest.approx(math.sqrt(ARW * VRW / G))
    assert filt.alpha == pytest.approx(VRW / (G * DT * ARW + VRW))
    # the optimum is a minimum of sigma(T) = sqrt((N^2 T + VRW^2/(T g^2))/2)
    grid = T_OPT * np.geomspace(0.2, 5.0, 201)
    sig = [complementary_filter_sigma(ARW, VRW, t, g=G) for t in grid]
    assert grid[int(np.argmin(sig))] == pytest.approx(T_OPT, rel=0.02)
    assert complementary_filter_sigma(ARW, VRW, 2 * T_OPT, g=G) > filt.sigma


def test_output_variance_matches_simulation(simulated):
    filt, out = simulated
    v = np.mean(out[1000:] ** 2, axis=0)  # skip the start-up transient (10 T)
    mean, se = _mean_se(v)
    assert abs(mean - filt.output_variance) < Z * se
    # the discrete optimum tends to the continuous sigma^2 = N VRW / g for T0 << T
    assert filt.output_variance == pytest.approx(filt.sigma**2, rel=2 * DT / T_OPT)


def test_angle_view_avar_matches_the_exact_form(simulated):
    filt, out = simulated
    taus = DT * np.array([1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048])
    res = allanite.avar(out, fs=FS, input="angle", taus=taus, alpha=0)
    mean, se = _mean_se(res.var)
    exact = filt.output_avar(res.tau)
    assert np.all(np.abs(mean - exact) < Z * se), (mean / exact, se / exact)


def _loglog_slope(tau, var):
    """Least-squares slope of log ADEV against log tau, per channel."""
    x = np.log(tau)
    y = 0.5 * np.log(var)
    xc = x - x.mean()
    return (xc @ (y - y.mean(axis=0))) / (xc @ xc)


def test_angle_view_slopes_and_break(simulated):
    filt, out = simulated
    short = DT * np.array([2, 3, 4, 6, 8, 10])  # tau <= 0.1 T
    long_ = T_OPT * np.array([8.0, 10.0, 14.0, 20.0, 28.0])  # tau >= 8 T
    rs = allanite.avar(out, fs=FS, input="angle", taus=short, alpha=0)
    rl = allanite.avar(out, fs=FS, input="angle", taus=long_, alpha=0)
    s_short, se_short = _mean_se(_loglog_slope(rs.tau, rs.var))
    s_long, se_long = _mean_se(_loglog_slope(rl.tau, rl.var))
    # the exact curve's own curvature over these ranges is below 0.02 in slope
    assert abs(s_short + 0.5) < Z * se_short + 0.02, (s_short, se_short)
    assert abs(s_long + 1.0) < Z * se_long + 0.02, (s_long, se_long)
    # asymptote levels per channel: var*tau -> 2V/T_d, var*tau^2 -> 3V; they cross at 1.5 T_d
    c_short = np.mean(rs.var * rs.tau[:, None], axis=0)
    c_long = np.mean(rl.var * rl.tau[:, None] ** 2, axis=0)
    tb, se_tb = _mean_se(c_long / c_short)
    assert filt.break_tau == pytest.approx(1.5 * T_OPT, rel=0.01)
    assert abs(tb - filt.break_tau) < Z * se_tb + 0.01 * filt.break_tau, (tb, se_tb)
    # the quoted 1.89 T is not where the angle-view asymptotes cross
    assert abs(tb - 1.89 * T_OPT) > Z * se_tb


def test_signal_view_has_the_gauss_markov_hump_at_1_89_t(simulated):
    filt, out = simulated
    taus = T_OPT * np.array([0.25, 0.5, 1.0, 1.5, 1.89, 2.5, 4.0, 8.0])
    taus = np.round(taus / DT) * DT
    res = allanite.avar(out, fs=FS, input="rate", taus=taus, alpha=0)
    mean, se = _mean_se(res.var)
    exact = filt.output_avar(res.tau, view="signal")
    assert np.all(np.abs(mean - exact) < Z * se), (mean / exact, se / exact)
    # the exact signal-view deviation peaks at 1.89 T_d, and the simulated curve rises to it
    # and falls after it
    dense = DT * np.arange(10, 1000)
    peak = dense[np.argmax(filt.output_avar(dense, view="signal"))]
    assert peak == pytest.approx(filt.signal_peak_tau, rel=0.01)
    i_peak = int(np.argmin(np.abs(res.tau - 1.89)))
    assert mean[i_peak] - mean[2] > Z * math.hypot(se[i_peak], se[2])
    assert mean[i_peak] - mean[-1] > Z * math.hypot(se[i_peak], se[-1])


def test_asymptote_helpers_are_the_limits_of_the_exact_form():
    filt = optimal_complementary_filter(ARW, VRW, dt=DT, g=G)
    tiny, huge = DT * np.array([1.0, 2.0]), DT * np.array([1e5, 2e5])
    np.testing.assert_allclose(filt.output_avar(tiny), filt.short_asymptote(tiny), rtol=2e-2)
    np.testing.assert_allclose(filt.output_avar(huge), filt.long_asymptote(huge), rtol=1e-9)


def test_apply_starts_on_the_accelerometer_tilt():
    filt = ComplementaryFilter(arw=ARW, vrw=VRW, time_constant=5.0, dt=DT)
    tilt = 0.1
    rate = np.zeros(500)
    accel = np.full(500, tilt * G)
    np.testing.assert_allclose(filt.apply(rate, accel), tilt, rtol=1e-12)
    # a constant gyro bias b settles to the tilt offset b * alpha T0 / (1 - alpha) = b T
    out = filt.apply(np.full(20_000, 1e-3), np.zeros(20_000))
    assert out[-1] == pytest.approx(1e-3 * filt.time_constant, rel=1e-6)


def test_bad_input():
    with pytest.raises(ValueError, match="arw"):
        optimal_complementary_filter(-1.0, VRW, dt=DT)
    with pytest.raises(TypeError, match="vrw"):
        optimal_complementary_filter(ARW, "x", dt=DT)
    filt = optimal_complementary_filter(ARW, VRW, dt=DT)
    with pytest.raises(ValueError, match="same shape"):
        filt.apply(np.zeros(10), np.zeros(11))
    with pytest.raises(ValueError, match="finite"):
        filt.apply(np.array([0.0, np.nan]), np.zeros(2))
    with pytest.raises(ValueError, match="multiples"):
        filt.output_avar([0.015])
    with pytest.raises(ValueError, match="view"):
        filt.output_avar([0.01], view="phase")
