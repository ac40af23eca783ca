"""Unit parsing, conversion and customary display units of noise coefficients."""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import allanite
from allanite.model import NoiseModel
from allanite.terms import Flicker, RateRandomWalk, White
from allanite.units import (
    RATE_UNITS,
    STANDARD_GRAVITY,
    coefficient_unit,
    convert,
    customary_unit,
    display_unit,
    integral_unit,
    parse_unit,
    quantity,
    rate_unit,
    sensor_kind,
)


@pytest.mark.parametrize(
    ("value", "src", "dst", "expected"),
    [
        (1.0, "deg/sqrt(s)", "deg/sqrt(h)", 60.0),
        (1.0, "deg/s/sqrt(s)", "deg/h/sqrt(h)", 3600.0 * 60.0),
        (1.0, "deg/s", "deg/h", 3600.0),
        (1.0, "rad/s", "deg/s", 180.0 / math.pi),
        (1.0, "deg/sqrt(s)", "deg/s/sqrt(Hz)", 1.0),
        (1.0, "deg/h/sqrt(Hz)", "deg/sqrt(h)", 1.0 / 60.0),
        (1.0, "rad/s^2", "deg/h^2", 180.0 / math.pi * 3600.0**2),
        (1.0, "deg/h^1.5", "deg/h/sqrt(h)", 1.0),
        (1.0, "(rad/s)*sqrt(Hz)", "rad/s/sqrt(s)", 1.0),
        (1.0, "dph", "deg/h", 1.0),
        (1.0, "°/√h", "deg/sqrt(h)", 1.0),
        (1.0, "arcsec", "deg", 1.0 / 3600.0),
        (1.0, "min", "s", 60.0),
    ],
)
def test_conversions(value, src, dst, expected):
    assert math.isclose(convert(value, src, dst), expected, rel_tol=1e-12)


def test_original_work_coefficients_in_customary_units():
    # N = 6.153e-3 deg/sqrt(s) = 0.369 deg/sqrt(h); K = 8.1e-4 deg/s/sqrt(s) = 175 deg/h/sqrt(h)
    assert math.isclose(convert(6.153e-3, "deg/sqrt(s)", "deg/sqrt(h)"), 0.36918)
    assert math.isclose(convert(8.1e-4, "deg/s/sqrt(s)", "deg/h/sqrt(h)"), 174.96)
    assert math.isclose(convert(6.619e-5, "deg/s", "deg/h"), 0.238284)


def test_display_units():
    assert display_unit("deg/h", "N") == "deg/sqrt(h)"
    assert display_unit("deg/h", "K") == "deg/h/sqrt(h)"
    assert display_unit("deg/h", "B") == "deg/h"
    assert display_unit("rad/s", "Q") == "rad"
    assert display_unit("deg/s", "R") == "deg/s^2"
    assert display_unit("deg/s", "tau_c_2") == "s"
    assert display_unit("deg/s", "sigma_1") == "deg/s"
    assert display_unit("deg/s", "frequency") == "Hz"


def test_dimensions_and_errors():
    u = parse_unit("deg/h/sqrt(h)")
    assert (u.angle, u.time) == (1.0, -1.5)
    with pytest.raises(ValueError, match="cannot convert"):
        convert(1.0, "deg/s", "deg/sqrt(h)")
    with pytest.raises(ValueError, match="unknown unit 'furlong'"):
        parse_unit("furlong/s")
    with pytest.raises(ValueError, match="not a rate unit"):
        rate_unit("deg")
    with pytest.raises(ValueError, match="unexpected end"):
        parse_unit("sqrt(h")
    with pytest.raises(TypeError, match="string"):
        parse_unit(3.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="no customary unit"):
        display_unit("deg/s", "X")


# --- one unit algebra: the same physical record gives the same coefficients in any unit -------

