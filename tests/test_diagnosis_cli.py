"""``allanite diagnose``: the exact CLI contract (--json is one JSON object), errors, outputs."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from allanite.cli import main
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

FS = 100.0
N = 2**14


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("diagnose")
    base = NoiseModel(
        (TERM_TYPES["white"](N=0.05), TERM_TYPES["rrw"](K=0.001)), {"rate": "deg/s", "time": "s"}
    )
    real = base.plus(TERM_TYPES["sine"](amplitude=0.2, frequency=13.0)).simulate(N, fs=FS, seed=3)
    paths = {
        "model": root / "model.json",
        "real": root / "real.npy",
        "sim": root / "sim.npy",
        "short": root / "short.npy",
        "nan": root / "nan.npy",
    }
    base.save(paths["model"])
    np.save(paths["real"], real)
    np.save(paths["sim"], base.simulate(N, fs=FS, seed=4))
    np.save(paths["short"], real[: N // 4])
    bad = real.copy()
    bad[10] = np.nan
    np.save(paths["nan"], bad)
    return paths


def test_json_is_exactly_one_object(files, tmp_path):
    cmd = [
        sys.executable, "-m", "allanite", "diagnose", str(files["real"]), "--fs", "100",
        "--units", "deg/s", "--sim-model", str(files["model"]), "--holdout", "0.5",
        "--n-mc", "40", "--json", "--report", str(tmp_path / "gap.html"),
    ]  # fmt: skip
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, timeout=600)
    data = json.loads(out.stdout)  # fails on anything but exactly one JSON value
    assert isinstance(data, dict)
    assert data["gap"]["significant"] is True
    assert isinstance(data["gap"]["statistic"], float)
    assert isinstance(data["gap"]["p_value"], float)
    assert data["where"]["frequency_lines_hz"][0] == pytest.approx(13.0, rel=0.02)
    assert data["attribution"][0]["effect"] == "sine"
    for entry in data["attribution"]:
        assert isinstance(entry["shrinkage"], float)
        assert isinstance(entry["consistent_after"], bool)
        assert all(isinstance(e, str) for e in entry["alternatives"])
    # the contract: {"shrinkage": float} | null; a sine is checked on the held-out half
    assert isinstance(data["holdout"]["shrinkage"], float)
    html = (tmp_path / "gap.html").read_text()
    assert "<img" in html
    assert "sine" in html


def test_sim_record_and_full_output(files, tmp_path, capsys):
    out_file = tmp_path / "full.json"
    code = main(
        [
            "diagnose", str(files["real"]), "--fs", "100", "--sim-record", str(files["sim"]),
            "--n-mc", "20", "--effects", "sine,white", "-o", str(out_file),
        ]
    )  # fmt: skip
    assert code == 0
    text = capsys.readouterr().out
    assert "SIGNIFICANT" in text
    assert "sine" in text
    full = json.loads(out_file.read_text())
    # a simulated record has no model: the term list is the effects' alone, and says so
    terms = full["explanation"]["terms"]
    assert [t["type"] for t in terms] == [a["term"]["type"] for a in full["explanation"]["effects"]]
    (line,) = [x for x in text.splitlines() if '"terms"' in x]
    assert "the effects as model JSON" in line
    assert "with the effects added" not in line
    assert json.loads(line[line.index("[") :]) == terms
    assert set(full["views"]) == {"tau", "frequency", "time"}
    assert full["meta"]["sim"] == "record"


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--units", "m/s^2", "--sim-model", "{model}"], "no accel noise model"),
        (["--sim-model", "{model}"], "units are never guessed"),
        (["--sim-record", "{short}"], "shorter than the real"),
        (["--sim-record", "{sim}", "--sim-fs", "200"], "sample-rate mismatch"),
        (["--sim-record", "{nan}"], "NaN"),
        (["--units", "deg/s", "--sim-model", "{model}", "--holdout", "2"], "holdout"),
        (["--units", "deg/s", "--sim-model", "{model}", "--seed", "-1"], "--seed must be"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(files, capsys, extra, message):
    args = [a.format(**{k: str(v) for k, v in files.items()}) for a in extra]
    code = main(["diagnose", str(files["real"]), "--fs", "100", "--n-mc", "20", *args])
    assert code == 2
    err = capsys.readouterr().err
    assert message.lower() in err.lower()
    assert len(err.strip().splitlines()) == 1


def test_sim_source_is_required(files):
    with pytest.raises(SystemExit):
        main(["diagnose", str(files["real"]), "--fs", "100"])


def test_a_model_in_another_unit_of_the_same_quantity_is_converted(files, tmp_path, capsys):
    """A deg/s record against a rad/s model JSON: the model is put in deg/s, as configs are."""
    from allanite.model import NoiseModel

    model = NoiseModel.load(files["model"])
    in_rad = tmp_path / "model_rad.json"
    model.in_units("rad/s").save(in_rad)
    common = ["diagnose", str(files["real"]), "--fs", "100", "--units", "deg/s", "--n-mc", "20"]
    assert main([*common, "--sim-model", str(files["model"]), "--json"]) == 0
    same = json.loads(capsys.readouterr().out)
    assert main([*common, "--sim-model", str(in_rad), "--json"]) == 0
    converted = json.loads(capsys.readouterr().out)
    assert converted["gap"]["p_value"] == pytest.approx(same["gap"]["p_value"], rel=1e-9)
    assert converted["meta"]["units"] == "deg/s"


def test_help_describes_every_top_level_json_field(files, capsys):
    """The --help epilog names every key of the --json object (headline and explanation too)."""
    with pytest.raises(SystemExit):
        main(["diagnose", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    code = main(
        ["diagnose", str(files["real"]), "--fs", "100", "--units", "deg/s", "--sim-model",
         str(files["model"]), "--n-mc", "20", "--json"]
    )  # fmt: skip
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    epilog = text[text.index("JSON (--json)") :]
    for key in data:
        assert key in epilog, key
    for key in data["explanation"]:
        assert key in epilog, key


def test_a_model_of_the_other_sensor_is_refused_with_what_to_give(files, tmp_path, capsys):
    """A gyro record against an accelerometer model JSON: one error naming both sensors (it
    used to advise --sim-sensor accel, which then failed on a 'unit mismatch')."""
    accel = NoiseModel((TERM_TYPES["white"](N=0.002),), {"rate": "m/s^2", "time": "s"})
    path = tmp_path / "accel.json"
    accel.save(path)
    common = ["diagnose", str(files["real"]), "--fs", "100", "--units", "deg/s", "--n-mc", "20"]
    assert main([*common, "--sim-model", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "accel.json is an accelerometer model (m/s^2)" in err
    assert "the record is a gyro record (--units deg/s)" in err
    assert "--sim-sensor accel" not in err
    assert main([*common, "--sim-model", str(path), "--sim-sensor", "accel"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--sim-sensor accel compares an accelerometer model with a gyro record" in err
    assert "unit mismatch" not in err


def test_progress_is_shown_on_a_terminal_for_a_short_record(files, capsys, monkeypatch):
    """A 480 000-sample ROS bag took 30-160 s to diagnose in silence: auto showed progress
    only from 2^20 samples. On a terminal it is shown whatever the length."""
    argv = [
        "diagnose", str(files["real"]), "--fs", "100", "--units", "deg/s",
        "--sim-model", str(files["model"]), "--n-mc", "20", "--effects", "sine",
    ]  # fmt: skip
    assert main(argv) == 0
    assert "diagnose: " not in capsys.readouterr().err  # not a terminal: quiet below 2^20
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert main(argv) == 0
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("diagnose: ")]
    assert lines, "no progress line on a terminal"


def test_a_config_with_zero_noise_is_refused_before_the_diagnosis(files, tmp_path, capsys):
    """A gnss-ins-sim file whose gyro entries are zero failed late with 'the model has no
    terms', naming neither the file nor the sensor."""
    from allanite.formats import ImuConfig, write_config
    from allanite.formats.base import sensor_model

    config = tmp_path / "imu_err.py"
    accel = sensor_model([TERM_TYPES["white"](N=1e-3)], "accel")
    write_config(ImuConfig(accel=accel), config, format="gnss-ins-sim", rate=100.0)
    argv = [
        "diagnose", str(files["real"]), "--fs", "100", "--units", "deg/s",
        "--sim-model", str(config), "--n-mc", "20",
    ]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "imu_err.py (gnss-ins-sim) gives the gyro no noise" in err
    assert "set its gyro noise" in err


