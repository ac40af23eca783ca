"""The laser-gyro error model: white angle noise + rate random walk + random turn-on bias.

Monte Carlo variance of the simulated angle error at step k (sample period T, k = 0 is the
first sample) against the exact law of the simulated discretisation,
(k+1) T^2 Dw + (k+1)(k+2)(2k+3)/6 T^4 Du + (k+1)^2 T^2 m^2 (Dw = N^2/T, Du = K^2/T), and
against the tabulated law (k+1) T^2 Dw + k(k+1)(2k+1)/6 T^4 Du + k(k+1) T^2 m^2, which
differs from it by O(1/k) (the random walk and the bias enter one step later there) and so
agrees within the sampling uncertainty once k >= 100.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from allanite.model import NoiseModel
from allanite.terms import RateRandomWalk, TurnOnBias, White

T, N, K, M = 0.01, 0.01, 0.006, 0.006
RUNS = 4000
STEPS = np.array([0, 1, 2, 5, 10, 100, 300, 999])


def _band(variance):
    lo, hi = stats.chi2.ppf([0.0005, 0.9995], RUNS - 1) / (RUNS - 1)
    return lo * variance, hi * variance


def _mc_variance():
    model = NoiseModel((White(N=N), RateRandomWalk(K=K), TurnOnBias(sigma=M)))
    angle = model.simulate(1000, fs=1.0 / T, output="angle", n_channels=RUNS, seed=2024)
    return angle[STEPS].var(axis=1, ddof=0)  # the error has mean zero by construction


def test_angle_variance_matches_the_exact_and_the_tabulated_law():
    dw, du, k = N**2 / T, K**2 / T, STEPS.astype(float)
    exact = (k + 1) * T**2 * dw + (k + 1) * (k + 2) * (2 * k + 3) / 6 * T**4 * du
    exact += (k + 1) ** 2 * T**2 * M**2
    tabulated = (k + 1) * T**2 * dw + k * (k + 1) * (2 * k + 1) / 6 * T**4 * du
    tabulated += k * (k + 1) * T**2 * M**2
    mc = _mc_variance()
    lo, hi = _band(exact)
    assert np.all((lo <= mc) & (mc <= hi)), mc / exact
    late = STEPS >= 100
    lo, hi = _band(tabulated[late])
    assert np.all((lo <= mc[late]) & (mc[late] <= hi)), mc[late] / tabulated[late]
