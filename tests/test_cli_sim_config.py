"""``allanite model convert`` and ``allanite diagnose --sim-model CONFIG --write-corrected``."""

from __future__ import annotations

import math

import numpy as np
import pytest

from allanite.cli import main
from allanite.formats import read_config
from allanite.model import NoiseModel
from allanite.terms import RateRandomWalk, White

FS = 100.0
N = 2**14


def test_convert_kalibr_to_sdf_and_back(tmp_path, capsys):
    src = tmp_path / "imu.yaml"
    src.write_text("gyroscope_noise_density: 0.001\ngyroscope_random_walk: 2.0e-5\n"
                   "update_rate: 200.0\n")  # fmt: skip
    assert main(["model", "convert", str(src), str(tmp_path / "m.sdf"), "--to", "gz-sdf"]) == 0
    assert "projected gyro: rrw" in capsys.readouterr().err  # the SDF holds no random walk
    cfg = read_config(tmp_path / "m.sdf")
    assert cfg.rate == 200.0
    white = cfg.model("gyro").terms_of_type("white")[0]
    assert math.isclose(white.N, 1e-3, rel_tol=1e-9)
    assert main(["model", "convert", str(src), str(tmp_path / "model.json")]) == 0
    model = NoiseModel.load(tmp_path / "model.json")
    assert model.units["rate"] == "rad/s"
    assert [t.type for t in model.terms] == ["white", "rrw"]