def test_a_wrong_config_is_told_what_to_change_in_its_own_names_and_units(tmp_path, capsys):
    """Against a Kalibr file with 3x the gyro noise density the diagnosis said N = ... deg/√h
    and gave model-JSON terms; the user edits gyroscope_noise_density in rad/s/√Hz (SDF: the
    per-sample stddev of each axis). The change is listed in those names; untouched keys
    (the accelerometer's, rewritten as 0.002 for 2e-3) are not."""
    import re

    white = NoiseModel((TERM_TYPES["white"](N=1e-3),), {"rate": "rad/s", "time": "s"})
    real = tmp_path / "real.npy"
    np.save(real, white.simulate(2**15, fs=100.0, seed=1))
    kalibr = tmp_path / "imu.yaml"
    kalibr.write_text(
        "gyroscope_noise_density: 3e-3\ngyroscope_random_walk: 1e-7\n"
        "accelerometer_noise_density: 2e-3\naccelerometer_random_walk: 3e-5\nupdate_rate: 100\n"
    )
    sdf = tmp_path / "imu.sdf"
    axes = "".join(
        f"<{a}><noise type='gaussian'><stddev>0.03</stddev></noise></{a}>" for a in "xyz"
    )
    sdf.write_text(
        f"<sensor type='imu'><update_rate>100</update_rate><imu><angular_velocity>{axes}"
        "</angular_velocity></imu></sensor>"
    )
    base = ["diagnose", str(real), "--fs", "100", "--units", "rad/s", "--sim-model"]

    def white_n(out: str) -> float:  # the white noise of the corrected model (whites add)
        found = re.findall(r'"white", "N": ([0-9.e+-]+)', out.split('"terms" with', 1)[1])
        return math.hypot(*map(float, found))

    assert main([*base, str(kalibr)]) == 0
    out = capsys.readouterr().out
    fitted = white_n(out)
    assert "change in imu.yaml (kalibr; --write-corrected OUT writes it):" in out
    changes = out.split("--write-corrected OUT writes it):\n", 1)[1].splitlines()
    assert len(changes) == 1, changes
    old, new = changes[0].split("  ->  ")
    assert old.split(":")[0].strip() == "gyroscope_noise_density"
    assert float(old.split(":")[1]) == 3e-3
    assert new.startswith("gyroscope_noise_density: ")
    assert new.endswith("[rad/s/sqrt(Hz)]")
    assert float(new.split()[1]) == pytest.approx(fitted, rel=1e-9)
    assert main([*base, str(sdf)]) == 0
    out = capsys.readouterr().out
    fitted = white_n(out)
    line = next(ln for ln in out.splitlines() if "<stddev>0.03</stddev>  ->" in ln)
    # only the measured axis (x: the channel names none) changes, not the y and z blocks
    assert line.endswith("[per sample: rad/s | m/s^2]")
    stddev = float(re.search(r"->\s+<stddev>([0-9.e+-]+)</stddev>", line).group(1))
    assert stddev == pytest.approx(fitted * 10.0, rel=1e-9)  # stddev = N / sqrt(dt)
    plugin = tmp_path / "px4.sdf"  # the PX4 plugin's defaults: N 3.39e-4, bias tau 1000 s
    plugin.write_text('<plugin name="imu_plugin" filename="libgazebo_imu_plugin.so"></plugin>')
    assert main([*base, str(plugin)]) == 0
    out = capsys.readouterr().out
    fitted = white_n(out)
    line = next(ln for ln in out.splitlines() if "<gyroscopeNoiseDensity>0.000339" in ln)
    assert line.endswith("</gyroscopeNoiseDensity>  [rad/s/sqrt(Hz)]")
    new_density = re.search(r"->\s+<gyroscopeNoiseDensity>([0-9.e+-]+)<", line).group(1)
    assert float(new_density) == pytest.approx(fitted, rel=1e-9)
    for line in out.split("writes it):\n", 1)[1].splitlines():  # every changed line: a unit
        assert re.search(r"\[(rad/s\S*|s)\]$", line), line


