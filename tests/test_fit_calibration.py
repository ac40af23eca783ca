"""Calibration of the default fit's standard errors: mean and spread of z over fixed seeds.

A coverage count of a few dozen records cannot tell a biased or overconfident estimate from
chance (44 records: binomial sd 3.3 % around 95 %). These tests look at the standardised
errors ``z = (estimate - truth) / stderr`` of many records of one design instead: a bias
shows as ``mean(z) != 0`` (standard error ``1/sqrt(K)``), an underestimated standard error
as ``sd(z) > 1`` (``(K - 1) sd^2`` is chi-square with ``K - 1`` degrees of freedom when the
errors are normal with the stated spread). They also compare the default fit with the ideal
generalized least squares, the true terms' exact shapes weighted by the covariance of the
true model (:func:`allanite.fit.avar_covariance`): the fit's iterated covariance, its
selection of terms and its positivity constraint must cost no precision on a record whose
terms all show.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import allanite
from allanite.fit.covariance import avar_covariance
from allanite.fit.result import FitResult
from allanite.model import NoiseModel
from allanite.terms import Flicker, White
from fit_generator import simulate

DT = 0.1
N_SAMPLES = 2**15
SEEDS = 160
UNITS = {"rate": "deg/s", "time": "s"}
#: white noise over the first octaves, flicker over the last (crossing near tau = 16 dt), the
#: configuration of the coverage misses of N in the validation runs
MODEL = NoiseModel((White(N=0.01), Flicker(B=0.013)), UNITS)


@pytest.fixture(scope="module")
def fits() -> tuple[list[FitResult], np.ndarray, np.ndarray]:
    x = simulate(MODEL, N_SAMPLES, DT, SEEDS, seed=41)
    res = allanite.avar(x, fs=1 / DT, taus="octave", alpha=0, units="deg/s")
    out = [allanite.fit(res.channel(c)) for c in range(SEEDS)]
    # the ideal GLS on the same taus, with the true model's covariance and shapes
    tau = out[0].tau
    m = np.round(tau / DT)
    cov = avar_covariance(MODEL, m, DT, N_SAMPLES)
    design = np.column_stack(
        [np.asarray(t.avar(tau, DT)) / next(iter(t.values().values())) ** 2 for t in MODEL.terms]
    )
    weight = np.linalg.inv(cov)
    normal = design.T @ weight @ design
    y = np.array([np.asarray(res.channel(c).var)[np.isin(res.m, m)] for c in range(SEEDS)])
    ideal = np.linalg.solve(normal, design.T @ weight @ y.T).T
    return out, ideal, np.linalg.inv(normal)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["N", "B"])
def test_z_has_mean_zero_and_unit_spread(fits, name: str) -> None:
    out, _, _ = fits
    truth = MODEL.coefficients()[name]
    assert all(name in f.coefficients for f in out)
    z = np.array([(f[name].value - truth) / f[name].stderr for f in out])
    # bias: mean z within 3 of its standard errors
    assert abs(z.mean()) <= 3.0 / math.sqrt(SEEDS), (name, z.mean())
    # spread: sd(z)^2 (K - 1) inside the central 99.8 % of chi-square(K - 1)
    lo, hi = stats.chi2.ppf([0.001, 0.999], SEEDS - 1)
    assert lo <= z.var(ddof=1) * (SEEDS - 1) <= hi, (name, z.std(ddof=1))


@pytest.mark.slow
@pytest.mark.parametrize(("j", "name"), [(0, "N"), (1, "B")])
def test_default_fit_is_the_ideal_gls(fits, j: int, name: str) -> None:
    """The fit equals the GLS under the true covariance to a small part of its error."""
    out, ideal, ideal_cov = fits
    truth = MODEL.coefficients()[name]
    value = np.array([f[name].value for f in out])
    stderr = np.array([f[name].stderr for f in out])
    ideal_amp = np.sqrt(np.maximum(ideal[:, j], 0.0))
    # the reported standard error is the ideal one (delta method: half the relative se of
    # the squared amplitude), to the precision of the iterated covariance
    ideal_se = math.sqrt(ideal_cov[j, j]) / (2.0 * truth)
    assert np.median(stderr) == pytest.approx(ideal_se, rel=0.05)
    # and the estimates follow the ideal ones: their difference is a tenth of the spread
    # in at least 95 % of the records
    close = np.abs(value - ideal_amp) <= 0.1 * ideal_se
    assert close.mean() >= 0.95, (name, close.mean())
    # the ideal estimator's own spread matches its standard error (covariance calibration)
    assert ideal_amp.std(ddof=1) == pytest.approx(
        ideal_se, rel=3.0 * math.sqrt(1.0 / (2.0 * (SEEDS - 1)))
    )
