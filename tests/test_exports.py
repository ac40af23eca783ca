"""Exports to MATLAB gyroparams and Kalibr imu.yaml: values, SI units, files."""

from __future__ import annotations

import math

import pytest
import yaml

from allanite.exports import (
    KALIBR_UNITS,
    MATLAB_UNITS,
    kalibr_imu,
    kalibr_imu_yaml,
    matlab_gyroparams,
    matlab_gyroparams_script,
    save_kalibr_imu_yaml,
    save_matlab_gyroparams,
)
from allanite.model import NoiseModel
from allanite.terms import Flicker, GaussMarkov, Quantization, RateRandomWalk, White

D2R = math.pi / 180
# deg/s model: N = 0.3 deg/sqrt(h) = 0.005 deg/sqrt(s), B = 3.6 deg/h = 0.001 deg/s,
# K = 21.6 deg/h/sqrt(h) = 1e-4 deg/s/sqrt(s)
MODEL = NoiseModel(
    (White(N=0.005), Flicker(B=0.001), RateRandomWalk(K=1e-4), Quantization(Q=1e-3)),
    {"rate": "deg/s", "time": "s"},
)


def test_matlab_fields_are_si():
    p = matlab_gyroparams(MODEL)
    assert math.isclose(p["NoiseDensity"], 0.005 * D2R)  # single-sided: NoiseDensity = N
    assert math.isclose(p["RandomWalk"], 1e-4 * D2R)
    assert p["NoiseType"] == "single-sided"
    # imuSensor's bias instability is a filtered white noise, not flicker: B is projected onto
    # its first-order (Gauss-Markov) filter, and said
    assert 0 < p["BiasInstability"] < 0.001 * D2R
    assert "'Denominator', [1 -0.99" in p["BiasInstabilityCoefficients"]
    assert p["units"] == MATLAB_UNITS
    assert len(p["not_exported"]) == 2
    assert p["not_exported"][0].startswith("gyro: quantization")
    assert p["not_exported"][1].startswith("gyro: flicker")


def test_matlab_from_a_deg_per_hour_model_gives_the_same_numbers():
    assert matlab_gyroparams(MODEL.in_units("deg/h"))["RandomWalk"] == pytest.approx(1e-4 * D2R)


def test_matlab_script(tmp_path):
    text = matlab_gyroparams_script(MODEL, "g")
    assert "g = gyroparams(" in text
    assert f"'NoiseDensity', {0.005 * D2R:.10g}" in text
    assert "(rad/s)/sqrt(Hz)" in text
    assert "quantization" in text
    path = tmp_path / "gyro.m"
    save_matlab_gyroparams(path, MODEL)
    assert path.read_text() == matlab_gyroparams_script(MODEL)
    with pytest.raises(ValueError, match="identifier"):
        matlab_gyroparams_script(MODEL, "1x")


def test_kalibr_yaml_parses_with_si_values(tmp_path):
    path = tmp_path / "imu.yaml"
    save_kalibr_imu_yaml(path, MODEL, 200.0, accelerometer_noise_density=2e-3)
    data = yaml.safe_load(path.read_text())
    assert data["update_rate"] == 200.0
    assert data["rostopic"] == "/imu0"
    assert math.isclose(data["gyroscope_noise_density"], 0.005 * D2R, rel_tol=1e-9)
    # the flicker term is not representable: folded into the random walk, which grows
    assert data["gyroscope_random_walk"] > 1e-4 * D2R
    assert "# projected: gyro: rrw" in path.read_text()
    assert data["accelerometer_noise_density"] == 2e-3
    assert data["accelerometer_random_walk"] == 0.0  # Kalibr needs all four keys
    text = path.read_text()
    for key in ("gyroscope_noise_density", "gyroscope_random_walk"):
        assert KALIBR_UNITS[key] in text


def test_kalibr_missing_terms_are_zero_and_gm_is_projected():
    white = NoiseModel((White(N=0.01),), {"rate": "rad/s", "time": "s"})
    entries = kalibr_imu(white, 100.0)
    assert entries["gyroscope_random_walk"] == 0.0
    assert entries["not_exported"] == []
    model = NoiseModel((White(N=0.01), GaussMarkov(0.1, 5.0)), {"rate": "rad/s", "time": "s"})
    entries = kalibr_imu(model, 100.0)
    # the Gauss-Markov bias cannot be held: it is projected onto the random walk and the
    # white noise (a 5 s Gauss-Markov looks white beyond a minute), and said
    assert entries["gyroscope_noise_density"] > 0.01
    assert entries["gyroscope_random_walk"] > 0.0
    assert len(entries["not_exported"]) == 1
    assert "markov (sigma=2.063e+04 deg/h, tau_c=5 s)" in entries["not_exported"][0]  # 0.1 rad/s
    assert "-> rrw" in entries["not_exported"][0]
    assert "markov" in kalibr_imu_yaml(model, 100.0)


def test_export_errors():
    with pytest.raises(ValueError, match="update_rate"):
        kalibr_imu(MODEL, 0.0)
    with pytest.raises(TypeError, match="NoiseModel"):
        matlab_gyroparams({"N": 1})  # type: ignore[arg-type]
    two = MODEL.plus(White(N=0.1))
    with pytest.raises(ValueError, match="2 'white' terms"):
        matlab_gyroparams(two)
