"""``allanite diagnose`` shows fitted parameters in the customary units of ``allanite fit``.

The text (CLI, headline, report) converts with :mod:`allanite.units` (N in deg/sqrt(h), K in
deg/h/sqrt(h), sigma in deg/h for deg/s and rad/s gyros alike); the JSON keeps the values in
the model's units and states them in ``params_units`` next to ``params``.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from allanite.cli import main
from allanite.diagnosis import diagnose
from allanite.diagnosis.verdict import format_params, shown_param
from allanite.model import NoiseModel
from allanite.report.diagnosis import diagnosis_html
from allanite.terms import RateRandomWalk, White
from allanite.units import convert

FS = 100.0
N_SAMPLES = 2**15
#: the simulated sensor: N 0.01 deg/sqrt(s) = 0.6 deg/sqrt(h), K 1e-4 deg/s/sqrt(s)
MODEL = NoiseModel((White(N=0.01), RateRandomWalk(K=1e-4)), {"rate": "deg/s", "time": "s"})
#: the real sensor's white noise is 1.6x the model's: N = 0.016 deg/sqrt(s) = 0.96 deg/sqrt(h)
TRUE_N_DEG_SQRT_H = 0.016 * 60.0


@pytest.fixture(scope="module")
def real_deg_s() -> np.ndarray:
    real = MODEL.without("white").plus(White(N=0.016))
    return np.asarray(real.simulate(N_SAMPLES, fs=FS, seed=5)).ravel()


def _cli(tmp_path, x: np.ndarray, rate: str, *extra: str) -> None:
    model = tmp_path / f"model_{rate.replace('/', '_')}.json"
    MODEL.in_units(rate).save(model)
    real = tmp_path / "real.npy"
    np.save(real, x)
    rc = main(
        ["diagnose", str(real), "--fs", str(FS), "--units", rate, "--sim-model", str(model),
         "--n-mc", "30", "--seed", "2", *extra]
    )  # fmt: skip
    assert rc == 0


def _white_n(text: str) -> float:
    """The white-noise N of the best attribution's row, in deg/sqrt(h), from the CLI text."""
    row = next(line for line in text.splitlines() if line.strip().startswith(("rescale:white",)))
    match = re.search(r"N = ([0-9.eE+-]+) (?:± [0-9.eE+-]+ )?deg/sqrt\(h\)", row)
    assert match is not None, row
    return float(match.group(1))


@pytest.mark.parametrize(("rate", "factor"), [("deg/s", 1.0), ("rad/s", np.pi / 180.0)])
def test_cli_shows_customary_units_and_json_states_model_units(
    tmp_path, capsys, real_deg_s, rate, factor
):
    """The same record in deg/s and in rad/s: the text shows N in deg/sqrt(h) (the value the
    fit shows), the JSON holds N in the model's unit with ``params_units`` next to it."""
    _cli(tmp_path, real_deg_s * factor, rate)
    text = capsys.readouterr().out
    assert "deg/sqrt(s)" not in text
    assert "rad/sqrt(s)" not in text
    shown = _white_n(text)
    _cli(tmp_path, real_deg_s * factor, rate, "--json")
    data = json.loads(capsys.readouterr().out)
    best = next(a for a in data["attribution"] if a["effect"] == "rescale:white")
    unit = best["params_units"]["N"]
    assert unit == {"deg/s": "deg/sqrt(s)", "rad/s": "rad/sqrt(s)"}[rate]
    assert best["params_units"]["scale"] == ""
    # the text is the JSON value converted, to its 4 printed digits
    assert shown == pytest.approx(convert(best["params"]["N"], unit, "deg/sqrt(h)"), rel=1e-3)
    # and it is the real sensor's N, within 4 sd of the fit (the tau view's Fisher sd)
    sd = convert(best["params_sigma"]["N"], unit, "deg/sqrt(h)")
    assert abs(shown - TRUE_N_DEG_SQRT_H) < 4 * sd
    first = data["explanation"]["effects"][0]
    assert set(first["params_units"]) == set(first["params"])


