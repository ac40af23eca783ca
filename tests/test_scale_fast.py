"""Fast mode: strided sums at large m, deviation from exact bounded by the stated R."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import allanite
from allanite import _core
from allanite.variance.fast import autocovariance, fast_variance, relative_deviation, stride
from allanite.variance.outofcore import avar_large


@pytest.mark.parametrize("q", [4, 8, 16])
def test_documented_bounds_hold_for_all_factors(q):
    for m in [*range(2 * q, 6 * q), 257, 1000, 4099]:
        s = stride(m, q)
        assert relative_deviation(m, s, 0) <= 1.2 / q
        assert relative_deviation(m, s, -2) <= 0.06 / q
    # phase-type noise is the documented exception: R ~ sqrt(s - 1)
    assert relative_deviation(1024, 64, 2) > 5.0


def test_fast_equals_exact_below_2q_and_strided_sum_is_right():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((20_000, 2))
    phase = _core.phase(x, "rate")
    factors = np.array([1, 5, 31, 32, 100, 1000], dtype=np.int64)
    var, strides = fast_variance(phase, factors, "overlapping", q=16)
    assert strides.tolist() == [1, 1, 1, 2, 6, 62]
    exact = _core.variance(phase, factors, "overlapping", 1)
    assert np.array_equal(var[:3], exact[:3])
    for i in range(3, factors.size):  # the strided estimator, written out with numpy
        m, s = int(factors[i]), int(strides[i])
        n = phase.shape[0] - 2 * m
        d = phase[2 * m : 2 * m + n : s] - 2.0 * phase[m : m + n : s] + phase[:n:s]
        np.testing.assert_allclose(var[i], (d**2).mean(axis=0) / (2.0 * m * m), rtol=1e-12)


def test_monte_carlo_deviation_matches_the_bound():
    """White rate noise: (fast - exact)/exact ~ R * sd_rel(exact); check the scale by chi2."""
    q, n, trials = 16, 100_000, 24
    factors = np.array([256, 1024], dtype=np.int64)
    z2 = np.zeros((trials, factors.size))
    for t in range(trials):
        x = np.random.default_rng(1000 + t).standard_normal((n, 1))
        phase = _core.phase(x, "rate")
        fast, strides = fast_variance(phase, factors, "overlapping", q=q)
        exact = _core.variance(phase, factors, "overlapping", 1)
        for i, m in enumerate(factors.tolist()):
            gamma = autocovariance(m, 0)
            terms = phase.shape[0] - 2 * m
            sd_rel = (
                np.sqrt(2.0 * (gamma[0] ** 2 + 2.0 * (gamma[1:] ** 2).sum()) / terms) / gamma[0]
            )
            scale = relative_deviation(m, int(strides[i]), 0) * sd_rel
            z2[t, i] = ((fast[i, 0] - exact[i, 0]) / exact[i, 0] / scale) ** 2
    lo, hi = stats.chi2.ppf([0.0005, 0.9995], trials) / trials
    for i in range(factors.size):
        assert lo < z2[:, i].mean() < hi, z2[:, i].mean()


def test_fast_mode_in_the_api():
    x = np.random.default_rng(5).standard_normal(50_000)
    exact = allanite.avar(x, fs=100.0, alpha=0)
    fast = avar_large(x, fs=100.0, alpha=0, fast=True)
    assert fast.meta["fast_q"] == 16
    small = fast.m < 32
    assert np.array_equal(fast.var[small], exact.var[small])
    lo, hi = exact.var_ci(0.683)
    # R <= 0.075 sd: far inside the 68 % interval of the exact estimate
    assert np.all((fast.var > lo) & (fast.var < hi))
    with pytest.raises(ValueError, match="fast"):
        avar_large(x, fs=100.0, alpha=0, fast=True, kind="modified")
    with pytest.raises(ValueError, match="positive integer"):
        avar_large(x, fs=100.0, alpha=0, fast=-3)
    with pytest.raises(ValueError, match="in memory"):
        avar_large(x, fs=100.0, alpha=0, fast=True, memory_limit="100kB")