GYRO_RATES = [u for u in RATE_UNITS if sensor_kind(u) == "gyro"]
ACCEL_RATES = [u for u in RATE_UNITS if sensor_kind(u) == "accelerometer"]
#: units of N and K of each sensor, written in many ways (same dimension, other spellings)
N_UNITS = {
    "gyro": [
        "deg/sqrt(h)",
        "rad/sqrt(s)",
        "deg/s/sqrt(Hz)",
        "arcsec/sqrt(s)",
        "°/√h",
        "dph/sqrt(Hz)",
    ],
    "accelerometer": [
        "m/s/sqrt(h)",
        "ug/sqrt(Hz)",
        "mg/sqrt(Hz)",
        "m/s^2/sqrt(Hz)",
        "ft/s/sqrt(h)",
    ],
}
K_UNITS = {
    "gyro": ["deg/h/sqrt(h)", "deg/h^1.5", "rad/s^1.5", "dph/sqrt(s)", "rpm/sqrt(min)"],
    "accelerometer": ["m/s/h^1.5", "m/s^2/sqrt(s)", "ug/sqrt(s)", "mg/sqrt(h)", "gal/sqrt(h)"],
}


def _physical_record() -> np.ndarray:
    """One physical record in SI (rad/s for a gyro, m/s^2 for an accelerometer)."""
    rng = np.random.default_rng(13)
    n = 60_000
    return 1e-3 * rng.standard_normal(n) + np.cumsum(2e-6 * rng.standard_normal(n))


@functools.cache
def _fit_in(unit: str):
    """Fit of the physical record written in ``unit`` (scale from the unit algebra)."""
    x = _physical_record() / parse_unit(unit).scale
    res = allanite.oadev(x, fs=100.0, units=unit, taus="octave")
    return allanite.fit(res, terms=["white", "rrw"])


def _si(fit, name: str) -> float:
    coef = fit.coefficients[name]
    return coef.value * parse_unit(coef.unit).scale


ANGLES = ["rad", "mrad", "urad", "deg", "mdeg", "arcmin", "arcsec", "rev"]
LENGTHS = ["m", "cm", "mm", "um", "km", "ft", "in"]
GEES = ["g", "mg", "ug", "gal", "mGal"]
TIMES = ["s", "ms", "us", "min", "h", "day"]


def _composed(sensor: str, name: str) -> st.SearchStrategy[str]:
    """Display units of N or K built from any atoms (every spelling of the dimension)."""
    t = st.sampled_from(TIMES)
    if sensor == "gyro":
        a = st.sampled_from(ANGLES)
        if name == "N":  # angle / sqrt(time)
            return st.one_of(
                st.builds(lambda a, t: f"{a}/sqrt({t})", a, t),
                st.builds(lambda a, t: f"{a}/{t}/sqrt(Hz)", a, t),
                st.builds(lambda a, t, u: f"({a}/{t})*sqrt({u})", a, t, t),
            )
        return st.one_of(  # angle / time^1.5
            st.builds(lambda a, t: f"{a}/{t}^1.5", a, t),
            st.builds(lambda a, t, u: f"{a}/{t}/sqrt({u})", a, t, t),
        )
    length, gee = st.sampled_from(LENGTHS), st.sampled_from(GEES)
    if name == "N":  # length / time^1.5
        return st.one_of(
            st.builds(lambda x, t, u: f"{x}/{t}/sqrt({u})", length, t, t),
            st.builds(lambda x: f"{x}/sqrt(Hz)", gee),
            st.builds(lambda x, t: f"{x}*sqrt({t})", gee, t),
        )
    return st.one_of(  # length / time^2.5
        st.builds(lambda x, t, u: f"{x}/{t}^2/sqrt({u})", length, t, t),
        st.builds(lambda x, t, u: f"{x}/{t}/{u}^1.5", length, t, t),
        st.builds(lambda x, t: f"{x}/sqrt({t})", gee, t),
    )


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    sensor=st.sampled_from(["gyro", "accelerometer"]),
    data=st.data(),
)
def test_same_record_same_coefficients_in_every_unit(sensor, data):
    rates = GYRO_RATES if sensor == "gyro" else ACCEL_RATES
    record_unit = data.draw(st.sampled_from(rates), label="record unit")
    display = data.draw(st.sampled_from(rates), label="display rate")
    n_unit = data.draw(st.sampled_from(N_UNITS[sensor]) | _composed(sensor, "N"), label="N unit")
    k_unit = data.draw(st.sampled_from(K_UNITS[sensor]) | _composed(sensor, "K"), label="K unit")
    reference = _fit_in("rad/s" if sensor == "gyro" else "m/s^2")
    fit = _fit_in(record_unit)
    # the fit itself is scale-equivariant: the SI values agree
    for name in ("N", "K"):
        assert math.isclose(_si(fit, name), _si(reference, name), rel_tol=1e-9)
    # a display rate unit: N in <angle>/sqrt(T), K in <angle>/T/sqrt(T), ...
    for table in (fit.table(units=display), fit.table(units={"N": n_unit, "K": k_unit})):
        for row in table:
            expected = _si(reference, row["name"]) / parse_unit(row["unit"]).scale
            assert math.isclose(row["value"], expected, rel_tol=1e-9), (row, expected)
    assert fit.model.sensor == sensor


