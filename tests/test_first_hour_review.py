"""Regression tests of a newcomer review: reprs, CLI advice, export-note units, gnss-ins-sim."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from allanite.cli import main
from allanite.formats import ImuConfig, format_module, read_config
from allanite.formats.base import sensor_model
from allanite.model import NoiseModel
from allanite.terms import RateRandomWalk, White
from allanite.units import convert

FS = 100.0


def _value(note: str, name: str) -> tuple[float, str]:
    """``(value, unit)`` of ``name=value unit`` in an export note."""
    found = re.search(rf"\b{name}=([-+0-9.e]+) (\S+?)(?:,|\) )", note)
    assert found is not None, note
    return float(found.group(1)), found.group(2)


def test_projection_notes_give_each_value_its_unit() -> None:
    """Regression: "rrw (K=2.63e-05) -> markov (sigma=0.005324, ...)" had no units."""
    k_si = 2.63e-5  # rad/s/sqrt(s)
    gyro = sensor_model([White(N=1.2e-4), RateRandomWalk(K=k_si)], "gyro")
    accel = sensor_model([White(N=2e-3), RateRandomWalk(K=3e-4)], "accel")
    written = format_module("gnss-ins-sim").write(ImuConfig(gyro=gyro, accel=accel), rate=FS)
    notes = {p.split(":", 1)[0]: p for p in written.projections}
    k, unit = _value(notes["gyro"], "K")
    assert unit == "deg/h/sqrt(h)"
    assert k == pytest.approx(convert(k_si, "rad/s/sqrt(s)", unit), rel=1e-3)
    assert _value(notes["gyro"], "sigma")[1] == "deg/h"
    assert _value(notes["gyro"], "tau_c")[1] == "s"
    k_acc, unit_acc = _value(notes["accel"], "K")
    assert k_acc == pytest.approx(convert(3e-4, "m/s^2/sqrt(s)", unit_acc), rel=1e-3)
    assert "rad/s" not in notes["gyro"]
    assert "deg" not in notes["accel"]


def test_gnss_ins_sim_writes_the_accelerometer_and_says_when_it_is_zero(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: a gyro-only source gave accel entries of zero (gnss-ins-sim requires the
    keys) with the warning "has no accel noise entries"; with an accel model they are its."""
    gyro = NoiseModel((White(N=1e-3),), {"rate": "rad/s", "time": "s"})
    src = tmp_path / "gyro.json"
    gyro.save(src)
    out = tmp_path / "imu_err.py"
    assert main(["model", "convert", str(src), str(out), "--rate", "100"]) == 0
    err = capsys.readouterr().err
    assert "has no accel noise entries" not in err
    assert f"{out} has accel noise entries of zero" in err
    text = out.read_text()
    assert re.search(r"'accel_vrw': np.array\(\[0, 0, 0\]\)", text)
    assert "# accel: zero noise (the source holds no accel model" in text
    assert "# gyro: zero noise" not in text
    # a source with an accelerometer model: its entries, no warning about them
    n_acc = 2e-3  # m/s^2/sqrt(Hz)
    both = ImuConfig(
        gyro=sensor_model([White(N=1e-3)], "gyro"),
        accel=sensor_model([White(N=n_acc)], "accel"),
        rate=FS,
    )
    text = format_module("gnss-ins-sim").write(both, rate=FS).text
    assert "zero noise" not in text
    out.write_text(text)
    (white,) = read_config(out, rate=FS).model("accel").terms_of_type("white")
    assert pytest.approx(n_acc, rel=1e-6) == white.N
    vrw = re.search(r"'accel_vrw': np.array\(\[([0-9.e+-]+),", text)
    assert vrw is not None
    assert float(vrw.group(1)) == pytest.approx(n_acc * 60.0, rel=1e-6)  # m/s/sqrt(h)
