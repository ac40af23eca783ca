"""Configs as users write them: misspelled keys, disabled noise, formatting kept on write.

Issue #30 items 1-5: a misspelled key is named (and a half-given sensor refused), an SDF
noise block of type none is named as the cause, configs are checked before a record is read,
``--write-corrected`` edits only the values it changes, ``model convert`` keeps the topic.
"""

from __future__ import annotations

import difflib
import math

import pytest

from allanite.cli import main
from allanite.formats import read_config
from allanite.model import NoiseModel
from allanite.terms import White

pytest.importorskip("yaml")

KALIBR_TYPO = (
    "rostopic: /imu0\n"
    "gyroscope_noise_denisty: 1.87e-4\n"
    "gyroscope_random_walk: 2.66e-5\n"
    "accelerometer_noise_density: 1.86e-3\n"
    "accelerometer_random_walk: 4.33e-4\n"
    "update_rate: 200.0\n"
)


def test_a_misspelled_kalibr_key_is_refused_naming_the_right_key(tmp_path, capsys):
    src = tmp_path / "imu.yaml"
    src.write_text(KALIBR_TYPO)
    with pytest.raises(ValueError, match="gyroscope_noise_density is missing") as exc:
        read_config(src)
    assert "gyroscope_noise_denisty" in str(exc.value)
    assert main(["model", "convert", str(src), str(tmp_path / "m.json")]) == 2
    assert "gyroscope_noise_denisty" in capsys.readouterr().err


def test_unknown_keys_are_warned_with_the_closest_known_key(tmp_path, capsys):
    src = tmp_path / "imu.yaml"
    src.write_text(KALIBR_TYPO.replace("denisty", "density") + "update_rat: 100\nfoo: 1\n")
    notes = read_config(src).notes
    assert any("'update_rat'" in n and "did you mean 'update_rate'" in n for n in notes)
    assert any("'foo'" in n for n in notes)  # Kalibr's file holds nothing else
    assert main(["model", "convert", str(src), str(tmp_path / "m.json")]) == 0
    assert "did you mean 'update_rate'" in capsys.readouterr().err
    # a VINS config holds many other settings: only near misses of its noise keys are named
    vins = tmp_path / "vins.yaml"
    vins.write_text("%YAML:1.0\nimu_topic: /imu\nacc_n: 0.08\nacc_w: 4e-5\ngyr_n: 4e-3\n"
                    "gyr_ww: 2e-6\ngyr_w: 2e-6\n")  # fmt: skip
    notes = read_config(vins, format="vins").notes
    assert len(notes) == 1
    assert "'gyr_ww'" in notes[0]


def test_a_kalibr_file_without_one_sensor_says_kalibr_would_refuse_it(tmp_path, capsys):
    """Kalibr's ConfigReader reads all four densities: a gyro-only file is read for the gyro,
    with a note that Kalibr itself needs the accelerometer's too; a gyro-only model written as
    Kalibr says the same in the file."""
    src = tmp_path / "imu.yaml"
    gyro_only = "".join(ln + "\n" for ln in KALIBR_TYPO.replace("denisty", "density").split("\n")
                        if ln and not ln.startswith("accelerometer"))  # fmt: skip
    src.write_text(gyro_only)
    config = read_config(src)
    assert config.gyro is not None
    assert config.accel is None
    assert any("accelerometer_noise_density" in n and "would refuse" in n for n in config.notes)
    assert main(["model", "convert", str(src), str(tmp_path / "m.json")]) == 0
    assert "would refuse" in capsys.readouterr().err
    # the complete file has no such note
    assert not any(
        "would refuse" in n
        for n in read_config(_written(tmp_path, KALIBR_TYPO.replace("denisty", "density"))).notes
    )
    # written back from a gyro-only model: the file says what Kalibr still needs
    out = tmp_path / "back.yaml"
    assert main(["model", "convert", str(tmp_path / "m.json"), str(out), "--to", "kalibr"]) == 0
    text = out.read_text()
    assert "gyroscope_noise_density" in text
    assert "# Kalibr imu.yaml: no accelerometer_noise_density" in text