def test_a_corrected_config_that_cannot_be_written_keeps_the_diagnosis(tmp_path, capsys):
    """Regression: a --write-corrected failure (here a folder that does not exist) ended the
    command before the diagnosis was printed or --output written, after minutes of work."""
    white = NoiseModel((TERM_TYPES["white"](N=1e-3),), {"rate": "rad/s", "time": "s"})
    real = tmp_path / "real.npy"
    np.save(real, white.simulate(2**14, fs=100.0, seed=2))
    kalibr = tmp_path / "imu.yaml"
    kalibr.write_text(
        "gyroscope_noise_density: 3e-3\ngyroscope_random_walk: 1e-7\n"
        "accelerometer_noise_density: 2e-3\naccelerometer_random_walk: 3e-5\nupdate_rate: 100\n"
    )
    out_json = tmp_path / "d.json"
    target = tmp_path / "no such folder" / "fixed.yaml"
    argv = [
        "diagnose", str(real), "--fs", "100", "--units", "rad/s", "--sim-model", str(kalibr),
        "--n-mc", "20", "--output", str(out_json), "--write-corrected", str(target),
    ]  # fmt: skip
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert "--write-corrected OUT writes it):" in captured.out  # not "written to"
    assert "gyroscope_noise_density" in captured.out
    assert json.loads(out_json.read_text())["gap"]["significant"] is True
    assert "the diagnosis above stands, but --write-corrected" in captured.err
    assert "no such folder" in captured.err
    assert not target.exists()
