"""Regression tests of a new user's first hour: inputs that failed for the wrong reason."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from allanite.cli import main
from allanite.diagnosis import diagnose
from allanite.model import NoiseModel
from allanite.terms import White

RNG = np.random.default_rng(16)
FS = 100.0


def _one_line_error(capsys: pytest.CaptureFixture[str], command: str) -> str:
    out, err = capsys.readouterr()
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"allanite {command}: error: ")
    return lines[0]


def test_unknown_diagnose_effects_are_refused_with_the_known_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    x = RNG.standard_normal(4000) * 0.01
    model = NoiseModel([White(0.001)], units={"rate": "deg/s", "time": "s"})
    with pytest.raises(ValueError, match=r"unknown effect\(s\) 'bogus'; known effects: white, "):
        diagnose(x, model, fs=FS, effects=["white", "bogus"])
    with pytest.raises(ValueError, match=r"rescale:<term type> \(.*white"):
        diagnose(x, model, fs=FS, effects=["rescale:nonsense"])
    with pytest.raises(ValueError, match="no effect given"):
        diagnose(x, model, fs=FS, effects=[])
    rec = tmp_path / "real.npy"
    np.save(rec, x)
    path = tmp_path / "model.json"
    model.save(path)
    argv = ["diagnose", str(rec), "--fs", "100", "--units", "deg/s", "--sim-model", str(path)]
    argv.append("--json")
    assert main([*argv, "--effects", "white,bogus"]) == 2
    line = _one_line_error(capsys, "diagnose")
    assert "unknown effect(s) 'bogus'; known effects: white, quantization, flicker" in line
    # known names, including rescale forms, are accepted
    assert main([*argv, "--effects", "white,rescale:white,rescale", "--n-mc", "20"]) == 0


def test_datasheet_unknown_quantity_is_refused_not_missing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: a typo in a limit's quantity was reported as MISSING with exit code 0."""
    from allanite.datasheet import Datasheet
    from allanite.errors import InputError

    sheet = tmp_path / "limits.json"
    sheet.write_text(
        '{"limits": [{"quantity": "N", "max": 1, "unit": "deg/sqrt(h)"},'
        ' {"quantity": "Bias", "max": 10, "unit": "deg/h"}]}'
    )
    match = r"limits\[1\]: unknown quantity 'Bias' \(did you mean 'B'"
    with pytest.raises(InputError, match=match):
        Datasheet.load(sheet)
    rec = tmp_path / "rec.npy"
    np.save(rec, RNG.standard_normal(20_000) * 0.01)
    argv = ["fit", str(rec), "--fs", "100", "--units", "deg/s", "--datasheet", str(sheet)]
    assert main(argv) == 2
    line = _one_line_error(capsys, "fit")
    assert "unknown quantity 'Bias'" in line
    assert "use adev or a noise coefficient: B, K, N, Q, R," in line
    # the real names, a suffixed label and the compact form are accepted
    Datasheet.from_dict({"sigma_2": 1.0, "N": {"max": 1.0}})
    Datasheet.from_dict({"limits": [{"quantity": "adev", "tau": 1, "max": 1, "unit": "deg/s"}]})
    with pytest.raises(InputError, match=r"entry 'ARW': unknown quantity 'ARW' \(did you mean 'N'"):
        Datasheet.from_dict({"ARW": 0.1})


def _model_file(tmp_path: Path) -> Path:
    path = tmp_path / "model.json"
    NoiseModel([White(0.001)], units={"rate": "deg/s", "time": "s"}).save(path)
    return path


