"""NoiseModel: sums, JSON schema round trip, validation errors, unit change."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from allanite.model import NoiseModel
from allanite.terms import Flicker, GaussMarkov, Quantization, RateRamp, RateRandomWalk, Sine, White

MODEL = NoiseModel(
    (
        White(N=6.153e-3),
        Quantization(Q=2.45e-3),
        Flicker(B=6.619e-5),
        RateRandomWalk(K=8.1e-4),
        RateRamp(R=1.039e-8),
        GaussMarkov(sigma=1e-3, tau_c=20.0),
        Sine(amplitude=1e-3, frequency=1.5),
    ),
    {"rate": "deg/s", "time": "s"},
)


def test_avar_is_sum_of_terms():
    tau = np.array([0.01, 1.0, 100.0])
    total = sum(t.avar(tau, 0.01) for t in MODEL.terms)
    assert np.allclose(MODEL.avar(tau, 0.01), total)
    assert np.allclose(MODEL.adev(tau, 0.01) ** 2, total)


def test_psd_needs_stationary_terms():
    f = np.array([0.1, 1.0])
    with pytest.raises(ValueError, match="psd_sampled"):
        MODEL.psd(f)
    with pytest.raises(ValueError, match="not stationary"):
        MODEL.without("quantization").psd(f)
    stationary = MODEL.without("ramp", "quantization")
    assert np.allclose(stationary.psd(f), sum(t.psd(f) for t in stationary.terms))


def test_json_round_trip(tmp_path):
    text = MODEL.to_json()
    data = json.loads(text)
    assert data["units"] == {"rate": "deg/s", "time": "s"}
    assert data["terms"][0] == {"type": "white", "N": 6.153e-3}
    assert data["terms"][5] == {"type": "markov", "sigma": 1e-3, "tau_c": 20.0}
    assert NoiseModel.from_json(text) == MODEL
    path = tmp_path / "m.json"
    MODEL.save(path)
    assert NoiseModel.load(path) == MODEL


def test_terms_of_type_and_coefficients():
    two = MODEL.plus(GaussMarkov(sigma=2e-3, tau_c=0.5))
    assert len(two.terms_of_type("markov")) == 2
    assert two.terms_of_type(White) == (White(N=6.153e-3),)
    coef = two.coefficients()
    assert coef["N"] == 6.153e-3
    assert coef["sigma_1"] == 1e-3
    assert coef["tau_c_2"] == 0.5
    with pytest.raises(ValueError, match="unknown term type"):
        MODEL.terms_of_type("pink")


def test_in_units_converts_every_coefficient():
    rad = MODEL.in_units("rad/s")
    d2r = math.pi / 180
    assert math.isclose(rad.terms_of_type("white")[0].N, 6.153e-3 * d2r)
    assert math.isclose(rad.terms_of_type("markov")[0].tau_c, 20.0)
    assert math.isclose(rad.terms_of_type("sine")[0].frequency, 1.5)
    tau = np.array([0.1, 10.0])
    assert np.allclose(rad.avar(tau, 0.01), MODEL.avar(tau, 0.01) * d2r**2)
    dph = MODEL.in_units("deg/h")
    assert math.isclose(dph.terms_of_type("flicker")[0].B, 6.619e-5 * 3600)


@pytest.mark.parametrize(
    ("data", "error", "match"),
    [
        (
            {"units": {"rate": "deg/s", "time": "s"}, "terms": [{"type": "white"}]},
            ValueError,
            "missing",
        ),
        ({"units": {"rate": "deg", "time": "s"}, "terms": []}, ValueError, "not a rate unit"),
        ({"units": {"rate": "furlong/s", "time": "s"}, "terms": []}, ValueError, "unknown unit"),
        ({"units": {"rate": "deg/s", "time": "h"}, "terms": []}, ValueError, "time must be 's'"),
        ({"units": {"rate": "deg/s"}, "terms": []}, ValueError, "missing"),
        ({"terms": []}, ValueError, "'units'"),
        ({"units": {"rate": "deg/s", "time": "s"}}, ValueError, "'terms'"),
        (
            {"units": {"rate": "deg/s", "time": "s"}, "terms": [{"type": "bogus", "x": 1}]},
            ValueError,
            r"terms\[0\]: unknown term type",
        ),
        (
            {"units": {"rate": "deg/s", "time": "s"}, "terms": [{"type": "white", "N": -1}]},
            ValueError,
            "non-negative",
        ),
    ],
)
def test_bad_json_models(data, error, match):
    with pytest.raises(error, match=match):
        NoiseModel.from_json(json.dumps(data))


def test_not_json_and_not_terms():
    with pytest.raises(ValueError, match="not valid JSON"):
        NoiseModel.from_json("{units")
    with pytest.raises(TypeError, match="Term instances"):
        NoiseModel((1.0,), {"rate": "deg/s", "time": "s"})  # type: ignore[arg-type]


def test_load_names_the_file_and_what_a_model_is(tmp_path, capsys):
    """Regression: an .npy given as the model raised UnicodeDecodeError, a missing file a raw
    '[Errno 2]'; both, and the other sample formats, are one clear InputError."""
    from allanite.cli import main
    from allanite.diagnosis import diagnose
    from allanite.errors import InputError

    samples = tmp_path / "rec.npy"
    np.save(samples, np.zeros(10))
    npz = tmp_path / "rec.npz"
    np.savez(npz, a=np.zeros(3))
    binary = tmp_path / "model.json"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    broken = tmp_path / "broken.json"
    broken.write_text('{"terms": [')
    cases = [
        (samples, r"rec.npy: this is a NumPy .npy array \(recorded or simulated samples\), not a "),
        (npz, r"rec.npz: this is a NumPy .npz archive"),
        (binary, r"model.json: not a text file, so not a noise model"),
        (tmp_path / "nope.json", r"nope.json: no such model file; check the path"),
        (tmp_path, r"is a directory, not a model file"),
    ]
    for path, match in cases:
        with pytest.raises(InputError, match=match):
            NoiseModel.load(path)
    with pytest.raises(ValueError, match=r"broken.json: the noise model is not valid JSON"):
        NoiseModel.load(broken)
    # the API of diagnose and the simulate command go through the same load
    with pytest.raises(InputError, match=r"rec.npy: this is a NumPy .npy array"):
        diagnose(np.random.default_rng(0).standard_normal(2000), samples, fs=100.0)
    argv = ["simulate", str(samples), "--fs", "100", "-n", "100", "-o", str(tmp_path / "s.npy")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "not a noise model; a noise model is JSON text, as written by 'allanite fit" in err
    assert not (tmp_path / "s.npy").exists()


def test_units_as_the_rate_unit_alone():
    """Regression: ``units="deg/s"`` failed with dict()'s "update sequence element #0"."""
    data = {"units": "deg/h", "terms": [{"type": "white", "N": 0.1}]}
    model = NoiseModel.from_dict(data)
    assert model.units == {"rate": "deg/h", "time": "s"}
    assert NoiseModel(model.terms, "rad/s").units == {"rate": "rad/s", "time": "s"}
    with pytest.raises(ValueError, match="unknown unit"):
        NoiseModel.from_dict({"units": "furlong/s", "terms": []})
    with pytest.raises(TypeError, match="a rate unit such as 'deg/s' or a dict"):
        NoiseModel(model.terms, 3)  # type: ignore[arg-type]
