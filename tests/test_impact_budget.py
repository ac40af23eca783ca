"""Error budget, the diagnosis hook and the NoiseModel adapter."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from allanite.impact import (
    Earth,
    MarkovNoise,
    SensorNoise,
    error_budget,
    error_change,
    error_model,
)
from allanite.impact.sensor import Component
from allanite.model import NoiseModel
from allanite.terms import (
    Flicker,
    GaussMarkov,
    LowPassWhite,
    Quantization,
    RateRandomWalk,
    Telegraph,
    TurnOnBias,
    White,
)

DEG = math.pi / 180.0
GYRO = SensorNoise(
    constant=1e-6,
    white=2e-6,
    random_walk=3e-8,
    markov=(MarkovNoise(5e-6, 300.0),),
)
ACCEL = SensorNoise(constant=1e-3, white=5e-4)


@pytest.fixture(scope="module")
def budget():
    t = np.geomspace(1.0, 1e6, 61)
    return error_budget(GYRO, ACCEL, t=t, times=[60.0, 3600.0], latitude=45.0)


def test_budget_shapes_and_rows(budget):
    assert [c.label for c in budget.components] == [
        "constant",
        "white",
        "random_walk",
        "markov(tau_c=300 s)",
        "constant",
        "white",
    ]
    assert budget.exact.shape == (6, 5, 61)
    assert budget.table.shape == (6, 5, 2)
    # accelerometer rows drive only velocity and position
    accel_rows = [i for i, c in enumerate(budget.components) if c.sensor == "accel"]
    for q in ("vertical", "azimuth", "latitude"):
        assert np.all(np.isnan(budget.curve(q)[accel_rows]))
    assert budget.earth == Earth.at_latitude(45.0)
    assert budget.unit("heading") == "rad"


def test_budget_curves_equal_the_exact_models(budget):
    e = budget.earth
    for ci, comp in enumerate(budget.components):
        c = Component(comp.kind, comp.value, comp.tau_c)
        sig = error_model(comp.sensor, c, e, regime="schuler").sigma(budget.t)
        for q, s in sig.items():
            np.testing.assert_allclose(budget.curve(q)[ci], s, rtol=1e-12)
    # totals are root-sum-squares of independent components
    pos = budget.curve("position")
    np.testing.assert_allclose(budget.total("position"), np.sqrt(np.nansum(pos**2, axis=0)))


def test_budget_asymptotes_bracket_the_exact_curve(budget):
    # short laws hold for t << 1/w_s (and t << tau_c), long laws for t >> 1/w_s, tau_c
    early, late = budget.t < 10.0, budget.t > 2e5
    for ci, comp in enumerate(budget.components):
        for q in ("velocity", "position"):
            ex = budget.curve(q)[ci]
            np.testing.assert_allclose(
                budget.curve(q, "short")[ci][early], ex[early], rtol=0.05, err_msg=comp.label
            )
            if comp.kind != "constant":  # constant: |sin|, (1-cos) are exact, compared below
                np.testing.assert_allclose(
                    budget.curve(q, "long")[ci][late], ex[late], rtol=0.02, err_msg=comp.label
                )


def test_table_is_the_exact_value_at_the_table_times(budget):
    t = np.array([60.0, 3600.0])
    again = error_budget(GYRO, ACCEL, t=t, times=t, latitude=45.0)
    np.testing.assert_allclose(budget.table, again.exact, rtol=1e-12)
    rows = budget.rows()
    totals = [r for r in rows if r["component"] == "total" and r["quantity"] == "azimuth"]
    assert [r["t"] for r in totals] == [60.0, 3600.0]
    assert totals[1]["sigma"] == pytest.approx(budget.total_at("azimuth")[1])
    frame = budget.table_frame()
    assert set(frame.columns) == {"sensor", "component", "quantity", "unit", "t", "sigma"}
    curves = budget.to_frame()
    assert len(curves) == 61 * (4 * 5 + 2 * 2)
    payload = json.loads(budget.to_json())
    assert payload["earth"]["latitude"] == 45.0


def test_markov_start_stationary_raises_the_early_error():
    g = SensorNoise(markov=(MarkovNoise(1e-5, 1000.0),))
    zero = error_budget(g, t=[10.0, 100.0], times=[100.0])
    stat = error_budget(g, t=[10.0, 100.0], times=[100.0], markov_start="stationary")
    # at t << tau_c the stationary start behaves as a random constant of size sigma
    assert stat.total("azimuth")[0] == pytest.approx(
        math.hypot(1e-5 * 10.0, zero.total("azimuth")[0]), rel=0.02
    )


def test_error_change_reports_the_cost_of_a_missing_markov_term():
    before = SensorNoise(white=2e-6)
    after = SensorNoise(white=2e-6, markov=(MarkovNoise(5e-6, 300.0),))
    change = error_change(before, after, quantity="heading", t=3600.0)
    ref = error_budget(after, t=[3600.0], times=[3600.0])
    assert change.quantity == "azimuth"
    assert change.after == pytest.approx(ref.total_at("azimuth")[0])
    assert change.before == pytest.approx(2e-6 * math.sqrt(3600.0), rel=1e-9)
    assert change.ratio > 1
    text = change.describe("the missing Gauss-Markov term")
    assert text.startswith("the missing Gauss-Markov term changes the 1-hour heading error")
    assert f"{change.before / DEG:.3g} deg" in text
    assert f"{change.after / DEG:.3g} deg" in text


def test_error_change_for_the_accelerometer_and_zero_models():
    change = error_change(
        SensorNoise(), SensorNoise(white=5e-4), quantity="velocity", t=600.0, sensor="accel"
    )
    assert change.before == 0.0
    assert math.isinf(change.ratio)
    assert "10-minute velocity error" in change.describe()
    with pytest.raises(ValueError, match="does not drive"):
        error_change(SensorNoise(white=1.0), SensorNoise(white=2.0), sensor="accel")
    with pytest.raises(ValueError, match="quantity"):
        error_change(GYRO, GYRO, quantity="altitude")
    with pytest.raises(ValueError, match="positive"):
        error_change(GYRO, GYRO, t=-1.0)


def test_noise_model_adapter_converts_to_si_and_maps_terms():
    model = NoiseModel(
        (
            White(N=0.1),  # model units deg/s: N in deg/sqrt(s)
            White(N=0.2),
            RateRandomWalk(K=1e-4),
            TurnOnBias(sigma=0.01),
            GaussMarkov(sigma=0.003, tau_c=300.0),
            Telegraph(amplitude=0.002, tau_c=50.0),
            LowPassWhite(N=0.05, bandwidth=10.0),
            Quantization(Q=1e-4),
        ),
        {"rate": "deg/s", "time": "s"},
    )
    b = error_budget(model, t=[1.0, 100.0], times=[100.0])
    labels = [c.label for c in b.components]
    assert labels[:3] == ["constant", "white", "random_walk"]
    white = b.components[1]
    assert white.value == pytest.approx(math.hypot(0.1, 0.2) * DEG)
    assert b.components[0].value == pytest.approx(0.01 * DEG)
    assert "telegraph" in labels
    assert "lowpass_white" in labels
    assert b.ignored == ("gyro: quantization",)
    # a telegraph signal has the Gauss-Markov autocovariance, so the same error variance
    tele = error_budget(
        NoiseModel((Telegraph(amplitude=0.002, tau_c=50.0),)), t=[100.0], times=[100.0]
    )
    gm_noise = SensorNoise(markov=(MarkovNoise(0.002 * DEG, 50.0),))
    gm = error_budget(gm_noise, t=[100.0], times=[100.0])
    np.testing.assert_allclose(tele.exact, gm.exact, rtol=1e-12)


def test_accelerometer_noise_model_with_a_scale():
    # an accelerometer model in units of g: VRW 0.01 g/sqrt(s), bias 1 mg
    g0 = 9.80665
    accel = NoiseModel((White(N=0.01), TurnOnBias(sigma=1e-3)))
    budget = error_budget(SensorNoise(white=1e-6), accel, accel_scale=g0, t=[1.0], times=[1.0])
    rows = {c.label: c.value for c in budget.components if c.sensor == "accel"}
    assert rows["white"] == pytest.approx(0.01 * g0)
    assert rows["constant"] == pytest.approx(1e-3 * g0)


def test_only_ignored_terms_is_an_error_naming_them():
    with pytest.raises(ValueError, match="quantization"):
        error_budget(NoiseModel((Quantization(Q=1e-4),)))


def test_flicker_becomes_one_budget_row():
    # flicker B: the ADEV plateau 0.664 B; the heading error of a bias of about B grows like
    # B t over times where the bank's correlation times exceed t
    b_rad = 1e-5
    model = NoiseModel((Flicker(B=b_rad),), {"rate": "rad/s", "time": "s"})
    budget = error_budget(model, t=[10.0, 100.0, 1000.0], times=[100.0])
    assert [c.label for c in budget.components] == ["flicker(B=1e-05)"]
    assert np.all(np.isnan(budget.short))
    assert np.all(np.isnan(budget.long))
    az = budget.total("azimuth")
    slope = np.diff(np.log(az)) / np.diff(np.log([10.0, 100.0, 1000.0]))
    # between the white (0.5) and random-constant (1) growth: flicker-like ~ t sqrt(ln t)
    assert np.all((slope > 0.8) & (slope < 1.2))
    assert 0.1 * b_rad * 1000 < az[-1] < 10 * b_rad * 1000


def test_budget_bad_input():
    with pytest.raises(TypeError, match="SensorNoise"):
        error_budget({"white": 1.0})
    with pytest.raises(ValueError, match="nothing to budget"):
        error_budget(SensorNoise())
    with pytest.raises(ValueError, match="increasing"):
        error_budget(GYRO, t=[10.0, 1.0])
    with pytest.raises(ValueError, match="not both"):
        error_budget(GYRO, latitude=10.0, earth=Earth())
    with pytest.raises(ValueError, match="markov_start"):
        error_budget(GYRO, markov_start="hot")
    with pytest.raises(ValueError, match=">= 0"):
        SensorNoise(white=-1.0)
    with pytest.raises(TypeError, match="MarkovNoise"):
        SensorNoise(markov=((1.0, 2.0),))
    with pytest.raises(ValueError, match="tau_c"):
        MarkovNoise(1.0, 0.0)
    with pytest.raises(ValueError, match="accel_scale"):
        error_budget(GYRO, NoiseModel((White(N=1.0),)), accel_scale=-1.0)