def test_convert_errors_are_one_line_rc2(tmp_path, capsys):
    src = tmp_path / "imu.yaml"
    src.write_text("something: 1\n")
    assert main(["model", "convert", str(src), str(tmp_path / "o.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "--from" in err
    assert not (tmp_path / "o.yaml").exists()
    sdf = tmp_path / "a.sdf"
    noise = "<noise type='gaussian'><stddev>0.01</stddev></noise>"
    sdf.write_text(f"<sensor type='imu'><imu><angular_velocity><x>{noise}</x>"
                   "</angular_velocity></imu></sensor>")  # fmt: skip
    assert main(["model", "convert", str(sdf), str(tmp_path / "o.json")]) == 2
    assert "--rate" in capsys.readouterr().err
    assert main(["model", "convert", str(sdf), str(tmp_path / "o.json"), "--rate", "100"]) == 0


def test_samples_given_as_a_config_are_named_not_decoded(tmp_path, capsys):
    np.save(tmp_path / "rec.npy", np.zeros(10))
    (tmp_path / "rec.bin").write_bytes(bytes(range(256)))
    for bad, said in (("rec.npy", "NumPy .npy array"), ("rec.bin", "not a text file")):
        out = tmp_path / "o.yaml"
        assert main(["model", "convert", str(tmp_path / bad), str(out)]) == 2
        err = capsys.readouterr().err
        assert said in err
        assert "codec" not in err
        assert err.count("\n") == 1
        assert not out.exists()
    assert main(["model", "convert", str(tmp_path / "missing.yaml"), str(out)]) == 2
    assert "no such model file" in capsys.readouterr().err


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    root = tmp_path_factory.mktemp("loop")
    truth = NoiseModel((White(N=0.03), RateRandomWalk(K=0.002)), {"rate": "deg/s", "time": "s"})
    np.save(root / "real.npy", truth.simulate(N, fs=FS, seed=11))
    # a simulator config with the white noise 3x too low (densities in SI units)
    d2r = math.pi / 180
    (root / "kalibr.yaml").write_text(
        "# my camera-imu setup\nrostopic: /imu0\n"
        f"gyroscope_noise_density: {0.01 * d2r}\ngyroscope_random_walk: {0.002 * d2r}\n"
        "accelerometer_noise_density: 0.002\naccelerometer_random_walk: 0.0003\n"
        "update_rate: 100.0\n"
    )
    return root


def test_diagnose_a_kalibr_config_and_write_the_corrected_one(loop, capsys):
    out = loop / "kalibr_fixed.yaml"
    argv = [
        "diagnose", str(loop / "real.npy"), "--fs", "100", "--units", "deg/s",
        "--sim-model", str(loop / "kalibr.yaml"), "--n-mc", "40",
        "--write-corrected", str(out),
    ]  # fmt: skip
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "SIGNIFICANT" in captured.out
    assert "corrected config" in captured.err
    text = out.read_text()
    assert "# my camera-imu setup" in text  # the user's file, only the values changed
    assert "accelerometer_noise_density: 0.002" in text
    fixed = read_config(out).model("gyro").in_units("deg/s")
    n = fixed.terms_of_type("white")[0].N
    assert abs(n - 0.03) < 0.1 * 0.03  # the diagnosed white noise is folded in
    # the corrected config closes the gap
    argv[argv.index("--sim-model") + 1] = str(out)
    argv = argv[: argv.index("--write-corrected")]
    assert main(argv) == 0
    assert "consistent with chance" in capsys.readouterr().out


def test_diagnose_config_without_units_says_so(loop, capsys):
    argv = [
        "diagnose", str(loop / "real.npy"), "--fs", "100",
        "--sim-model", str(loop / "kalibr.yaml"), "--n-mc", "20",
    ]  # fmt: skip
    assert main(argv) == 2
    assert "--units" in capsys.readouterr().err


def test_accelerometer_of_a_config_is_chosen_by_the_record_unit(loop, capsys):
    truth = NoiseModel((White(N=0.004), RateRandomWalk(K=3e-4)), {"rate": "m/s^2", "time": "s"})
    np.save(loop / "accel.npy", truth.simulate(N, fs=FS, seed=12))
    out = loop / "fixed.yaml"
    argv = [
        "diagnose", str(loop / "accel.npy"), "--fs", "100", "--units", "m/s^2",
        "--sim-model", str(loop / "kalibr.yaml"), "--n-mc", "40", "--write-corrected", str(out),
    ]  # fmt: skip
    assert main(argv) == 0
    assert "SIGNIFICANT" in capsys.readouterr().out  # the config's 0.002 vs the real 0.004
    fixed = read_config(out)
    n = fixed.model("accel").terms_of_type("white")[0].N
    assert abs(n - 0.004) < 0.1 * 0.004
    gyro = fixed.model("gyro").terms_of_type("white")[0].N
    assert math.isclose(gyro, 0.01 * math.pi / 180, rel_tol=1e-8)  # the gyro is untouched


def test_sdf_without_rate_takes_the_records(loop, capsys):
    noise = "<noise type='gaussian'><stddev>0.3</stddev></noise>"  # 0.03 deg/s*sqrt(s) at 100 Hz
    axes = "".join(f"<{a}>{noise}</{a}>" for a in "xyz")
    sdf = loop / "imu.sdf"
    sdf.write_text(f"<sensor type='imu'><imu><angular_velocity>{axes}</angular_velocity></imu>"
                   "</sensor>".replace("0.3", str(0.03 * 10 * math.pi / 180)))  # fmt: skip
    argv = [
        "diagnose", str(loop / "real.npy"), "--fs", "100", "--units", "deg/s",
        "--sim-model", str(sdf), "--n-mc", "40",
    ]  # fmt: skip
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "taken from the record: 100 Hz" in captured.err
    # per-sample stddev at the record's 100 Hz is the real white noise: no gap at this length
    assert "consistent with chance" in captured.out


def test_write_corrected_needs_a_config(loop, capsys):
    np.save(loop / "sim.npy", np.zeros(N))
    argv = [
        "diagnose", str(loop / "real.npy"), "--fs", "100", "--units", "deg/s",
        "--sim-record", str(loop / "sim.npy"), "--write-corrected", str(loop / "x.yaml"),
    ]  # fmt: skip
    assert main(argv) == 2
    assert "--sim-model" in capsys.readouterr().err
    assert not (loop / "x.yaml").exists()


def test_a_ros_bag_against_a_gazebo_sdf(loop, tmp_path, capsys):
    pytest.importorskip("rosbags")
    from test_io_robot_logs import write_bag

    rate = 100.0
    truth = NoiseModel((White(N=0.002), RateRandomWalk(K=1e-3)), {"rate": "rad/s", "time": "s"})
    gyro = truth.simulate(N, fs=rate, n_channels=3, seed=21)
    data = np.column_stack([gyro, np.zeros((N, 2)), np.full(N, 9.81)])
    write_bag(tmp_path / "flight.bag", "ros1", data, np.arange(N) / rate, topics=("/imu0",))
    stddev = 0.002 * math.sqrt(rate)  # the white noise right, the random walk missing
    noise = f"<noise type='gaussian'><stddev>{stddev}</stddev></noise>"
    axes = "".join(f"<{a}>{noise}</{a}>" for a in "xyz")
    (tmp_path / "imu.sdf").write_text(
        f"<sensor type='imu'><update_rate>{rate}</update_rate><imu><angular_velocity>{axes}"
        "</angular_velocity></imu></sensor>"
    )
    argv = [
        "diagnose", str(tmp_path / "flight.bag"), "--topic", "/imu0", "--channels", "gyro_x",
        "--units", "rad/s", "--sim-model", str(tmp_path / "imu.sdf"), "--n-mc", "40",
        "--write-corrected", str(tmp_path / "fixed.sdf"),
    ]  # fmt: skip
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "SIGNIFICANT" in captured.out
    fixed = read_config(tmp_path / "fixed.sdf").model("gyro")
    # the SDF holds no random walk: the diagnosed rrw comes back as a long Gauss-Markov bias
    (gm,) = fixed.terms_of_type("markov")
    assert gm.tau_c > 10.0
    assert "projected gyro: rrw" in captured.err


def test_diagnose_sim_model_given_samples_is_refused(loop, capsys):
    real = str(loop / "real.npy")
    args = ["diagnose", real, "--fs", str(FS), "--units", "deg/s", "--sim-model", real]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "NumPy .npy array" in err
    assert "codec" not in err


def test_report_reads_a_simulator_config_as_diagnose_does(tmp_path, capsys):
    """``report --sim-model kalibr.yaml`` reads the config (in SI) in the record's unit."""
    pytest.importorskip("matplotlib")
    n_si, k_si = 1e-3, 2e-5  # rad/s/sqrt(Hz), rad/s^2/sqrt(Hz)
    src = tmp_path / "kalibr.yaml"
    src.write_text(f"gyroscope_noise_density: {n_si}\ngyroscope_random_walk: {k_si}\n"
                   "update_rate: 100.0\n")  # fmt: skip
    model = NoiseModel((White(N=n_si), RateRandomWalk(K=k_si)), {"rate": "rad/s", "time": "s"})
    rec = tmp_path / "real.npy"
    np.save(rec, np.degrees(model.simulate(N, fs=FS, seed=5)))
    out = tmp_path / "r.html"
    argv = ["report", str(rec), "--fs", "100", "--units", "deg/s", "--no-fit", "--n-mc", "20"]
    assert main([*argv, "--sim-model", str(src), "-o", str(out)]) == 0, capsys.readouterr().err
    html = out.read_text()
    assert "Sim-to-real diagnosis" in html
    assert "kalibr.yaml" in html
    assert "no gap" in html


def test_convert_warns_when_the_written_file_departs_or_lacks_a_sensor(tmp_path, capsys):
    """Read back as the simulator reads it: a poor projection and a missing sensor are warned."""
    flicker = NoiseModel.from_dict(
        {"units": {"rate": "rad/s", "time": "s"}, "terms": [{"type": "flicker", "B": 1e-4}]}
    )
    src = tmp_path / "flicker.json"
    flicker.save(src)
    assert main(["model", "convert", str(src), str(tmp_path / "k.yaml"), "--rate", "100"]) == 0
    err = capsys.readouterr().err
    assert "warning: the written gyro model departs from the source by up to" in err
    assert "has no accel noise entries" in err
    white = NoiseModel((White(N=1e-3),), {"rate": "rad/s", "time": "s"})
    white.save(src)
    assert main(["model", "convert", str(src), str(tmp_path / "k2.yaml"), "--rate", "100"]) == 0
    err = capsys.readouterr().err
    assert "departs" not in err  # white noise is held exactly
    assert main(["model", "convert", str(tmp_path / "k2.yaml"), str(tmp_path / "back.json")]) == 0
    assert "warning" not in capsys.readouterr().err  # a model JSON holds one sensor by design


def test_a_config_with_both_sensors_into_a_model_json_warns_once(tmp_path, capsys):
    """Regression: a PX4 plugin block written for a gyro (the plugin's defaults give it an
    accelerometer) converted to a model JSON said "dropped accel: the model JSON holds one
    sensor ..." and then warned "back.json lost the accel model (the format cannot hold
    it)", as if a model had been lost that the user never had."""
    gyro = NoiseModel((White(N=1.2e-4), RateRandomWalk(K=2.6e-5)), {"rate": "rad/s", "time": "s"})
    gyro.save(tmp_path / "g.json")
    sdf = tmp_path / "px4.sdf"
    assert main(["model", "convert", str(tmp_path / "g.json"), str(sdf), "--to", "px4-plugin",
                 "--rate", "200"]) == 0  # fmt: skip
    capsys.readouterr()
    assert main(["model", "convert", str(sdf), str(tmp_path / "back.json")]) == 0
    err = capsys.readouterr().err
    assert "dropped accel: the model JSON holds one sensor" in err  # how to write the other
    assert "lost the accel model" not in err
    assert NoiseModel.load(tmp_path / "back.json").units["rate"] == "rad/s"
