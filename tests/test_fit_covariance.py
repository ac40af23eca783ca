"""Calibration of the Whittle covariance of AVAR estimates against Monte Carlo.

For each model, 400 records are simulated and the sample covariance of their overlapping AVAR
estimates is compared with :func:`allanite.fit.avar_covariance`. The allowed difference of a
variance is four Monte Carlo standard errors (from the sample fourth moment) plus the 10 %
accuracy claimed for the approximation at taus up to an eighth of the record.
"""

from __future__ import annotations

import numpy as np
import pytest

import allanite
from allanite.fit import avar_covariance
from allanite.fit.covariance import UNIFORM_EXCESS_KURTOSIS, _fourth_cumulant
from allanite.model import NoiseModel
from allanite.terms import Flicker, GaussMarkov, Quantization, RateRandomWalk, White
from fit_generator import simulate

DT = 0.01
N = 4096
REPS = 400
UNITS = {"rate": "deg/s", "time": "s"}
M = 2 ** np.arange(10)  # up to N/8


@pytest.mark.parametrize(
    "model",
    [
        NoiseModel((White(N=0.1), Quantization(Q=3e-3)), UNITS),
        NoiseModel((White(N=0.1), Flicker(B=0.05), RateRandomWalk(K=0.01)), UNITS),
        NoiseModel((White(N=0.02), GaussMarkov(sigma=1.0, tau_c=0.3)), UNITS),
    ],
    ids=["white+quantization", "white+flicker+rrw", "white+markov"],
)
def test_variances_and_correlations_match_monte_carlo(model):
    x = simulate(model, N, DT, REPS, seed=21)
    est = allanite.avar(x, fs=1 / DT, m=M, alpha=0).var
    centred = est - est.mean(axis=1, keepdims=True)
    mc_var = np.mean(centred**2, axis=1)
    mc_se = np.sqrt((np.mean(centred**4, axis=1) - mc_var**2) / REPS)
    cov = avar_covariance(model, M, DT, N)
    assert np.all(np.abs(np.diag(cov) - mc_var) <= 4 * mc_se + 0.10 * mc_var)
    # adjacent-octave correlations: Fisher-z standard error 1/sqrt(REPS - 3)
    mc_corr = np.corrcoef(est)
    model_corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    dz = np.arctanh(np.diag(mc_corr, 1)) - np.arctanh(np.diag(model_corr, 1))
    assert np.all(np.abs(dz) <= 4 / np.sqrt(REPS - 3) + 0.1)


def test_quantization_fourth_cumulant_matters():
    """Uniform quantization errors are lighter-tailed than Gaussian: the estimates vary less.

    The model with the fourth-cumulant term matches Monte Carlo; the Gaussian part alone
    overstates the short-tau variances by about 40 % (exactly 1/0.7 for m = 1).
    """
    q = 3e-3
    model = NoiseModel((Quantization(Q=q),), UNITS)
    cov = avar_covariance(model, M, DT, N)
    gaussian = cov - UNIFORM_EXCESS_KURTOSIS * q**4 * _fourth_cumulant(M.astype(float), DT, N)
    x = simulate(model, N, DT, REPS, seed=22)
    est = allanite.avar(x, fs=1 / DT, m=M, alpha=0).var
    centred = est - est.mean(axis=1, keepdims=True)
    mc_var = np.mean(centred**2, axis=1)
    allowed = 4 * np.sqrt((np.mean(centred**4, axis=1) - mc_var**2) / REPS) + 0.10 * mc_var
    assert np.all(np.abs(np.diag(cov) - mc_var) <= allowed)
    # at the short taus, where quantization dominates, the Gaussian part alone is farther off
    full_error = np.abs(np.diag(cov) - mc_var)[:4]
    gaussian_error = np.abs(np.diag(gaussian) - mc_var)[:4]
    assert np.all(gaussian_error > full_error)
    assert np.all(np.diag(gaussian)[:4] > 1.3 * np.diag(cov)[:4])
