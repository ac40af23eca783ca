"""Unit parsing, conversion and customary display units of noise coefficients."""

from __future__ import annotations

import math

import pytest

from allanite.units import convert, display_unit, parse_unit, rate_unit


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
