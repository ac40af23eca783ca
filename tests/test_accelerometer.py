"""Accelerometers as first-class sensors, six-axis records, records without a unit."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import allanite
from allanite.cli import main
from allanite.datasheet import Datasheet, check_limits
from allanite.gui.session import display_units_for
from allanite.model import NoiseModel
from allanite.report import DeviceAnalysis, build_report, coefficient_table, slope_table
from allanite.terms import RateRandomWalk, White
from allanite.units import STANDARD_GRAVITY, convert

FS = 100.0
N_ACCEL = 2e-3  # m/s^2*sqrt(s) = m/s/sqrt(s): velocity random walk
K_ACCEL = 1e-4  # m/s^2/sqrt(s): acceleration random walk
N_GYRO = 0.01  # deg/sqrt(s)
ACCEL_MODEL = NoiseModel(
    (White(N=N_ACCEL), RateRandomWalk(K=K_ACCEL)), {"rate": "m/s^2", "time": "s"}
)


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


# --- library: analyse, fit, simulate, report an accelerometer --------------------------------


@pytest.fixture(scope="module")
def accel_record() -> np.ndarray:
    return ACCEL_MODEL.simulate(200_000, fs=FS, seed=5)


def test_accelerometer_fit_recovers_the_model_in_any_acceleration_unit(accel_record):
    fits = {}
    for unit in ("m/s^2", "mg", "ug", "ft/s^2", "gal"):
        x = accel_record * convert(1.0, "m/s^2", unit)
        res = allanite.oadev(x, fs=FS, units=unit, taus="octave")
        fits[unit] = allanite.fit(res, terms=["white", "rrw"])
    si = fits["m/s^2"]
    n, k = si["N"], si["K"]
    # the truth within 4 standard errors (fixed seed)
    assert abs(n.value - N_ACCEL) < 4 * n.stderr
    assert abs(k.value - K_ACCEL) < 4 * k.stderr
    # every unit shows the same physical coefficients, in customary units
    for fit in fits.values():
        rows = {r.symbol: r for r in coefficient_table(fit, None)}
        assert rows["N"].unit == "m/s/sqrt(h)"
        assert rows["N"].quantity == "velocity random walk"
        assert rows["K"].unit == "m/s^2/sqrt(s)"  # = m/s^3/sqrt(Hz), Kalibr's random walk
        assert rows["K"].quantity == "acceleration random walk"
        assert rows["N"].value == pytest.approx(60 * n.value, rel=1e-9)
        assert rows["K"].value == pytest.approx(k.value, rel=1e-9)
        table = {r["name"]: r for r in fit.table(units="ug")}
        assert table["N"]["unit"] == "ug/sqrt(Hz)"
        assert table["N"]["value"] == pytest.approx(n.value / (1e-6 * STANDARD_GRAVITY), rel=1e-9)
    assert fits["mg"].model.sensor == "accelerometer"


def test_velocity_increments_are_an_accelerometer_record(accel_record):
    # delta-velocity samples in m/s: their rate is m/s/s = m/s^2
    dv = ACCEL_MODEL.simulate(200_000, fs=FS, seed=5, output="increment")
    res = allanite.oadev(dv, fs=FS, input="increment", units="m/s", taus="octave")
    ref = allanite.oadev(accel_record, fs=FS, units="m/s^2", taus="octave")
    assert res.units == "m/s^2"
    np.testing.assert_allclose(res.dev, ref.dev, rtol=1e-9)


def test_accelerometer_slope_names_and_report(accel_record):
    res = allanite.oadev(accel_record, fs=FS, units="m/s^2")
    rows = slope_table(res.tau, res.dev, res.edf, sensor="accelerometer")
    assert rows[0].term.startswith("velocity random walk")
    assert rows[0].symbol == "N"
    record = allanite.io.Record(
        samples=accel_record[:, None], fs=FS, units="m/s^2", channels=("ax",), source="acc.npy"
    )
    fit = allanite.fit(res, terms=["white", "rrw"])
    report = build_report([DeviceAnalysis(record, res, (fit,))])
    assert "velocity random walk" in report.html
    assert "m/s/sqrt(h)" in report.html
    assert "angle random walk" not in report.html


def test_accelerometer_limits_apply_to_accelerometer_channels_only():
    sheet = Datasheet.from_dict(
        {
            "limits": [
                {"quantity": "N", "max": 0.5, "unit": "deg/sqrt(h)"},
                {"quantity": "N", "max": 0.1, "unit": "m/s/sqrt(h)"},
                {"quantity": "B", "max": 50, "unit": "ug"},
            ]
        }
    )
    assert [limit.sensor for limit in sheet.limits] == ["gyro", "accelerometer", "accelerometer"]
    model = NoiseModel((White(N=N_ACCEL),), {"rate": "m/s^2", "time": "s"})
    measured = {r.symbol: r.measured() for r in coefficient_table(model, None)}
    curve = (np.array([1.0]), np.array([1.0]), np.array([0.9]), np.array([1.1]), "m/s^2")
    checks = check_limits(sheet, "ax", measured, curve)
    # the gyro limit is left out; N = 0.12 m/s/sqrt(h) fails 0.1; B was not measured
    assert [(c.limit.unit, c.status) for c in checks] == [
        ("m/s/sqrt(h)", "fail"),
        ("ug", "missing"),
    ]
    assert checks[0].value == pytest.approx(60 * N_ACCEL)
    with pytest.raises(allanite.errors.InputError, match="furlong"):
        Datasheet.from_dict({"limits": [{"quantity": "N", "max": 1, "unit": "furlong"}]})


def test_gui_offers_the_display_units_of_the_record_sensor():
    assert "deg/h" in display_units_for("deg/s")
    assert "mg" not in display_units_for("deg/s")
    assert display_units_for("m/s^2") == ("as recorded", "m/s^2", "g", "mg", "ug")
    assert display_units_for(None) == ("as recorded",)


# --- six-axis records on the command line -----------------------------------------------------


@pytest.fixture(scope="module")
def imu_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    rng = np.random.default_rng(13)
    n = 40_000
    t = np.arange(n) / FS
    gyro = N_GYRO * np.sqrt(FS) * rng.standard_normal((n, 3))
    accel = N_ACCEL * np.sqrt(FS) * rng.standard_normal((n, 3))
    path = tmp_path_factory.mktemp("imu") / "imu.csv"
    np.savetxt(
        path,
        np.column_stack([t, gyro, accel]),
        delimiter=",",
        header="t,gx,gy,gz,ax,ay,az",
        comments="",
        fmt="%.10g",
    )
    return path


SIX = ["--time-column", "t", "--channels", "gx,gy,gz,ax,ay,az"]


@pytest.mark.parametrize(
    "units", ["deg/s,deg/s,deg/s,m/s^2,m/s^2,m/s^2", "deg/s,m/s^2"], ids=["per-channel", "groups"]
)
def test_six_axis_fit_gives_one_table_per_sensor(imu_csv, units, capsys):
    code, out, err = _run(["fit", str(imu_csv), *SIX, "--units", units, "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    channels = {c["channel"]: c for c in data["channels"]}
    assert list(channels) == ["gx", "gy", "gz", "ax", "ay", "az"]
    for name, item in channels.items():
        rows = {r["symbol"]: r for r in item["coefficients"]}
        if name.startswith("g"):
            assert (item["sensor"], item["units"]) == ("gyro", "deg/s")
            assert rows["N"]["quantity"] == "angle random walk"
            assert rows["N"]["unit"] == "deg/sqrt(h)"
            truth = 60 * N_GYRO
        else:
            assert (item["sensor"], item["units"]) == ("accelerometer", "m/s^2")
            assert rows["N"]["quantity"] == "velocity random walk"
            assert rows["N"]["unit"] == "m/s/sqrt(h)"
            assert item["model"]["units"] == {"rate": "m/s^2", "time": "s"}
            truth = 60 * N_ACCEL
        # white noise: N within its 68 % interval widened to ~4 sigma
        width = rows["N"]["high"] - rows["N"]["low"]
        assert abs(rows["N"]["value"] - truth) < 4 * width
    assert data["record"]["units"] == ["deg/s"] * 3 + ["m/s^2"] * 3
    code, out, err = _run(["fit", str(imu_csv), *SIX, "--units", units], capsys)
    assert code == 0, err
    assert "channel gx (gyro, deg/s):" in out
    assert "channel az (accelerometer, m/s^2):" in out
    assert "velocity random walk" in out


def test_six_axis_report_shows_both_sensors(imu_csv, tmp_path, capsys):
    sheet = tmp_path / "sheet.json"
    sheet.write_text(
        json.dumps(
            {
                "device": "IMU",
                "limits": [
                    {"quantity": "N", "max": 1.0, "unit": "deg/sqrt(h)"},
                    {"quantity": "N", "max": 1.0, "unit": "m/s/sqrt(h)"},
                ],
            }
        )
    )
    html = tmp_path / "imu.html"
    argv = ["report", str(imu_csv), *SIX, "--units", "deg/s,m/s^2", "-o", str(html)]
    code, out, err = _run([*argv, "--datasheet", str(sheet), "--json"], capsys)
    assert code == 0, err
    checks = json.loads(out)["checks"]
    # each channel is checked against its own sensor's limit only
    assert len(checks) == 6
    assert {c["unit"] for c in checks if c["channel"].endswith(("gx", "gy", "gz"))} == {
        "deg/sqrt(h)"
    }
    assert {c["unit"] for c in checks if c["channel"].endswith(("ax", "ay", "az"))} == {
        "m/s/sqrt(h)"
    }
    text = html.read_text()
    assert "imu.csv (gyro, deg/s)" in text
    assert "imu.csv (accelerometer, m/s^2)" in text
    assert "angle random walk" in text
    assert "velocity random walk" in text
    assert text.count('alt="Allan deviation plot"') == 2  # one figure per unit


def test_six_axis_bad_unit_lists(imu_csv, tmp_path, capsys):
    code, _, err = _run(["fit", str(imu_csv), *SIX, "--units", "deg/s,m/s^2,g,g"], capsys)
    assert code == 2
    assert "4 units for 6 channels" in err
    code, _, err = _run(["fit", str(imu_csv), *SIX, "--units", "deg/s,deg"], capsys)
    assert code == 2
    assert "ax, ay, az" in err
    assert "not a rate unit: it is an angle" in err
    target = tmp_path / "a.csv"
    code, _, err = _run(
        ["analyze", str(imu_csv), *SIX, "--units", "deg/s,m/s^2", "-o", str(target)], capsys
    )
    assert code == 2
    assert "one sensor at a time" in err
    assert not target.exists()


# --- one validation of a record's unit, and records without a unit ----------------------------


def test_analyze_refuses_units_like_fit(imu_csv, capsys):
    base = ["--time-column", "t", "--channels", "gx"]
    for command in ("analyze", "fit"):
        code, _, err = _run([command, str(imu_csv), *base, "--units", "furlong/s"], capsys)
        assert code == 2
        assert "unknown unit 'furlong'" in err
        assert len(err.strip().splitlines()) == 1
    code, _, err = _run(
        ["analyze", str(imu_csv), *base, "--input", "angle", "--units", "deg/s"], capsys
    )
    assert code == 2
    assert "the unit of an angle or increment record is an angle" in err
    assert "deg/s/s" not in err
    code, out, _ = _run(["analyze", str(imu_csv), *base, "--units", "dph", "--json"], capsys)
    assert code == 0
    assert json.loads(out)["record"]["units"] == "dph"


def test_records_without_units_are_shown_in_record_units(imu_csv, tmp_path, capsys):
    base = ["--time-column", "t", "--channels", "gx"]
    code, out, err = _run(["fit", str(imu_csv), *base], capsys)
    assert code == 0, err
    assert "no --units given: coefficients in the record's own units" in out
    assert "unit*sqrt(s)" in out
    assert "angle random walk / velocity random walk" in out  # the sensor is not known
    assert "deg" not in out
    # the library: no silent deg/s either
    x = np.random.default_rng(1).standard_normal(20_000)
    fit = allanite.fit(allanite.oadev(x, fs=FS, taus="octave"), terms=["white"])
    assert fit.model.units["rate"] == "unit"
    assert fit.model.sensor == "unknown"
    with pytest.raises(ValueError, match="cannot convert 'unit\\*sqrt\\(s\\)'"):
        fit.table(units={"N": "deg/sqrt(h)"})
    # a datasheet in physical units cannot be checked without the record's unit
    sheet = tmp_path / "sheet.json"
    sheet.write_text(json.dumps({"limits": [{"quantity": "N", "max": 1, "unit": "deg/sqrt(h)"}]}))
    code, _, err = _run(["fit", str(imu_csv), *base, "--datasheet", str(sheet)], capsys)
    assert code == 2
    assert "record's unit is not known" in err
    # batch says which unit its coefficient columns are in
    np.save(tmp_path / "a.npy", x)
    code, out, err = _run(["batch", str(tmp_path / "a.npy"), "--fs", "100"], capsys)
    assert code == 0, err
    assert "coefficients in record units" in out
    code, out, err = _run(
        ["batch", str(tmp_path / "a.npy"), "--fs", "100", "--units", "deg/h"], capsys
    )
    assert code == 0, err
    assert "N in deg/sqrt(h)" in out  # the units allanite fit prints


def test_navigation_impact_reads_the_accelerometer_unit():
    from allanite.impact.model_adapter import sensor_noise_from_model

    si = sensor_noise_from_model(ACCEL_MODEL, sensor="accel")
    in_mg = sensor_noise_from_model(ACCEL_MODEL.in_units("mg"), sensor="accel")
    assert si.white == pytest.approx(N_ACCEL, rel=1e-12)
    assert in_mg.white == pytest.approx(N_ACCEL, rel=1e-12)
    assert in_mg.random_walk == pytest.approx(K_ACCEL, rel=1e-12)
    with pytest.raises(ValueError, match="leave accel_scale at 1"):
        sensor_noise_from_model(ACCEL_MODEL, sensor="accel", accel_scale=9.8)
    with pytest.raises(ValueError, match=r"cannot convert 'm/s\^2' \(acceleration\)"):
        sensor_noise_from_model(ACCEL_MODEL, sensor="gyro")


def test_datasheet_verdict_does_not_depend_on_the_record_unit(tmp_path, capsys):
    # issue 13: a deg/sqrt(h) limit passed the deg/s file and failed the identical deg/h file
    x = N_GYRO * np.sqrt(FS) * np.random.default_rng(2).standard_normal(40_000)
    sheet = tmp_path / "sheet.json"
    limits = [
        {"quantity": "N", "max": 0.61, "unit": "deg/sqrt(h)"},
        {"quantity": "adev", "tau": 1.0, "max": 40.0, "unit": "deg/h"},
    ]
    sheet.write_text(json.dumps({"limits": limits}))
    checks = {}
    for unit, factor in (("deg/s", 1.0), ("deg/h", 3600.0), ("dph", 3600.0), ("deg/min", 60.0)):
        path = tmp_path / f"{unit.replace('/', '_')}.npy"
        np.save(path, x * factor)
        argv = ["fit", str(path), "--fs", "100", "--units", unit, "--datasheet", str(sheet)]
        code, out, err = _run([*argv, "--json"], capsys)
        assert code == 0, err
        checks[unit] = json.loads(out)["channels"][0]["checks"]
    for unit, found in checks.items():
        for a, b in zip(found, checks["deg/s"], strict=True):
            assert a["status"] == b["status"] == "pass", unit
            assert a["value"] == pytest.approx(b["value"], rel=1e-9), unit