@pytest.mark.parametrize("unit", ["dph", "deg/h", "deg/min", "rpm", "arcsec/s", "ug", "gal"])
def test_every_rate_unit_is_accepted_everywhere(unit):
    # analyse, fit, table, model JSON, in_units: no place refuses a rate unit
    fit = _fit_in(unit)
    assert fit.table(units=unit)
    model = NoiseModel.from_json(fit.model.to_json())
    assert model.units["rate"] == unit
    base = "rad/s" if sensor_kind(unit) == "gyro" else "m/s^2"
    back = model.in_units(base)
    assert math.isclose(back.coefficients()["N"], _si(fit, "N"), rel_tol=1e-9)


def test_deg_per_hour_record_reads_like_deg_per_second():
    # the defect of issue 13: a deg/h record printed N 60x too large in deg/sqrt(h)
    a = {r["name"]: r["value"] for r in _fit_in("deg/s").table(units="deg/h")}
    b = {r["name"]: r["value"] for r in _fit_in("deg/h").table(units="deg/h")}
    c = {r["name"]: r["value"] for r in _fit_in("dph").table(units="deg/h")}
    for name in ("N", "K"):
        assert math.isclose(a[name], b[name], rel_tol=1e-9)
        assert math.isclose(a[name], c[name], rel_tol=1e-9)
    # and the coefficient's own unit is exact: N of a deg/h model is in deg/h * sqrt(s)
    assert parse_unit(_fit_in("deg/h")["N"].unit).scale == pytest.approx(
        math.pi / 180 / 3600, rel=1e-12
    )


@pytest.mark.parametrize(
    ("sensor_unit", "wrong"),
    [("deg/s", "m/s^2"), ("deg/h", "deg"), ("m/s^2", "deg/h"), ("g", "m/s")],
)
def test_wrong_dimension_is_refused_naming_both(sensor_unit, wrong):
    fit = _fit_in(sensor_unit)
    with pytest.raises(ValueError, match="cannot convert") as info:
        fit.table(units={"N": wrong})
    assert repr(wrong) in str(info.value)
    assert fit["N"].unit in str(info.value)
    with pytest.raises(ValueError, match="cannot") as info:
        fit.model.in_units("m/s^2" if sensor_kind(sensor_unit) == "gyro" else "rad/s")
    assert sensor_unit in str(info.value)


def test_display_rate_of_another_sensor_is_refused():
    with pytest.raises(ValueError, match=r"'m/s\^2' \(acceleration\)"):
        _fit_in("deg/s").table(units="m/s^2")
    with pytest.raises(ValueError, match="not a rate unit: it is an angle"):
        _fit_in("deg/s").table(units="deg")


# --- accelerometer units ----------------------------------------------------------------------


def test_standard_gravity_is_defined_once():
    from allanite.impact.earth import STANDARD_GRAVITY as earth_g

    assert STANDARD_GRAVITY == 9.80665
    assert earth_g is STANDARD_GRAVITY
    assert convert(1.0, "g", "m/s^2") == 9.80665
    assert math.isclose(convert(1.0, "ug", "m/s^2"), 9.80665e-6, rel_tol=1e-12)
    assert math.isclose(convert(1.0, "mg", "ug"), 1000.0, rel_tol=1e-12)
    assert math.isclose(convert(1.0, "gal", "m/s^2"), 0.01, rel_tol=1e-12)
    assert math.isclose(convert(1.0, "ft/s^2", "m/s^2"), 0.3048, rel_tol=1e-12)
    assert math.isclose(convert(1.0, "cm/s²", "gal"), 1.0, rel_tol=1e-12)


