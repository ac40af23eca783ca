"""allanite.fit: exact curves, records, tables, comparisons, selection and bad input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import allanite
from allanite.fit import classic_readout, fit_factors
from allanite.model import NoiseModel
from allanite.terms import GaussMarkov, RateRandomWalk, White
from allanite.variance import AllanResult

DT = 0.01
UNITS = {"rate": "deg/s", "time": "s"}


def exact_curve(model: NoiseModel, n: int = 2**16, units: str = "deg/s") -> AllanResult:
    """An AllanResult holding the model's exact Allan variance (no estimation noise)."""
    m = 2 ** np.arange(int(np.log2(n // 8)) + 1)
    tau = m * DT
    size = m.size
    return AllanResult(
        tau=tau,
        m=m.astype(np.int64),
        var=model.avar(tau, DT),
        kind="overlapping",
        n_terms=(n - 2 * m).astype(np.int64),
        edf=np.full(size, 100.0),
        alpha=np.zeros(size, dtype=np.int64),
        fs=1 / DT,
        input="rate",
        n_samples=n,
        units=units,
    )


MODEL = NoiseModel((White(N=0.02), RateRandomWalk(K=2e-3)), UNITS)


def test_exact_curve_gives_exact_coefficients_and_zero_chi2():
    fitted = allanite.fit(exact_curve(MODEL), ["white", "rrw"])
    assert fitted["N"].value == pytest.approx(0.02, rel=1e-6)
    assert fitted["K"].value == pytest.approx(2e-3, rel=1e-5)
    assert fitted.chi2 < 1e-8
    assert fitted.dof == fitted.tau.size - 2
    assert np.allclose(fitted.residuals, 0.0, atol=1e-4)
    lo, hi = fitted["N"].ci(0.95)
    assert lo < 0.02 < hi
    lo68, hi68 = fitted["N"].ci(0.68)
    assert lo < lo68 < hi68 < hi


def test_exact_gauss_markov_curve():
    model = NoiseModel((White(N=0.05), GaussMarkov(sigma=0.5, tau_c=1.0)), UNITS)
    fitted = allanite.fit(exact_curve(model), ["white", "markov"])
    assert fitted["sigma"].value == pytest.approx(0.5, rel=1e-3)
    assert fitted["tau_c"].value == pytest.approx(1.0, rel=1e-3)
    assert fitted["tau_c"].unit == "s"


def test_auto_on_exact_curve_selects_present_terms():
    fitted = allanite.fit(exact_curve(MODEL), "auto")
    assert {t.type for t in fitted.model.terms} == {"white", "rrw"}
    kept = {row["term"]: row["kept"] for row in fitted.selection}
    assert kept["white"]
    assert kept["rrw"]
    assert not kept["flicker"]


def test_fit_a_record_directly():
    rng = np.random.default_rng(5)
    x = rng.standard_normal(2**14) * 0.02 / math.sqrt(DT)
    fitted = allanite.fit(x, ["N"], fs=1 / DT, units="deg/h")
    assert fitted.model.units["rate"] == "deg/h"
    lo, hi = fitted["N"].ci(0.999)
    assert lo <= 0.02 <= hi


@pytest.mark.parametrize(("taus", "points"), [("log", 100), ("octave", 100), ("log", 400)])
def test_fit_factors_are_the_taus_the_fit_uses(taus, points):
    # the validation grid places its terms in these taus: they must be the fit's own
    rng = np.random.default_rng(6)
    x = rng.standard_normal(30_000) * 0.02 / math.sqrt(DT)
    res = allanite.avar(x, fs=1 / DT, taus=taus, points=points, units="deg/s")
    fitted = allanite.fit(res, ["N"])
    factors = fit_factors(res.m, res.n_samples)
    np.testing.assert_array_equal(np.round(fitted.tau / DT).astype(np.int64), factors)
    assert factors[-1] <= 30_000 / 8
    assert np.all(factors[1:] >= 2 * factors[:-1])
    # a looser cut keeps more taus
    assert fit_factors(res.m, res.n_samples, max_fraction=0.25)[-1] > factors[-1]


def test_table_units_and_json():
    fitted = allanite.fit(exact_curve(MODEL), ["N", "K"])
    rows = {r["name"]: r for r in fitted.table("deg/h")}
    assert rows["N"]["value"] == pytest.approx(0.02 * 60, rel=1e-6)
    assert rows["K"]["value"] == pytest.approx(2e-3 * 3600 * 60, rel=1e-5)
    custom = {r["name"]: r for r in fitted.table({"N": "deg/sqrt(h)"})}
    assert custom["N"]["unit"] == "deg/sqrt(h)"
    assert custom["K"]["unit"] == "deg/s/sqrt(s)"
    assert "deg/sqrt(h)" in fitted.format_table("deg/h")
    data = json.loads(fitted.to_json())
    assert data["model"]["terms"][0]["type"] == "white"
    assert data["coefficients"][0]["name"] == "N"


def test_compare_with_datasheet_and_reference():
    fitted = allanite.fit(exact_curve(MODEL), ["N", "K"])
    # N = 1.2 deg/sqrt(h): passes a 1.5 limit, fails 1.0
    good = fitted.compare({"N": (1.5, "deg/sqrt(h)")})
    assert good.passed
    assert good.rows[0].conclusive
    bad = fitted.compare({"N": (1.0, "deg/sqrt(h)"), "K": 1.0})
    assert not bad.passed
    assert [r.passed for r in bad.rows] == [False, True]
    assert "FAIL" in bad.format()
    other = NoiseModel((White(N=0.03), RateRandomWalk(K=2e-3)), UNITS).in_units("deg/h")
    ref = fitted.compare(other)
    diffs = {r.name: r.conclusive for r in ref.rows}
    assert diffs == {"N": True, "K": False}
    with pytest.raises(ValueError, match="datasheet names 'B'"):
        fitted.compare({"B": 1.0})


def test_classic_readout_on_exact_lines():
    tau = np.geomspace(0.01, 1000, 200)
    n_only = np.sqrt(White(N=0.02).avar(tau, DT))
    assert classic_readout(tau, n_only).values["N"] == pytest.approx(0.02, rel=1e-9)
    assert classic_readout(tau, n_only).values["K"] is None
    k_only = np.sqrt(RateRandomWalk(K=2e-3).avar(tau, 1e-6))
    assert classic_readout(tau, k_only).values["K"] == pytest.approx(2e-3, rel=1e-4)


def test_covariance_matrix_and_residuals_are_consistent():
    fitted = allanite.fit(exact_curve(MODEL), ["N", "K"])
    cov = fitted.cov
    assert cov.shape == (fitted.tau.size, fitted.tau.size)
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    corr = cov[0, 1] / math.sqrt(cov[0, 0] * cov[1, 1])
    assert 0.3 < corr < 0.7  # adjacent octaves of white noise are correlated ~0.5


def test_estimate_at_the_bound_has_a_proper_interval():
    """An absent term fitted at 0 gets ``[0, upper]`` with ``upper > 0``, never ``[0, 0]``.

    White noise only, fitted with white + rate random walk: K often lands on the bound.
    Over 20 seeds every K interval contains its estimate and has a positive upper limit.
    """
    rng = np.random.default_rng(17)
    at_bound = 0
    for _ in range(20):
        x = rng.standard_normal(2**14) * 0.02 / math.sqrt(DT)
        fitted = allanite.fit(x, ["white", "rrw"], fs=1 / DT)
        k = fitted["K"]
        for level in (0.5, 0.95):  # at 50 % a negative free estimate used to give [0, 0]
            lo, hi = k.ci(level)
            assert lo <= k.value <= hi
            assert hi > 0
        at_bound += k.value == 0
    assert at_bound > 0  # the case under test occurred


def test_well_specified_fit_has_no_discrepancy_and_reports_it():
    fitted = allanite.fit(exact_curve(MODEL), ["N", "K"])
    assert fitted.discrepancy == 0
    assert not fitted.misspecified
    assert fitted.good_range == (fitted.tau[0], fitted.tau[-1])
    out = fitted.to_dict()
    assert out["discrepancy"] == 0
    assert out["misfit"] == [False] * fitted.tau.size
    assert "REJECTED" not in fitted.format_table()


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"terms": ["white", "pink"]}, ValueError, "unknown term 'pink'"),
        ({"terms": []}, ValueError, "non-empty"),
        ({"terms": ["white", "white"]}, ValueError, "twice"),
        ({"terms": [3]}, TypeError, "names"),
        ({"method": "magic"}, ValueError, "unknown method"),
        ({"penalty": -1.0}, ValueError, "penalty"),
        ({"fs": 7.0}, ValueError, "contradicts"),
        ({"units": "deg"}, ValueError, "not a rate unit"),
        ({"misfit_level": 1.5}, ValueError, "misfit_level"),
        ({"min_ratio": 0.5}, ValueError, "min_ratio"),
    ],
)
def test_bad_arguments(kwargs, error, match):
    with pytest.raises(error, match=match):
        allanite.fit(exact_curve(MODEL), **kwargs)