def test_write_corrected_onto_the_config_it_corrects_is_refused_before_the_diagnosis(
    tmp_path, capsys
):
    """``--write-corrected`` naming the ``--sim-model`` file would replace the user's config:
    refused like ``-o`` onto an input, before the record is read, the file untouched."""
    src = _written(tmp_path, KALIBR_TYPO.replace("denisty", "density"))
    before = src.read_bytes()
    code = main(["diagnose", str(tmp_path / "no-record.csv"), "--fs", "200", "--units", "rad/s",
                 "--sim-model", str(src), "--write-corrected", str(src)])  # fmt: skip
    assert code == 2
    err = capsys.readouterr().err
    assert f"--write-corrected {src} is the --sim-model config itself" in err
    assert "no-record.csv" not in err  # refused before the record is read
    assert src.read_bytes() == before


def _written(tmp_path, text: str):  # type: ignore[no-untyped-def]
    path = tmp_path / "full.yaml"
    path.write_text(text)
    return path


def _sdf(noise_type: str) -> str:
    noise = (f'<noise type="{noise_type}"><mean>0.0</mean><stddev>0.002</stddev>'
             "<bias_mean>0.0</bias_mean></noise>")  # fmt: skip
    axes = "".join(f"<{a}>{noise}</{a}>" for a in "xyz")
    return (f"<sensor name='imu' type='imu'><update_rate>200.0</update_rate><imu>"
            f"<angular_velocity>{axes}</angular_velocity></imu></sensor>")  # fmt: skip