def test_deg_per_hour_record_end_to_end(tmp_path, capsys, real_deg_s):
    """A record in deg/h: N in the JSON in deg/h*sqrt(s) (1/60 of a deg/sqrt(h)), shown in
    deg/sqrt(h) with the same value as the deg/s record's."""
    _cli(tmp_path, real_deg_s * 3600.0, "deg/h", "--json")
    data = json.loads(capsys.readouterr().out)
    best = next(a for a in data["attribution"] if a["effect"] == "rescale:white")
    unit = best["params_units"]["N"]
    assert unit == "deg/h*sqrt(s)"
    n = convert(best["params"]["N"], unit, "deg/sqrt(h)")
    sd = convert(best["params_sigma"]["N"], unit, "deg/sqrt(h)")
    assert abs(n - TRUE_N_DEG_SQRT_H) < 4 * sd
    _cli(tmp_path, real_deg_s * 3600.0, "deg/h")
    assert _white_n(capsys.readouterr().out) == pytest.approx(n, rel=1e-3)


def test_headline_and_report_use_the_same_units(real_deg_s):
    d = diagnose(real_deg_s, MODEL, fs=FS, units="deg/s", n_mc=30, seed=2)
    assert d.best is not None
    assert "deg/sqrt(h)" in d.headline
    assert "deg/sqrt(s)" not in d.headline
    html = diagnosis_html(d, channel="gyro x", model_name="model.json")
    text = format_params(d.best, "deg/s", fs=FS, sigma=True)
    assert "±" in text
    assert "deg/sqrt(h)" in text
    assert "deg/sqrt(h)" in html
    assert "deg/sqrt(s)" not in html


@pytest.mark.parametrize(
    ("rate", "name", "powers", "unit"),
    [("deg/s", "N", (1, 0.5), "deg/sqrt(h)"), ("rad/s", "K", (1, -0.5), "deg/h/sqrt(h)"),
     ("deg/s", "sigma", (1, 0), "deg/h"), ("deg/s", "tau_c", (0, 1), "s"),
     ("deg/s", "frequency", (0, -1), "Hz"), ("m/s^2", "N", (1, 0.5), "m/s/sqrt(h)")],
)  # fmt: skip
def test_shown_param_is_the_fit_customary_unit(rate, name, powers, unit):
    from allanite.diagnosis.verdict import param_unit

    own = param_unit(rate, *powers)
    value, shown = shown_param(name, 2.0, own, rate)
    assert shown == unit
    assert value == pytest.approx(convert(2.0, own, unit))


def test_without_a_rate_unit_the_record_units_are_kept():
    from allanite.diagnosis.verdict import param_unit

    own = param_unit(None, 1, 0.5)
    assert own == "rate*s^0.5"
    assert shown_param("N", 2.0, own, None) == (2.0, own)


def test_corrected_config_note_uses_the_same_units():
    """``--write-corrected`` says what it folded in with the CLI's text: N of a deg/s model and
    of a rad/s model (the same white noise) both in deg/sqrt(h)."""
    from types import SimpleNamespace

    from allanite.formats.corrected import corrected_model

    def white(n: float) -> SimpleNamespace:
        return SimpleNamespace(
            effect="white",
            term={"type": "white", "N": n},
            params={"N": n},
            params_sigma={},
            gap_before=100.0,
            gap_after=1.0,
            shrinkage=0.99,
        )

    for model, n in ((MODEL, 0.016), (MODEL.in_units("rad/s"), 0.016 * np.pi / 180.0)):
        diagnosis = SimpleNamespace(significant=True, attribution=[white(n)], explanation=None)
        _, what = corrected_model(model, diagnosis)
        # the added white merges with the configured one: the N written is said too
        assert what.startswith(
            "folded in white (N = 0.96 deg/sqrt(h) added to the configured white: written "
            "N = 1.132 deg/sqrt(h)); gap 100 -> 1"
        ), what