def test_simulate_refuses_an_output_larger_than_the_free_space(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: simulate -n 1000000000000 started writing an 8 TB file."""
    import shutil
    from collections import namedtuple

    from allanite.simulation.writers import output_size, write_record

    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda _: usage(10**12, 0, 5 * 10**9))
    model = _model_file(tmp_path)
    out = tmp_path / "big.npy"
    assert main(["simulate", str(model), "--fs", "100", "-n", "1e12", "-o", str(out)]) == 2
    line = _one_line_error(capsys, "simulate")
    assert "cannot write" in line
    assert "big.npy: the record needs 8 TB but" in line
    assert "has 5 GB free; write fewer samples (-n, --duration)" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]
    with pytest.raises(OSError, match="needs 8 TB"):
        write_record(out, NoiseModel.load(model), 10**12, fs=100.0)
    # sizes: exact for .npy/raw, an upper bound for CSV
    assert output_size("a.bin", 1000, 3) == 24_000
    assert output_size("a.npy", 1000, 3) == 24_128


def test_simulate_says_what_it_wrote(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = _model_file(tmp_path)
    for name, channels in (("s.npy", 1), ("s.csv", 2)):
        out = tmp_path / name
        argv = ["simulate", str(model), "--fs", "100", "--duration", "1h", "--seed", "3"]
        assert main([*argv, "--channels", str(channels), "-o", str(out)]) == 0
        printed, err = capsys.readouterr()
        assert err == ""
        size = out.stat().st_size
        axes = " x 2 channels" if channels == 2 else ""
        assert printed == (
            f"wrote {out}: 360000 samples{axes} of rate [deg/s] at 100 Hz (1 h, seed 3), "
            f"{size / 1e6:.3g} MB\n"
        )
    assert main([*argv, "-o", str(tmp_path / "q.npy"), "--quiet"]) == 0
    assert capsys.readouterr() == ("", "")


def test_negative_channel_indices_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: --channels -1 silently took the last column."""
    from allanite.errors import InputError
    from allanite.io import read_record

    path = tmp_path / "three.npy"
    np.save(path, RNG.standard_normal((1000, 3)))
    assert main(["analyze", str(path), "--fs", "100", "--channels", "-1"]) == 2
    line = _one_line_error(capsys, "analyze")
    assert "column -1: columns are numbered from 0 to 2; negative indices are not accepted" in line
    with pytest.raises(InputError, match="negative indices are not accepted"):
        read_record(path, fs=100.0, columns=[0, -2])
    with pytest.raises(InputError, match="negative indices"):
        read_record(path, fs=100.0, time_column=-1)
    record = read_record(path, fs=100.0)
    with pytest.raises(ValueError, match=r"channel -1: channels are numbered from 0 to 2"):
        record.select([-1])
    assert main(["analyze", "--example", "--channels", "-1"]) == 2
    assert "negative indices are not accepted" in _one_line_error(capsys, "analyze")
    assert record.select([2]).channels == (record.channels[2],)


def test_format_table_prints_the_units_the_cli_prints(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: format_table printed N in deg/sqrt(s) while allanite fit printed deg/sqrt(h)."""
    import allanite
    from allanite.report.coefficients import coefficient_table

    x = np.random.default_rng(21).standard_normal(40_000) * 0.01 * np.sqrt(FS)  # N 0.6 deg/√h
    fitted = allanite.fit(allanite.avar(x, fs=FS, units="deg/s"))
    text = fitted.format_table()
    rows = {r.symbol: r for r in coefficient_table(fitted, "deg/s")}
    assert rows["N"].unit == "deg/sqrt(h)"
    line = next(ln for ln in text.splitlines() if ln.startswith("N "))
    assert line.endswith("  deg/sqrt(h)")
    assert f"{rows['N'].value:>12.4g}" in line  # the CLI's value, the CLI's unit
    assert 0.55 < rows["N"].value < 0.65
    assert "deg/sqrt(s)" not in text
    # the model's own units stay available
    assert fitted.format_table(units=None).splitlines()[1].endswith("  deg/sqrt(s)")
    path = tmp_path / "x.npy"
    np.save(path, x)
    assert main(["fit", str(path), "--fs", "100", "--units", "deg/s"]) == 0
    printed = capsys.readouterr().out
    assert f"N = {rows['N'].value:.4g} deg/sqrt(h)" in printed


@pytest.mark.parametrize(
    ("rate", "per_second", "unit"), [("deg/h", "deg/s", "deg"), ("g", "m/s^2", "m/s")]
)
def test_simulated_increments_are_written_in_an_angle_unit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], rate: str, per_second: str, unit: str
) -> None:
    """Regression: simulate --output increment labelled its CSV column deg/s*s."""
    model = NoiseModel([White(3.0)], units={"rate": rate, "time": "s"})
    path = tmp_path / "m.json"
    model.save(path)
    for output in ("increment", "angle"):
        out = tmp_path / f"{output}.csv"
        argv = ["simulate", str(path), "--fs", "100", "-n", "500", "--seed", "4"]
        assert main([*argv, "--output", output, "-o", str(out)]) == 0
        assert f"of {output} [{unit}] at 100 Hz" in capsys.readouterr().out
        header = out.read_text().splitlines()[0]
        assert header == f"{output}_0[{unit}]"
        # the values are in that unit: the model converted to per second, then integrated
        expect = model.in_units(per_second).simulate(500, fs=FS, output=output, seed=4)
        np.testing.assert_allclose(np.loadtxt(out, skiprows=1), expect.ravel(), rtol=1e-12)


def test_a_config_without_the_sensor_names_the_other_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: "holds no gyro noise model" did not mention --sim-sensor accel."""
    from allanite.formats import ImuConfig, read_config, write_config

    accel = NoiseModel([White(0.002)], units={"rate": "m/s^2", "time": "s"})
    config = tmp_path / "imu.sdf"
    write_config(ImuConfig(accel=accel), config, format="gz-sdf", rate=FS)
    with pytest.raises(ValueError, match=r"holds no gyro noise model; it holds an accel model: "):
        read_config(config, format="gz-sdf").model("gyro")
    with pytest.raises(ValueError, match=r"holds no gyro noise model$"):
        ImuConfig().model("gyro")  # nothing else to suggest
    real = tmp_path / "real.npy"
    np.save(real, RNG.standard_normal(4000) * 0.01)
    argv = ["diagnose", str(real), "--fs", "100", "--units", "rad/s", "--sim-model", str(config)]
    assert main(argv) == 2
    line = _one_line_error(capsys, "diagnose")
    # the record is a gyro (rad/s): the CLI names both sensors rather than advising
    # --sim-sensor accel, which would then fail on the units
    assert "holds no gyro noise model: imu.sdf is an accelerometer model (m/s^2)" in line
    assert line.endswith("compare it with an accelerometer record, or give a gyro model")
    # a file that is no simulator config: the option that names the format, once
    (tmp_path / "log.csv").write_text("t,gz\n0,1\n")
    argv[-1] = str(tmp_path / "log.csv")
    assert main(argv) == 2
    line = _one_line_error(capsys, "diagnose")
    assert "cannot tell which simulator config this is; give it with --sim-format NAME " \
        "(model convert: --from NAME or --to NAME), NAME one of allanite, " in line  # fmt: skip
    assert "CLI:" not in line


def test_a_filter_bandwidth_above_nyquist_is_stated(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: the diagnosis printed a low-pass bandwidth above fs/2 without a word."""
    from allanite.terms.transients import LowPassWhite

    units = {"rate": "deg/s", "time": "s"}
    sim = tmp_path / "sim.json"
    NoiseModel([White(0.01)], units=units).save(sim)
    for bandwidth in (80.0, 20.0):
        real = NoiseModel([LowPassWhite(N=0.01, bandwidth=bandwidth)], units=units)
        x = real.simulate(2**16, fs=FS, seed=3)
        d = diagnose(x.ravel(), NoiseModel.load(sim), fs=FS, units="deg/s", n_mc=40)
        assert d.best is not None
        assert d.best.effect == "lowpass"
        above = d.best.params["bandwidth"] > FS / 2
        assert above == (bandwidth > FS / 2)
        note = "above the Nyquist frequency 50 Hz: it acts before sampling"
        assert (note in d.headline) == above
        path = tmp_path / "real.npy"
        np.save(path, x)
        argv = ["diagnose", str(path), "--fs", "100", "--units", "deg/s", "--n-mc", "40"]
        assert main([*argv, "--sim-model", str(sim)]) == 0
        attribution = capsys.readouterr().out.split("attribution (best first):")[1]
        assert (note in attribution.splitlines()[1]) == above


def _time_view_headline(x: np.ndarray) -> str:
    model = NoiseModel([White(0.01)], units={"rate": "deg/s", "time": "s"})
    return diagnose(x, model, fs=FS, units="deg/s", n_mc=40).headline


def test_negligible_time_view_deviations_are_not_dramatized() -> None:
    """Regression: a kurtosis of 0.05 on a long record read as "heavy-tailed" and "bursts"."""
    rng = np.random.default_rng(5)
    n, sd = 2**21, 0.01 * np.sqrt(FS)
    df = 60  # Student t: excess kurtosis 6 / (df - 4) = 0.11, estimated 0.049 here
    slight = rng.standard_t(df, n) / np.sqrt(df / (df - 2)) * sd
    text = _time_view_headline(slight)
    assert text.startswith("a small gap, significant but negligible in size")
    assert "slightly heavier-tailed than simulated (excess kurtosis 0.0491, simulated" in text
    assert "heavy-tailed sample-to-sample" not in text
    # a 3 % modulation of the noise level: its size, no "bursts", no zero-size effect named
    level = rng.standard_normal(n) * sd * (1 + 0.03 * np.sin(2 * np.pi * np.arange(n) / n * 7))
    text = _time_view_headline(level)
    assert "the short-tau noise level varies slightly over the record (rms +3" in text
    assert "bursts" not in text
    assert "is missing" not in text
    # a large deviation keeps the strong wording, with its size
    heavy = rng.standard_t(6, 2**17) / np.sqrt(6 / 4) * sd
    text = _time_view_headline(heavy)
    assert "heavy-tailed sample-to-sample changes (excess kurtosis) (real 1.39 vs simulated" in text
    assert "negligible" not in text


def test_positional_fs_names_the_fix() -> None:
    """Regression: simulate(model, n, fs) with fs now keyword-only was a bare TypeError."""
    import allanite
    from allanite.simulation import simulate, simulate_chunks, write_record

    model = NoiseModel([White(0.001)], units={"rate": "deg/s", "time": "s"})
    x = RNG.standard_normal(1000)
    with pytest.raises(TypeError, match=r"^fs is keyword-only: simulate\(model, n, fs=\.\.\.\);"):
        simulate(model, 100, 100.0)
    with pytest.raises(
        TypeError, match=r"^fs is keyword-only: NoiseModel.simulate\(n, fs=\.\.\.\)"
    ):
        model.simulate(100, 100.0)
    with pytest.raises(TypeError, match=r"^fs is keyword-only: avar\(x, fs=\.\.\.\); avar\(\) "):
        allanite.avar(x, 100.0)
    calls = [
        lambda: allanite.oadev(x, 100.0),
        lambda: allanite.mdev(x, 100.0),
        lambda: allanite.fit(x, "auto", 100.0),
        lambda: allanite.diagnose(x, model, 100.0),
        lambda: allanite.avar_large(x, 100.0),
        lambda: allanite.batch([x], 100.0),
        lambda: list(simulate_chunks(model, 10, 100.0)),
        lambda: write_record("never.npy", model, 10, 100.0),
    ]
    for call in calls:
        with pytest.raises(TypeError, match=r"^fs is keyword-only: \w+\(.*fs=\.\.\.\)"):
            call()
    np.testing.assert_array_equal(
        simulate(model, 10, fs=100.0, seed=1), model.simulate(10, fs=100.0, seed=1)
    )


def test_a_six_axis_robot_log_is_two_sensors_without_units(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: a ROS bag's gyro and accelerometer (units set by sensor_msgs/Imu) were
    fitted in "record units" unless --units repeated what the message defines."""
    pytest.importorskip("rosbags")
    from test_io_robot_logs import write_bag

    n, rate = 20_000, 200.0
    data = np.random.default_rng(8).standard_normal((n, 6)) * 0.01
    data[:, 5] += 9.81
    write_bag(tmp_path / "imu.bag", "ros1", data, np.arange(n) / rate, topics=("/imu0",))
    bag = str(tmp_path / "imu.bag")
    assert main(["fit", bag]) == 0
    out = capsys.readouterr().out
    assert "channel gyro_x (gyro, rad/s):" in out
    assert "channel accel_z (accelerometer, m/s^2):" in out
    assert "record's own units" not in out
    # white noise of 0.01 per sample at 200 Hz: N = 0.01 / sqrt(200) rad/sqrt(s), printed in
    # deg/sqrt(h) as a datasheet quotes it (the rad/s gyro's customary line)
    expect = 0.01 / np.sqrt(rate) * 60.0 * 180.0 / np.pi  # in deg/sqrt(h)
    line = next(ln for ln in out.splitlines() if "N = " in ln and "deg/sqrt(h)" in ln)
    value = float(line.split("N = ")[1].split()[0])
    assert abs(value / expect - 1) < 0.03  # 3 % = 7 standard errors of N at 20000 samples
    # --units still wins, and analyze (one sensor) says how to pick one
    assert main(["fit", bag, "--channels", "gyro_x", "--units", "deg/s"]) == 0
    assert "channel gyro_x (gyro, deg/s):" in capsys.readouterr().out
    assert main(["analyze", bag, "--summary"]) == 0
    err = capsys.readouterr().err
    assert "holds channels in rad/s and m/s^2" in err
    assert "--channels gyro_x,gyro_y,gyro_z (rad/s); --channels accel_x,accel_y,accel_z" in err


def test_write_corrected_folds_in_the_joint_explanation() -> None:
    """Regression: the headline named three effects, the corrected config held only the first."""
    from types import SimpleNamespace

    from allanite.formats import kalibr, px4_plugin
    from allanite.formats.corrected import corrected_model
    from allanite.terms import RateRandomWalk

    units = {"rate": "rad/s", "time": "s"}
    model = NoiseModel([White(2e-4), RateRandomWalk(3e-5)], units=units)

    def effect(name: str, term: dict[str, object], params: dict[str, float]) -> SimpleNamespace:
        return SimpleNamespace(
            effect=name, term=term, params=params, gap_before=100.0, gap_after=1.0, shrinkage=0.9
        )

    white = effect("rescale:white", {"type": "white", "N": 1e-4}, {"scale": 0.5})
    rrw = effect("rescale:rrw", {"type": "rrw", "K": 5e-6}, {"scale": 0.17})
    lowpass = effect("lowpass", {"type": "lowpass_white", "N": 1e-4, "bandwidth": 20.0}, {})
    joint = SimpleNamespace(effects=[white, rrw], gap_before=100.0, gap_after=0.5)
    diagnosis = SimpleNamespace(significant=True, attribution=[white, rrw], explanation=joint)
    out, what = corrected_model(model, diagnosis, kalibr.HOLDS)
    assert [(t.type, t.values()) for t in out.terms] == [
        ("white", {"N": 1e-4}),
        ("rrw", {"K": 5e-6}),
    ]
    assert what.startswith("folded in the joint explanation: rescale:white (x0.5); ")
    assert what.endswith("gap 100 -> 0.5 (shrinkage 100 %)")
    # the longest prefix the format holds; what follows an unheld effect is left out
    joint = SimpleNamespace(effects=[white, lowpass, rrw], gap_before=100.0, gap_after=0.5)
    diagnosis = SimpleNamespace(significant=True, attribution=[white], explanation=joint)
    out, what = corrected_model(model, diagnosis, px4_plugin.HOLDS)
    assert [(t.type, t.values()) for t in out.terms] == [
        ("white", {"N": 1e-4}),
        ("rrw", {"K": 3e-5}),
    ]
    assert "left out lowpass, rescale:rrw of the joint explanation" in what
    # a first effect the format cannot hold: the best single effect it holds, as before
    joint = SimpleNamespace(effects=[lowpass, rrw], gap_before=100.0, gap_after=0.5)
    diagnosis = SimpleNamespace(significant=True, attribution=[lowpass, rrw], explanation=joint)
    out, what = corrected_model(model, diagnosis, px4_plugin.HOLDS)
    assert what.startswith("folded in rescale:rrw (x0.17); gap 100 -> 1 (shrinkage 90 %)")
    assert "skipped lowpass" in what


@pytest.mark.parametrize(("fmt", "name"), [("kalibr", "imu.yaml"), ("px4-plugin", "p.sdf")])
def test_a_config_written_into_a_template_states_its_projections(
    tmp_path: Path, fmt: str, name: str
) -> None:
    """Regression: with a template (--write-corrected) the projected terms were not in the file."""
    import xml.etree.ElementTree as ET

    from allanite.formats import ImuConfig, read_config, write_config
    from allanite.terms import Flicker

    gyro = NoiseModel([White(1e-4), Flicker(3e-5)], units={"rate": "rad/s", "time": "s"})
    first = tmp_path / name
    start = ImuConfig(
        gyro=NoiseModel([White(2e-4)], units=gyro.units),
        accel=NoiseModel([White(2e-3)], units={"rate": "m/s^2", "time": "s"}),
    )
    write_config(start, first, format=fmt, rate=FS)
    paths = [first]
    for k in range(2):  # twice: the notes of the earlier write are replaced, not stacked
        paths.append(tmp_path / f"{k}{name}")
        config = read_config(paths[-2], format=fmt, rate=FS).with_model("gyro", gyro)
        written = write_config(config, paths[-1], format=fmt, rate=FS, template=paths[-2])
        assert written.projections
    text = paths[-1].read_text()
    assert text.count("projected: gyro: flicker (B=6.188 deg/h) -> ") == 1  # 3e-5 rad/s
    assert "largest ADEV error" in text
    if fmt == "px4-plugin":
        ET.fromstring(text.split("\n", 1)[1] if text.startswith("<?xml") else text)
    (white,) = read_config(paths[-1], format=fmt, rate=FS).model("gyro").terms_of_type("white")
    assert pytest.approx(1e-4) == white.N


def test_batch_prints_the_units_fit_prints(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: batch printed N in deg/h*sqrt(s), "PASS" without limits, the path twice."""
    x = np.random.default_rng(3).standard_normal(60_000) * 0.18 * np.sqrt(FS)  # deg/h
    path = tmp_path / "dut.npy"
    np.save(path, x)
    assert main(["fit", str(path), "--fs", "100", "--units", "deg/h"]) == 0
    fitted = capsys.readouterr().out
    n_fit = fitted.split("N = ")[1].split(" deg/sqrt(h)")[0]
    assert main(["batch", str(path), "--fs", "100", "--units", "deg/h"]) == 0
    out = capsys.readouterr().out
    header, row = (line.split() for line in out.splitlines()[:2])
    assert row[header.index("N")] == n_fit  # as fit prints it: 0.003 deg/sqrt(h)
    assert row[-1] == "OK"
    assert "units: Q in deg, N in deg/sqrt(h), B in deg/h, K in deg/h/sqrt(h)" in out
    assert main(["batch", str(path)]) == 1
    out = capsys.readouterr().out
    assert f"error: {path}: the sampling frequency is unknown; give it with --fs HZ" in out
    assert f"{path}: {path}" not in out


def test_a_time_column_left_out_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: a CSV "t,gz" without --time-column failed without naming t, and with --fs
    analysed t as a gyro channel, warning only "angle given as rate?"."""
    path = tmp_path / "nav.csv"
    t = np.arange(3000) / FS
    np.savetxt(path, np.column_stack([t, RNG.standard_normal(3000)]), delimiter=",",
               header="t,gz", comments="")  # fmt: skip
    assert main(["analyze", str(path)]) == 2
    assert "column 't' looks like the time: --time-column t" in _one_line_error(capsys, "analyze")
    assert main(["analyze", str(path), "--fs", "100", "--summary"]) == 0
    assert "warning: channel t is named like time stamps and always increases: if it is the " \
        "time, give --time-column t" in capsys.readouterr().out  # fmt: skip
    assert main(["analyze", str(path), "--time-column", "t", "--summary"]) == 0
    assert "named like time stamps" not in capsys.readouterr().out


def test_a_random_walk_projected_onto_gazebo_stays_a_random_walk(tmp_path: Path) -> None:
    """Regression: Kalibr -> gz SDF wrote dynamic_bias_correlation_time 2e17 s, where Gazebo's
    phi = exp(-dt/tau) is 1.0 in double precision: the written bias never moved."""
    import math

    from allanite.formats import read_config, write_config

    src = tmp_path / "imu.yaml"
    src.write_text("gyroscope_noise_density: 1.87e-4\ngyroscope_random_walk: 2.66e-5\n"
                   "update_rate: 200.0\n")  # fmt: skip
    written = write_config(read_config(src), tmp_path / "out.sdf", format="gz-sdf")
    (gm,) = read_config(tmp_path / "out.sdf").model("gyro").terms_of_type("markov")
    assert gm.tau_c <= 1000.0 * 3600.0  # the default tau range ends at 3600 s
    phi = math.exp(-(1 / 200.0) / gm.tau_c)
    driving = gm.sigma * math.sqrt(1.0 - phi * phi)  # Gazebo's per-step bias increment
    assert driving == pytest.approx(2.66e-5 * math.sqrt(1 / 200.0), rel=1e-4)
    assert "largest ADEV error 0.0 %" in written.projections[0]


def test_units_a_header_states_are_read(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Regression: a CSV allanite simulate wrote (``angle_0[deg]``) read back without a unit."""
    model = NoiseModel([White(0.005)], units={"rate": "deg/s", "time": "s"})
    model.save(tmp_path / "m.json")
    out = tmp_path / "a.csv"
    argv = ["simulate", str(tmp_path / "m.json"), "--fs", "100", "-n", "20000", "--seed", "2"]
    assert main([*argv, "--output", "angle", "-o", str(out), "--quiet"]) == 0
    assert main(["fit", str(out), "--fs", "100", "--input", "angle"]) == 0
    printed = capsys.readouterr().out
    assert "channel angle_0[deg] (gyro, deg/s):" in printed
    n = float(printed.split("N = ")[1].split(" deg/sqrt(h)")[0])
    assert abs(n / 0.3 - 1) < 0.03  # 0.005 deg/sqrt(s) = 0.3 deg/sqrt(h); 3 % ~ 4 s.e.
    # a unit that does not suit the input kind is not used, and the warning says why
    assert main(["analyze", str(out), "--fs", "100", "--summary"]) == 0
    assert "the header states deg, not a unit of rate samples: not used; give --input angle" \
        in capsys.readouterr().out  # fmt: skip
    # --units wins over the header; a header without units in brackets changes nothing
    assert main(["fit", str(out), "--fs", "100", "--input", "angle", "--units", "rad"]) == 0
    assert "(gyro, rad/s)" in capsys.readouterr().out
    plain = tmp_path / "p.csv"
    plain.write_text("gx[1],gy\n" + "\n".join(f"{v},{v}" for v in RNG.standard_normal(50)))
    from allanite.io import read_record

    assert read_record(plain, fs=FS).units is None


def test_fit_says_which_model_it_wrote(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Regression: fit -o on three channels saved the first one's model without a word."""
    path = tmp_path / "three.npy"
    np.save(path, RNG.standard_normal((20_000, 3)) * 0.05)
    out = tmp_path / "m.json"
    assert main(["fit", str(path), "--fs", "100", "--units", "deg/s", "-o", str(out)]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert last == (
        f"wrote {out}: the noise model of channel col0 (gyro, deg/s); 2 other channel(s) not "
        "saved: fit one with --channels NAME -o FILE"
    )
    assert NoiseModel.load(out).units["rate"] == "deg/s"


def test_simulate_given_a_config_names_the_conversion(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: allanite simulate imu.yaml said "the noise model is not valid JSON"."""
    src = tmp_path / "imu.yaml"
    src.write_text("gyroscope_noise_density: 1.87e-4\ngyroscope_random_walk: 2.66e-5\n"
                   "update_rate: 200.0\n")  # fmt: skip
    out = tmp_path / "s.npy"
    assert main(["simulate", str(src), "--fs", "200", "-n", "100", "-o", str(out)]) == 2
    line = _one_line_error(capsys, "simulate")
    assert f"{src} is a Kalibr imu.yaml config, not a noise-model JSON; convert it first: " \
        f"allanite model convert {src} model.json" in line  # fmt: skip
    assert not out.exists()
    assert main(["model", "convert", str(src), str(tmp_path / "m.json")]) == 0
    assert main(["simulate", str(tmp_path / "m.json"), "--fs", "200", "-n", "100", "-o",
                 str(out), "--quiet"]) == 0  # fmt: skip
    assert np.load(out).shape == (100,)


def test_slope_regions_do_not_repeat_a_class() -> None:
    """Regression: "15.9 – 39 s slope -0.17 (0)" then "43.6 – 61 s slope -0.24 (0)"."""
    import allanite
    from allanite.slopes import slope_table
    from allanite.terms import Flicker, RateRandomWalk

    model = NoiseModel(
        [White(0.3 / 60), Flicker(5.0 / 3600), RateRandomWalk(3 / 60 / 3600)],
        units={"rate": "deg/s", "time": "s"},
    )
    x = model.simulate(240_000, fs=200.0, n_channels=3, seed=1)[:, 0]
    res = allanite.avar(x, fs=200.0, units="deg/s")
    rows = slope_table(res.tau, res.dev, res.edf)
    assert [r.canonical for r in rows] == [-0.5, 0.0]
    assert rows[1].tau_min == pytest.approx(15.9, rel=0.01)
    assert rows[1].tau_max == pytest.approx(61.0, rel=0.01)
    assert rows[0].tau_max < rows[1].tau_min


def test_report_intervals_carry_the_values_digits(tmp_path: Path) -> None:
    """Regression: the report showed N = 0.2995 with the interval "0.299 … 0.3"."""
    import allanite
    from allanite.report.coefficients import coefficient_table

    x = np.random.default_rng(21).standard_normal(40_000) * 0.01 * np.sqrt(FS)
    path = tmp_path / "x.npy"
    np.save(path, x)
    out = tmp_path / "r.html"
    assert main(["report", str(path), "--fs", "100", "--units", "deg/s", "-o", str(out)]) == 0
    fitted = allanite.fit(allanite.avar(x, fs=FS, units="deg/s"))
    row = {r.symbol: r for r in coefficient_table(fitted, "deg/s", 0.95)}["N"]
    assert f"{row.low:.4g} … {row.high:.4g}" in out.read_text(encoding="utf-8")


def test_model_convert_takes_one_sensor(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Regression: a config's accelerometer could not be converted to a model JSON at all."""
    from allanite.formats import ImuConfig, write_config

    accel = NoiseModel([White(0.002)], units={"rate": "m/s^2", "time": "s"})
    gyro = NoiseModel([White(2e-4)], units={"rate": "rad/s", "time": "s"})
    src = tmp_path / "imu.yaml"
    write_config(ImuConfig(gyro=gyro, accel=accel), src, format="kalibr", rate=FS)
    assert main(["model", "convert", str(src), str(tmp_path / "g.json")]) == 0
    assert "write it with --sensor accel" in capsys.readouterr().err
    assert NoiseModel.load(tmp_path / "g.json").units["rate"] == "rad/s"
    out = tmp_path / "a.json"
    assert main(["model", "convert", str(src), str(out), "--sensor", "accel"]) == 0
    assert "dropped" not in capsys.readouterr().err
    (white,) = NoiseModel.load(out).terms
    assert NoiseModel.load(out).units["rate"] == "m/s^2"
    assert white.values()["N"] == pytest.approx(0.002)
    assert main(["model", "convert", str(out), str(tmp_path / "x.yaml"), "--sensor", "gyro"]) == 2
    assert "it holds an accel model: choose it with --sensor accel" in capsys.readouterr().err


def _header_csv(path: Path, unit: str = "deg/h") -> None:
    """A 3 h-like navigation-gyro log with a header stating units: ``time[s],gz[deg/h]``."""
    t = np.arange(20_000) / FS
    # white noise N = 0.18 deg/h*sqrt(s) = 0.003 deg/sqrt(h)
    rate = 0.18 * np.sqrt(FS) * np.random.default_rng(3).standard_normal(t.size)
    np.savetxt(path, np.column_stack([t, rate]), delimiter=",", header=f"time[s],gz[{unit}]",
               comments="", fmt="%.10g")  # fmt: skip


def test_a_column_is_named_without_the_unit_its_header_states(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: with a header ``time[s],gz[deg/h]`` (the form allanite simulate writes),
    ``--time-column time`` and ``--channels gz`` were refused: "no time column named 'time'"."""
    path = tmp_path / "fog.csv"
    _header_csv(path)
    assert main(["fit", str(path), "--time-column", "time", "--channels", "gz"]) == 0
    printed = capsys.readouterr().out
    assert "channel gz[deg/h] (gyro, deg/h):" in printed
    n = float(printed.split("N = ")[1].split(" deg/sqrt(h)")[0])
    assert abs(n / 0.003 - 1) < 0.04  # 20000 samples: s.e. of N about 0.7 %
    # the full name still works, and a name that is no column is still refused
    assert main(["analyze", str(path), "--time-column", "time[s]", "--summary"]) == 0
    capsys.readouterr()
    assert main(["analyze", str(path), "--time-column", "time", "--channels", "gy"]) == 2
    assert "no column named 'gy'; available: time[s], gz[deg/h]" in _one_line_error(
        capsys, "analyze"
    )


def test_units_given_against_the_header_are_warned(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: a header stating deg/h read with --units deg/s gave N 3600 times too large
    (10.8 deg/sqrt(h), inside the plausible range) without a word about the header."""
    path = tmp_path / "fog.csv"
    _header_csv(path)
    argv = ["fit", str(path), "--time-column", "time[s]"]
    assert main([*argv, "--units", "deg/s"]) == 0
    out, err = capsys.readouterr()
    assert "(gyro, deg/s)" in out  # --units wins
    assert "allanite fit: note: --units differs from the unit the file states (gz[deg/h] " \
        "read as deg/s)" in err  # fmt: skip
    assert main([*argv, "--units", "dph", "--json"]) == 0  # the same unit spelled otherwise
    out, err = capsys.readouterr()
    assert "file states" not in err
    # one unit per channel: the same check, and the JSON keeps it
    six = tmp_path / "six.csv"
    t = np.arange(5000) / FS
    np.savetxt(six, np.column_stack([t, RNG.standard_normal((5000, 2))]), delimiter=",",
               header="t,gz[deg/s],az[m/s^2]", comments="")  # fmt: skip
    assert main(["fit", str(six), "--time-column", "t", "--units", "deg/h,m/s^2", "--json"]) == 0
    out, err = capsys.readouterr()
    assert "(gz[deg/s] read as deg/h)" in err
    assert "az[m/s^2] read" not in err
    import json

    assert any("gz[deg/s] read as deg/h" in w for w in json.loads(out)["record"]["warnings"])


def test_a_template_without_an_entry_gets_it(tmp_path: Path) -> None:
    """Regression: diagnose --write-corrected into a PX4 plugin block allanite had written for
    a gyro model failed after the whole diagnosis: "the template has no
    <accelerometerNoiseDensity> element" (the plugin takes defaults for absent entries)."""
    from allanite.formats import read_config, write_config

    model = NoiseModel([White(2e-4)], units={"rate": "rad/s", "time": "s"})
    model.save(tmp_path / "g.json")
    write_config(read_config(tmp_path / "g.json"), tmp_path / "px4.sdf", format="px4-plugin")
    template_path = tmp_path / "px4.sdf"
    assert "accelerometer" not in template_path.read_text()
    config = read_config(tmp_path / "px4.sdf")  # accel: the plugin's defaults
    corrected = config.with_model("gyro", NoiseModel([White(3e-4)], units=model.units))
    write_config(corrected, tmp_path / "out.sdf", format="px4-plugin", template=template_path)
    text = (tmp_path / "out.sdf").read_text()
    assert "  <accelerometerNoiseDensity>0.004</accelerometerNoiseDensity>\n" in text
    assert text.index("<accelerometerTurnOnBiasSigma>") < text.index("</plugin>")
    back = read_config(tmp_path / "out.sdf")
    assert back.notes == ()  # every entry is in the file now
    assert back.model("gyro").terms_of_type("white")[0].values()["N"] == pytest.approx(3e-4)
    assert back.model("accel") == config.model("accel")
    (tmp_path / "b.sdf").write_text("<sdf/>\n")
    with pytest.raises(ValueError, match="no IMU plugin block"):
        write_config(
            corrected, tmp_path / "x.sdf", format="px4-plugin", template=tmp_path / "b.sdf"
        )


def test_a_template_keeps_the_other_sensors_entries_and_notes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: converting an accelerometer model into a Kalibr file holding the gyro's
    warned "has no gyro noise entries" (it had) and deleted the gyro's projection note."""
    from allanite.terms import Flicker

    gyro = NoiseModel([White(1.7e-4), Flicker(4.7e-5)], units={"rate": "rad/s", "time": "s"})
    accel = NoiseModel([White(2e-3), Flicker(6e-4)], units={"rate": "m/s^2", "time": "s"})
    gyro.save(tmp_path / "g.json")
    accel.save(tmp_path / "a.json")
    out = tmp_path / "imu.yaml"
    assert main(["model", "convert", str(tmp_path / "g.json"), str(out), "--rate", "400"]) == 0
    assert "has no accel noise entries" in capsys.readouterr().err  # a new file: true
    both = tmp_path / "both.yaml"
    argv = ["model", "convert", str(tmp_path / "a.json"), str(both), "--template", str(out)]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "noise entries" not in err
    text = both.read_text()
    assert "# projected: gyro: flicker" in text
    assert "# projected: accel: flicker" in text
    # the template's update_rate (400 Hz) is the rate of the projection: 10 samples = 0.025 s
    assert "evaluated at 100 Hz" not in text
    accel_note = next(ln for ln in text.splitlines() if ln.startswith("# projected: accel:"))
    assert "over 0.025-3.6e+03 s" in accel_note
    assert text.count("# projected: ") == 2
    # writing the accelerometer again replaces its own note only
    assert main([*argv[:3], str(tmp_path / "again.yaml"), "--template", str(both)]) == 0
    again = (tmp_path / "again.yaml").read_text()
    assert again.count("# projected: accel:") == 1
    assert again.count("# projected: gyro:") == 1


def test_units_given_against_a_robot_logs_units_are_warned(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: a ROS bag (sensor_msgs/Imu: rad/s) diagnosed with --units deg/s was read 57
    times too quiet without a word: the readouts (N 0.012 deg/sqrt(h)) look plausible."""
    pytest.importorskip("rosbags")
    from test_io_robot_logs import write_bag

    n = 3000
    data = np.random.default_rng(9).standard_normal((n, 6)) * 0.01
    write_bag(tmp_path / "imu.bag", "ros1", data, np.arange(n) / 200.0, topics=("/imu0",))
    bag = str(tmp_path / "imu.bag")
    assert main(["analyze", bag, "--channels", "gyro_x", "--units", "deg/s", "--summary"]) == 0
    out, err = capsys.readouterr()
    note = "--units differs from the unit the file states (gyro_x in rad/s read as deg/s)"
    assert f"warning: {note}" in out  # the record summary lists it with the reader's notes
    assert main(["analyze", bag, "--channels", "gyro_x", "--units", "rad/s", "--summary"]) == 0
    assert "file states" not in "".join(capsys.readouterr())
    assert main(["fit", bag, "--units", "deg/s,m/s^2"]) == 0  # one unit per sensor
    err = capsys.readouterr().err
    assert "(gyro_x in rad/s read as deg/s, gyro_y in rad/s read as deg/s" in err
    assert "accel_x in" not in err


def test_fit_prints_what_the_reader_noticed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: fit and diagnose dropped the reader's notes (analyze shows them in its
    summary): a "t,gz" CSV fitted with --fs said only "angle given as rate?" about t."""
    path = tmp_path / "nav.csv"
    t = np.arange(3000) / FS
    np.savetxt(path, np.column_stack([t, RNG.standard_normal(3000)]), delimiter=",",
               header="t,gz", comments="")  # fmt: skip
    assert main(["fit", str(path), "--fs", "100", "--units", "deg/s"]) == 0
    err = capsys.readouterr().err
    assert "allanite fit: note: channel t is named like time stamps and always increases: if " \
        "it is the time, give --time-column t" in err  # fmt: skip
    assert err.count("named like time stamps") == 1
    model = tmp_path / "m.json"
    NoiseModel([White(0.01)], units={"rate": "deg/s", "time": "s"}).save(model)
    argv = ["diagnose", str(path), "--fs", "100", "--units", "deg/s", "--channels", "t"]
    assert main([*argv, "--sim-model", str(model), "--n-mc", "20"]) == 0
    assert "allanite diagnose: note: channel t is named like time stamps" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("name", "first", "step", "unit"),
    [
        ("t_ms", 0.0, 10.0, "milliseconds"),
        ("time[us]", 0.0, 1e4, "microseconds"),
        ("stamp", 1.7e18, 1e7, "nanoseconds"),
        ("header.stamp", 1.7e18, 1e7, "nanoseconds"),
    ],
)
def test_time_stamps_whose_name_says_the_unit_are_converted(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    name: str,
    first: float,
    step: float,
    unit: str,
) -> None:
    """Regression: a log with time stamps in ms (``t_ms``) or ROS ns stamps was read in
    seconds: fs 0.1 Hz (or 1e-7 Hz) instead of 100 Hz, N 32 times too large. A name stating
    the unit is converted to seconds with a note."""
    path = tmp_path / "log.csv"
    n = 4000
    stamps = first + np.arange(n) * step  # 100 Hz in the stamps' own unit
    rate = 0.01 * np.sqrt(FS) * np.random.default_rng(4).standard_normal(n)  # N 0.6 deg/sqrt(h)
    with path.open("w") as out:
        out.write(f"{name},gz\n")
        out.writelines(f"{s:.0f},{r:.10g}\n" for s, r in zip(stamps, rate, strict=True))
    argv = ["fit", str(path), "--time-column", name, "--units", "deg/s"]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert f"time column {name!r} read as {unit} (its name says so), converted to seconds" in err
    value = float(out.split("N = ")[1].split(" deg/sqrt(h)")[0])
    assert abs(value / 0.6 - 1) < 0.05  # 4000 samples: s.e. of N about 1.5 %


@pytest.mark.parametrize(("name", "first", "step"), [("t", 1.7e18, 1e7), ("t", 0.0, 1e-8)])
def test_a_time_column_implying_no_imu_rate_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, first: float, step: float
) -> None:
    """Regression: nanosecond stamps in a column named ``t`` were fitted at fs = 1e-7 Hz."""
    path = tmp_path / "log.csv"
    n = 100
    rate = np.random.default_rng(5).standard_normal(n)
    with path.open("w") as out:
        out.write(f"{name},gz\n")
        out.writelines(f"{first + i * step!r},{r:.10g}\n" for i, r in enumerate(rate))
    assert main(["fit", str(path), "--time-column", name, "--units", "deg/s"]) != 0
    err = capsys.readouterr().err
    assert f"time column {name!r} read in seconds implies fs = " in err
    assert "--time-scale" in err
    assert "--fs" in err


def test_a_missing_ulog_topic_lists_the_ones_there(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: --topic sensor_gyro on a log with only sensor_combined said "found none"
    (the reader had filtered the log down to the topic asked for)."""
    pytest.importorskip("pyulog")
    from test_io_robot_logs import write_ulog

    fields = [("uint64_t", "timestamp")] + [("float", f"gyro_rad[{i}]") for i in range(3)]
    rows = [(1_000_000 + 5000 * k, 0.01 * k % 3, 0.0, 0.0) for k in range(600)]
    write_ulog(tmp_path / "f.ulg", "sensor_combined", fields, rows)
    assert main(["analyze", str(tmp_path / "f.ulg"), "--topic", "sensor_gyro"]) == 2
    line = _one_line_error(capsys, "analyze")
    assert line.endswith(
        "no IMU topic sensor_gyro (instance 0) in the log; found sensor_combined:0"
    )


def test_report_without_o_names_its_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Regression: ``allanite report fog.csv`` printed the whole usage text: -o was required."""
    data = tmp_path / "data"
    data.mkdir()
    path = data / "fog.csv"
    _header_csv(path)
    monkeypatch.chdir(tmp_path)
    assert main(["report", str(path), "--time-column", "time", "--no-fit"]) == 0
    assert capsys.readouterr().out.strip().endswith("wrote fog.html")
    assert "<html" in (tmp_path / "fog.html").read_text()[:200].lower()
    assert not (data / "fog.html").exists()  # in the current directory, not beside the data
    # several records go into one report: its name is asked for, nothing is written
    assert main(["report", str(path), str(path), "--time-column", "time", "--no-fit"]) == 2
    assert "2 records go into one report: name it with -o FILE.html" in _one_line_error(
        capsys, "report"
    )


def test_an_index_in_a_column_name_states_no_unit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: the README's ``allanite analyze run1.npz --key gyro_counts --scale 0.05
    --units deg/s`` warned "--units differs from the unit the file states (gyro_counts[0] read
    as deg/s ...)", and without --units "the header states 0, 1, 2, not a unit": the columns
    ``key[i]`` of a 2-D array were read as stating the unit "0"."""
    from allanite.io import read_record

    path = tmp_path / "run.npz"
    counts = np.round(RNG.standard_normal((3000, 3)) * 8).astype(np.int16)
    np.savez(path, gyro_counts=counts)
    given = read_record(path, fs=FS, key="gyro_counts", scale=0.05, units="deg/s")
    assert given.channels == ("gyro_counts[0]", "gyro_counts[1]", "gyro_counts[2]")
    assert given.warnings == ()
    assert read_record(path, fs=FS, key="gyro_counts").warnings == ()
    argv = ["analyze", str(path), "--key", "gyro_counts", "--fs", "100", "--summary"]
    assert main([*argv, "--scale", "0.05", "--units", "deg/s"]) == 0
    assert "file states" not in "".join(capsys.readouterr())
    assert main(argv) == 0
    assert "header states" not in "".join(capsys.readouterr())
    # a unit in brackets is still read: gz[deg/h]
    _header_csv(tmp_path / "fog.csv")
    assert read_record(tmp_path / "fog.csv", time_column="time").units == "deg/h"


def test_units_of_another_quantity_than_the_file_states_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: a ROS bag's gyro_x (sensor_msgs/Imu: rad/s) diagnosed with --units m/s^2
    against a Gazebo SDF was compared with the SDF's accelerometer, and --write-corrected
    wrote the gyro's "correction" into the accelerometer block; only a note was printed."""
    pytest.importorskip("rosbags")
    from test_io_robot_logs import write_bag

    n = 3000
    data = np.random.default_rng(9).standard_normal((n, 6)) * 0.01
    write_bag(tmp_path / "imu.bag", "ros1", data, np.arange(n) / 200.0, topics=("/imu0",))
    bag = str(tmp_path / "imu.bag")
    model = NoiseModel([White(1e-3)], units={"rate": "m/s^2", "time": "s"})
    model.save(tmp_path / "accel.json")
    out = tmp_path / "fixed.json"
    argv = ["diagnose", bag, "--channels", "gyro_x", "--units", "m/s^2"]
    argv += ["--sim-model", str(tmp_path / "accel.json"), "--write-corrected", str(out)]
    assert main(argv) == 2
    line = _one_line_error(capsys, "diagnose")
    assert line.endswith(
        "imu.bag: --units m/s^2 is an acceleration, but the file states rad/s (an angular "
        "rate) for gyro_x: leave --units out to read every channel in the unit the file "
        "states, or pick that sensor's channels with --channels (fit and report take one unit "
        "per sensor, e.g. --units rad/s,m/s^2)"
    )
    assert not out.exists()
    # one unit for a six-axis log: the accelerometer's channels are named
    assert main(["analyze", bag, "--units", "rad/s", "--summary"]) == 2
    assert "the file states m/s^2 (an acceleration) for accel_x, accel_y, accel_z" in (
        _one_line_error(capsys, "analyze")
    )
    # a header stating an angle, read as rate samples
    _header_csv(tmp_path / "theta.csv", unit="deg")
    assert main(["fit", str(tmp_path / "theta.csv"), "--time-column", "time", "--units",
                 "deg/s"]) == 2  # fmt: skip
    assert (
        "--units deg/s is an angular rate, but the file states deg (an angle) for gz[deg]: give "
        "--input angle (or increment) --units deg if the samples are angles"
    ) in _one_line_error(capsys, "fit")
    assert main(["fit", str(tmp_path / "theta.csv"), "--time-column", "time", "--input", "angle",
                 "--units", "deg"]) == 0  # fmt: skip
    capsys.readouterr()
    # the same quantity in another unit is still a note, and the unit given is used
    assert main(["analyze", bag, "--channels", "gyro_x", "--units", "deg/s", "--summary"]) == 0
    assert "(gyro_x in rad/s read as deg/s)" in capsys.readouterr().out