@pytest.mark.parametrize("seed", range(5))
def test_automatic_fit_refuses_a_record_with_two_usable_taus(seed):
    # 20 white samples give two usable taus; any single term fits two points exactly, so the
    # selection was chance (Q or B instead of N in 5 of 20 seeds, with tight intervals)
    x = 0.1 * np.random.default_rng(seed).standard_normal(20)
    with pytest.raises(ValueError, match=r"too short for an automatic fit: 20 samples give only 2"):
        allanite.fit(x, fs=100.0)
    assert allanite.fit(x, ["N"], fs=100.0).coefficients["N"].value > 0  # named terms still fit
    longer = 0.1 * np.random.default_rng(seed).standard_normal(40)  # three usable taus
    assert set(allanite.fit(longer, fs=100.0).coefficients) == {"N"}


def test_bad_curves():
    curve = exact_curve(MODEL, n=2**8)
    with pytest.raises(ValueError, match="usable taus"):
        allanite.fit(curve, ["Q", "N", "B", "K", "R", "markov"])
    nan = AllanResult(**{**curve.__dict__, "var": np.full(curve.tau.size, np.nan)})
    with pytest.raises(ValueError, match="all NaN"):
        allanite.fit(nan, ["N"])
    neg = AllanResult(**{**curve.__dict__, "var": -curve.var})
    with pytest.raises(ValueError, match="negative variances"):
        allanite.fit(neg, ["N"])
    hadamard = AllanResult(**{**curve.__dict__, "kind": "hadamard"})
    with pytest.raises(ValueError, match="overlapping"):
        allanite.fit(hadamard, ["N"])
    two = AllanResult(
        **{
            **curve.__dict__,
            "var": np.column_stack([curve.var, curve.var]),
            "edf": np.column_stack([curve.edf, curve.edf]),
            "alpha": np.column_stack([curve.alpha, curve.alpha]),
        }
    )
    with pytest.raises(ValueError, match="channel"):
        allanite.fit(two, ["N"])
    with pytest.raises(ValueError, match="sampling frequency"):
        allanite.fit(np.zeros(100), ["N"])
    with pytest.raises(ValueError, match="need at least 6"):
        allanite.fit(exact_curve(MODEL, n=2**6), method="seed")
    fitted = allanite.fit(exact_curve(MODEL), ["N"])
    with pytest.raises(ValueError, match="level"):
        fitted["N"].ci(1.5)
    with pytest.raises(KeyError, match="no coefficient 'B'"):
        fitted["B"]
