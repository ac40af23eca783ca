"""Regression tests of a newcomer review: reprs, CLI advice, export-note units, gnss-ins-sim."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
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


GYRO = NoiseModel((White(N=0.01), RateRandomWalk(K=1e-4)), {"rate": "deg/s", "time": "s"})


def test_fit_result_repr_is_compact_with_values_intervals_units_and_p() -> None:
    """Regression: repr(FitResult) dumped every array (thousands of characters)."""
    import allanite

    x = GYRO.simulate(100_000, fs=FS, seed=3)
    result = allanite.fit(x, fs=FS, units="deg/s")
    text = repr(result)
    assert len(text) < 300, text
    assert "array(" not in text
    assert text.startswith("FitResult(gls, ")
    for row in result.table("customary"):
        assert f"{row['name']} = {row['value']:.3g} [{row['low']:.3g}, {row['high']:.3g}] " in text
        assert row["unit"] in text
    assert "deg/sqrt(h)" in text
    assert f"p = {result.p_value:.3g}" in text
    assert f"{result.dof} dof" in text


def test_diagnosis_repr_is_compact_with_headline_effects_and_consistent_after() -> None:
    """Regression: repr(Diagnosis) dumped the three views' arrays."""
    from allanite.diagnosis import diagnose

    real = NoiseModel((White(N=0.02), RateRandomWalk(K=1e-4)), GYRO.units)
    d = diagnose(real.simulate(20_000, fs=FS, seed=4), GYRO, fs=FS, units="deg/s", n_mc=40)
    assert d.attribution
    text = repr(d)
    assert len(text) < 800, text
    assert "array(" not in text
    assert repr(d.headline) in text
    best = d.attribution[0]
    after = "consistent after" if best.consistent_after else "gap remains"
    assert f"effects=[{best.effect} (" in text
    assert f"; {after})" in text
    assert "deg/sqrt(h)" in text  # the effect's parameter with its unit
    assert f"p_value={d.p_value:.3g}" in text


def test_fit_on_a_too_short_record_gives_command_line_advice(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: `allanite fit` on a short record said to call allanite.fit(curve, ['N']),
    and `analyze` pointed a 3-sample record to that failing fit command."""
    import allanite

    x = np.random.default_rng(1).standard_normal(20) * 0.01
    rec = tmp_path / "short.npy"
    np.save(rec, x)
    with pytest.raises(ValueError, match=r"allanite\.fit\(curve, \['N'\]\)"):
        allanite.fit(x, fs=FS)  # the library's advice is the API call, and works:
    assert allanite.fit(x, fs=FS, terms=["N"]).coefficients["N"].value > 0
    assert main(["fit", str(rec), "--fs", "100", "--units", "deg/s"]) == 2
    err = capsys.readouterr().err
    assert "too short for an automatic fit" in err
    assert "allanite.fit(" not in err
    assert "use a longer record" in err
    assert main(["analyze", str(rec), "--fs", "100", "--units", "deg/s"]) == 0
    out = capsys.readouterr().out
    assert "allanite fit " not in out
    assert "too short for a fit (20 samples" in out
    long = tmp_path / "long.npy"
    np.save(long, np.random.default_rng(2).standard_normal(4000) * 0.01)
    assert main(["analyze", str(long), "--fs", "100", "--units", "deg/s"]) == 0
    out = capsys.readouterr().out
    assert "fitted coefficients with intervals: allanite fit " in out
    assert main(["fit", str(long), "--fs", "100", "--units", "deg/s"]) == 0