@pytest.mark.parametrize("command", ["diagnose", "report"])
def test_noise_type_none_is_named_before_the_record_is_read(tmp_path, capsys, command):
    sdf = tmp_path / "imu.sdf"
    sdf.write_text(_sdf("none"))
    # the record is not there: the config's error must come first (a bag takes minutes)
    missing = str(tmp_path / "flight_570MB.bag")
    argv = [command, missing, "--fs", "200", "--units", "rad/s", "--sim-model", str(sdf)]
    if command == "report":
        argv += ["-o", str(tmp_path / "r.html")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert 'type="none"' in err
    assert 'type="gaussian"' in err  # the fix
    assert "entry is zero" not in err
    assert "flight_570MB" not in err


def test_noise_type_none_is_noted_when_reading(tmp_path):
    sdf = tmp_path / "imu.sdf"
    sdf.write_text(_sdf("none"))
    cfg = read_config(sdf)
    assert not cfg.model("gyro").terms
    assert any('type="none"' in n and "x, y, z" in n for n in cfg.notes)
    sdf.write_text(_sdf("gaussian"))
    assert read_config(sdf).model("gyro").terms


def _gyro_axis(a: str) -> str:
    return f"""          <{a}>
            <noise type="gaussian">
              <mean>0.0</mean>
              <stddev>0.0002</stddev>
              <bias_mean>0.0000075</bias_mean>
              <bias_stddev>0.0000008</bias_stddev>
              <dynamic_bias_stddev>0.0000004</dynamic_bias_stddev>
              <dynamic_bias_correlation_time>100000.0</dynamic_bias_correlation_time>
            </noise>
          </{a}>
"""


REAL_SDF = (
    """<?xml version="1.0" ?>
<!-- x500 IMU, tuned by hand -->
<sdf version='1.9'>
  <model name='x500'>
    <link name='base_link'>
      <inertial><mass>2.0</mass></inertial>
      <sensor name='imu_sensor' type='imu'>
        <always_on>1</always_on>
        <update_rate>200.0</update_rate>
        <topic>imu/data</topic>
        <plugin filename='gz-sim-imu-system' name='gz::sim::systems::Imu'/>
        <imu>
        <angular_velocity>
"""
    + "".join(_gyro_axis(a) for a in "xyz")
    + """        </angular_velocity>
        <linear_acceleration>
          <x><noise type="gaussian"><mean>0.0</mean><stddev>0.0025</stddev></noise></x>
          <y><noise type="gaussian"><mean>0.0</mean><stddev>0.0025</stddev></noise></y>
          <z><noise type="gaussian"><mean>0.0</mean><stddev>0.0025</stddev></noise></z>
        </linear_acceleration>
        </imu>
      </sensor>
    </link>
  </model>
</sdf>
"""
)

REAL_KALIBR = """# Kalibr IMU noise, from the datasheet
rostopic: /imu0
update_rate: 200.0    # Hz

accelerometer_noise_density: 0.0     # m/s^2/sqrt(Hz)
accelerometer_random_walk: 3.0e-3     # m/s^3/sqrt(Hz)
gyroscope_noise_density: 1.6968e-04   # rad/s/sqrt(Hz)
gyroscope_random_walk: 1.9393e-05     # rad/s^2/sqrt(Hz)
"""


def _changed(before: str, after: str) -> list[str]:
    """The lines of ``before`` that ``after`` changed or removed (notes added are allowed)."""
    diff = difflib.ndiff(before.splitlines(), after.splitlines())
    return [line[2:] for line in diff if line.startswith("- ")]


@pytest.mark.parametrize(("name", "text"), [("imu.sdf", REAL_SDF), ("imu.yaml", REAL_KALIBR)])
def test_write_into_a_users_file_changes_only_the_changed_values(tmp_path, name, text):
    src = tmp_path / name
    src.write_text(text)
    config = read_config(src)
    gyro = config.model("gyro")
    white = gyro.terms_of_type("white")[0]
    terms = [White(N=3 * white.N) if t is white else t for t in gyro.terms]
    fixed = config.with_model("gyro", NoiseModel(tuple(terms), gyro.units))
    out = tmp_path / ("fixed" + src.suffix)
    write = pytest.importorskip("allanite.formats").write_config
    written = write(fixed, out, template=src)
    after = out.read_text()
    changed = _changed(text, after)
    key = "stddev>0.0002<" if name.endswith(".sdf") else "gyroscope_noise_density"
    assert changed, after
    assert all(key in line for line in changed), changed
    assert len(changed) == (3 if name.endswith(".sdf") else 1)
    # every added line is a note of the write, or a changed value
    added = [ln for ln in difflib.ndiff(text.splitlines(), after.splitlines()) if ln[:2] == "+ "]
    assert all("projected" in ln or "dropped" in ln or "stddev" in ln or "gyroscope_noise" in ln
               for ln in added), added  # fmt: skip
    assert len(added) == len(changed) + len(written.report())
    back = read_config(out).model("gyro").terms_of_type("white")[0]
    assert math.isclose(back.N, 3 * white.N, rel_tol=1e-8)


@pytest.mark.parametrize(("to", "line"), [("kalibr", "rostopic: /imu/data"),
                                      ("openvins", "  rostopic: /imu/data")])  # fmt: skip
def test_convert_an_sdf_keeps_its_topic(tmp_path, to, line):
    src = tmp_path / "imu.sdf"
    src.write_text(REAL_SDF)
    out = tmp_path / "imu.yaml"
    assert main(["model", "convert", str(src), str(out), "--to", to]) == 0
    text = out.read_text()
    assert line in text.splitlines()
    assert "/imu0" not in text
    assert read_config(out, format=to).topic == "/imu/data"
    # a config that names no topic still gets Kalibr's conventional one
    bare = tmp_path / "bare.sdf"
    bare.write_text(REAL_SDF.replace("<topic>imu/data</topic>", ""))
    assert main(["model", "convert", str(bare), str(out), "--to", to]) == 0
    assert "rostopic: /imu0" in out.read_text()