@pytest.mark.parametrize(
    ("value", "src", "dst", "expected"),
    [
        # VRW: 1 m/s/sqrt(h) = 1/60 m/s/sqrt(s) = 1/60 m/s^2/sqrt(Hz)
        (1.0, "m/s/sqrt(h)", "m/s^2/sqrt(Hz)", 1.0 / 60.0),
        (1.0, "ug/sqrt(Hz)", "m/s/sqrt(h)", 9.80665e-6 * 60.0),
        (1.0, "mg/√Hz", "ug/√Hz", 1000.0),
        (1.0, "μg", "µg", 1.0),  # Greek mu and the micro sign
        (1.0, "μrad/s", "urad/s", 1.0),
        # acceleration random walk: m/s/h^1.5 = m/s^2/sqrt(h) * ... = 1/(3600*60) m/s^2/sqrt(s)
        (1.0, "m/s/h^1.5", "m/s^2/sqrt(s)", 1.0 / (3600.0 * 60.0)),
        (1.0, "m/s^3", "m/s^2/h", 3600.0),
    ],
)
def test_accelerometer_conversions(value, src, dst, expected):
    assert math.isclose(convert(value, src, dst), expected, rel_tol=1e-12)


def test_quantities_and_sensors():
    assert quantity("deg/h") == "angular rate"
    assert quantity("mg") == "acceleration"
    assert quantity("m/s") == "velocity"
    assert quantity("deg") == "angle"
    assert sensor_kind("dph") == "gyro"
    assert sensor_kind("ft/s^2") == "accelerometer"
    assert sensor_kind("unit") == "unknown"
    assert integral_unit("deg") == "deg/s"
    assert parse_unit(integral_unit("m/s")).same_dimension(parse_unit("m/s^2"))
    with pytest.raises(ValueError, match="unit of an angle or increment record is an angle"):
        integral_unit("deg/s")


def test_accelerometer_display_and_customary_units():
    assert display_unit("m/s^2", "N") == "m/s/sqrt(s)"
    assert display_unit("ug", "N") == "ug/sqrt(Hz)"
    assert display_unit("mg", "B") == "mg"
    assert display_unit("m/s^2", "K") == "m/s^2/sqrt(s)"
    assert display_unit("m/s^2", "Q") == "m/s"
    expected = {"N": "m/s/sqrt(h)", "B": "ug", "K": "m/s^2/sqrt(s)", "Q": "m/s", "R": "m/s^2/h"}
    for name, unit in expected.items():
        own = coefficient_unit("g", *_powers(name))
        assert customary_unit("g", name, own) == unit
    assert customary_unit("dph", "N", coefficient_unit("dph", 1, 0.5)) == "deg/sqrt(h)"
    assert customary_unit("deg/s", "tau_c", coefficient_unit("deg/s", 0, 1)) == "s"


def _powers(name: str) -> tuple[float, float]:
    from allanite.units import SYMBOL_POWERS

    return SYMBOL_POWERS[name]


def test_accelerometer_model_json_and_names():
    model = NoiseModel(
        (White(N=6e-4), Flicker(B=2e-4), RateRandomWalk(K=1e-5)), {"rate": "m/s^2", "time": "s"}
    )
    again = NoiseModel.from_json(model.to_json())
    assert again == model
    assert again.sensor == "accelerometer"
    units = again.coefficient_units()
    assert units["N"].text == "m/s/sqrt(s)"
    assert units["B"].text == "m/s^2"
    in_g = again.in_units("ug")
    assert math.isclose(in_g.coefficients()["B"], 2e-4 / 9.80665e-6, rel_tol=1e-12)
    described = {
        spec.name: spec.describe("accelerometer") for _, _, spec in model.labelled_parameters()
    }
    assert described == {
        "N": "velocity random walk",
        "B": "bias instability",
        "K": "acceleration random walk",
    }
    assert White.params[0].describe("gyro") == "angle random walk"


def test_unparseable_and_unknown_units():
    with pytest.raises(ValueError, match="unknown unit 'furlong'"):
        rate_unit("furlong/s")
    with pytest.raises(ValueError, match="is not a rate unit: it is a velocity"):
        rate_unit("m/s")
    with pytest.raises(ValueError, match="empty"):
        parse_unit("  ")


# --- the documented model JSON schema ----------------------------------------------------------

DOCS = Path(__file__).resolve().parents[1] / "docs"
README = Path(__file__).resolve().parents[1] / "README.md"


def test_schema_file_is_generated_from_the_terms():
    from allanite.model import json_schema
    from allanite.terms import TERM_TYPES

    stored = json.loads((DOCS / "noise-model.schema.json").read_text(encoding="utf-8"))
    assert stored == json_schema(), "regenerate docs/noise-model.schema.json from json_schema()"
    variants = stored["properties"]["terms"]["items"]["oneOf"]
    assert {v["properties"]["type"]["const"] for v in variants} == set(TERM_TYPES)
    white = next(v for v in variants if v["properties"]["type"]["const"] == "white")
    assert "velocity random walk" in white["properties"]["N"]["description"]
    assert "rate*s^0.5" in white["properties"]["N"]["description"]


@pytest.mark.parametrize("path", [DOCS / "units.md", README], ids=["units.md", "README"])
def test_documented_model_json_examples_load(path):
    text = path.read_text(encoding="utf-8")
    blocks = [b.split("```", 1)[0] for b in text.split("```json")[1:]]
    assert blocks
    for block in blocks:
        model = NoiseModel.from_dict(json.loads(block))
        assert model.sensor in ("gyro", "accelerometer")


def test_rad_per_second_gyros_show_degrees_and_keep_si_in_the_model():
    """ROS and PX4 gyros record rad/s; their customary line reads like a datasheet (deg/sqrt(h),
    deg/h), the model (its JSON) keeps rad/s, and both are the same physical coefficients."""
    expected = {"N": "deg/sqrt(h)", "B": "deg/h", "K": "deg/h/sqrt(h)", "R": "deg/h^2"}
    for rate in ("rad/s", "mrad/s", "rpm", "deg/s"):
        for name, unit in expected.items():
            assert customary_unit(rate, name, coefficient_unit(rate, *_powers(name))) == unit
    assert customary_unit("rad/s", "Q", coefficient_unit("rad/s", *_powers("Q"))) == "deg"
    assert customary_unit("arcsec/s", "N", coefficient_unit("arcsec/s", 1, 0.5)) == (
        "deg/sqrt(h)"  # issue 30 item 9: datasheet units whatever the record's angle
    )
    from allanite.units import display_angle

    with display_angle("arcsec"):
        assert customary_unit("arcsec/s", "N", coefficient_unit("arcsec/s", 1, 0.5)) == (
            "arcsec/sqrt(h)"
        )
        assert customary_unit("rad/s", "B", coefficient_unit("rad/s", 1, 0)) == "arcsec/h"
    assert customary_unit("rad/s", "B", coefficient_unit("rad/s", 1, 0)) == "deg/h"
    x = np.random.default_rng(5).standard_normal(50_000) * 0.01  # rad/s at 100 Hz
    fitted = allanite.fit(x, fs=100.0, units="rad/s", terms=["N"])
    (row,) = fitted.table("customary")
    assert row["unit"] == "deg/sqrt(h)"
    si = fitted["N"]
    assert si.unit == "rad/sqrt(s)"
    assert si.value == pytest.approx(0.01 / 10.0, rel=5 * si.stderr / si.value)
    assert row["value"] == pytest.approx(convert(si.value, si.unit, "deg/sqrt(h)"), rel=1e-12)
    model = json.loads(fitted.model.to_json())  # the SI value, as fitted
    assert model["units"]["rate"] == "rad/s"
    assert model["terms"][0]["N"] == si.value


def test_export_notes_and_diagnosis_text_share_one_conversion():
    """describe_term (export notes) and format_params (diagnosis text) both show a term's
    coefficient through customary_value: a rad/s Gauss-Markov sigma in deg/h."""
    from allanite.diagnosis.verdict import param_unit, shown_param
    from allanite.formats.base import describe_term
    from allanite.terms import GaussMarkov
    from allanite.units import coefficient_text, customary_value

    assert param_unit is coefficient_text
    assert shown_param is customary_value
    own = coefficient_text("rad/s", 1, 0)
    assert own == "rad/s"
    value, unit = customary_value("sigma", 1.9e-3, own, "rad/s")
    assert unit == "deg/h"
    assert value == pytest.approx(1.9e-3 * 180 / math.pi * 3600, rel=1e-12)
    term = GaussMarkov(sigma=1.9e-3, tau_c=0.024)
    assert describe_term(term, "gyro") == f"markov (sigma={value:.4g} deg/h, tau_c=0.024 s)"
    assert describe_term(term) == "markov (sigma=0.0019, tau_c=0.024 s)"
    assert coefficient_text(None, 1, 0.5) == "rate*s^0.5"
    assert customary_value("N", 2.0, "unit*sqrt(s)", "unit") == (2.0, "unit*sqrt(s)")
