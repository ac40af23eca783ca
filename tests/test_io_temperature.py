"""Temperature in every reader (issue 29): Record.temperature on the sample times.

Text columns, HDF5 datasets, netCDF variables (classic and netCDF-4, read directly and
recognised by their first bytes), ROS ``sensor_msgs/Temperature`` topics and the
``temperature`` field of PX4 ULog ``sensor_gyro``; a missing name is refused listing what
exists, and a binary file is never parsed as text.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from allanite.cli import main
from allanite.errors import InputError
from allanite.io import Record, read_record

FS = 10.0
N = 400


def _table(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(N) / FS
    gyro = rng.normal(0.0, 0.01, (N, 2))
    temp = 20.0 + 0.05 * t
    return t, gyro, temp


def _write_csv(path: Path, t: np.ndarray, gyro: np.ndarray, temp: np.ndarray) -> None:
    lines = ["time,gx,gy,temp"]
    for row in zip(t, gyro[:, 0], gyro[:, 1], temp, strict=True):
        lines.append(",".join("nan" if np.isnan(v) else repr(float(v)) for v in row))
    path.write_text("\n".join(lines) + "\n")


def test_csv_temperature_column_is_not_a_channel_and_follows_the_samples(tmp_path):
    t, gyro, temp = _table()
    _write_csv(tmp_path / "r.csv", t, gyro, temp)
    rec = read_record(tmp_path / "r.csv", time_column="time", temperature="temp")
    assert rec.channels == ("gx", "gy")
    np.testing.assert_allclose(rec.temperature, temp)
    np.testing.assert_allclose(rec.samples, gyro)
    assert read_record(tmp_path / "r.csv", time_column="time").temperature is None


def test_a_slower_temperature_is_interpolated_onto_every_sample(tmp_path):
    t, gyro, temp = _table()
    sparse = temp.copy()
    sparse[np.arange(N) % 10 != 0] = np.nan  # 1 Hz temperature in a 10 Hz table
    _write_csv(tmp_path / "r.csv", t, gyro, sparse)
    rec = read_record(tmp_path / "r.csv", time_column="time", temperature="temp")
    last = (N - 1) // 10 * 10
    np.testing.assert_allclose(rec.temperature[: last + 1], temp[: last + 1], atol=1e-12)
    np.testing.assert_allclose(rec.temperature[last:], temp[last])  # the end holds


def test_temperature_follows_the_gap_policy(tmp_path):
    t, gyro, temp = _table()
    keep = np.ones(N, bool)
    keep[100:103] = False
    _write_csv(tmp_path / "g.csv", t[keep], gyro[keep], temp[keep])
    filled = read_record(tmp_path / "g.csv", time_column="time", temperature="temp", gaps="fill")
    assert filled.n_samples == N
    np.testing.assert_allclose(filled.temperature, temp, atol=1e-9)
    split = read_record(tmp_path / "g.csv", time_column="time", temperature="temp", gaps="split")
    longest = split.longest_segment()
    np.testing.assert_allclose(longest.temperature, temp[103:])
    np.testing.assert_array_equal(split.select(["gy"]).temperature, split.temperature)


def test_missing_temperature_column_lists_the_columns(tmp_path):
    t, gyro, temp = _table()
    _write_csv(tmp_path / "r.csv", t, gyro, temp)
    with pytest.raises(InputError, match=r"no temperature column named 'tmp'; available: time"):
        read_record(tmp_path / "r.csv", time_column="time", temperature="tmp")
    with pytest.raises(InputError, match="both the temperature column and a sample column"):
        read_record(tmp_path / "r.csv", time_column="time", temperature="temp", columns="gx,temp")


def test_record_refuses_a_temperature_of_another_length():
    with pytest.raises(ValueError, match="temperature has 3 values for 4 samples"):
        Record(samples=np.zeros(4), fs=1.0, temperature=np.zeros(3))
    with pytest.raises(ValueError, match="temperature at sample 1 is nan"):
        Record(samples=np.zeros(3), fs=1.0, temperature=[1.0, np.nan, 2.0])


def _classic_netcdf(path: Path, *, slow: bool = False) -> tuple[np.ndarray, np.ndarray]:
    from scipy.io import netcdf_file

    t, gyro, temp = _table()
    with netcdf_file(path, "w") as f:
        f.createDimension("time", None)
        f.createDimension("axis", 2)
        tv = f.createVariable("time", "d", ("time",))
        tv.units = "seconds since 2024-01-01 00:00:00"
        tv[:] = t
        g = f.createVariable("angular_velocity", "d", ("time", "axis"))
        g.units = "rad/s"
        g[:] = gyro
        k = f.createVariable("temperature", "d", ("time",))
        k[:] = temp
        if slow:  # a 1 Hz logger on a dimension of its own, with its own time coordinate
            f.createDimension("time_slow", N // 10)
            ts = f.createVariable("time_slow", "d", ("time_slow",))
            ts.units = "seconds since 2024-01-01 00:00:00"
            ts[:] = t[::10]
            s = f.createVariable("board_temp", "d", ("time_slow",))
            s[:] = temp[::10] + 5.0
    return gyro, temp


def test_classic_netcdf_is_read_directly_with_its_time_and_temperature(tmp_path):
    gyro, temp = _classic_netcdf(tmp_path / "r.nc", slow=True)
    rec = read_record(tmp_path / "r.nc", key="angular_velocity", temperature="temperature")
    assert rec.fs == pytest.approx(FS)
    assert rec.channels == ("angular_velocity[0]", "angular_velocity[1]")
    np.testing.assert_allclose(rec.samples, gyro)
    np.testing.assert_allclose(rec.temperature, temp)
    slow = read_record(tmp_path / "r.nc", key="angular_velocity", temperature="board_temp")
    last = (N - 1) // 10 * 10
    np.testing.assert_allclose(slow.temperature[: last + 1], temp[: last + 1] + 5.0, atol=1e-9)
    with pytest.raises(InputError, match=r"no netCDF variable 'temp'; variables: .*temperature"):
        read_record(tmp_path / "r.nc", temperature="temp")


def test_netcdf_is_recognised_by_its_bytes_not_read_as_text(tmp_path, capsys):
    _classic_netcdf(tmp_path / "r.nc")
    renamed = tmp_path / "r.dat"  # a text suffix: before issue 29 "field 1 is '\x1a'"
    renamed.write_bytes((tmp_path / "r.nc").read_bytes())
    rec = read_record(renamed, temperature="temperature")
    assert rec.channels == ("angular_velocity[0]", "angular_velocity[1]")
    assert main(["analyze", str(tmp_path / "r.nc"), "--temperature", "temperature"]) == 0
    assert "not a number" not in capsys.readouterr().err


def test_netcdf4_hdf5_file_is_read_as_netcdf(tmp_path):
    h5py = pytest.importorskip("h5py")
    t, gyro, temp = _table()
    with h5py.File(tmp_path / "r.nc", "w") as h:
        h["time"] = t
        h["time"].attrs["units"] = "s"
        h["time"].make_scale("time")
        for name, values in (("gx", gyro[:, 0]), ("gy", gyro[:, 1]), ("temp", temp)):
            h[name] = values
            h[name].dims[0].attach_scale(h["time"])
    rec = read_record(tmp_path / "r.nc", temperature="temp")
    assert rec.channels == ("gx", "gy")
    assert rec.fs == pytest.approx(FS)
    np.testing.assert_allclose(rec.temperature, temp)


def test_hdf5_temperature_dataset_beside_the_samples(tmp_path):
    h5py = pytest.importorskip("h5py")
    _, gyro, temp = _table()
    with h5py.File(tmp_path / "r.h5", "w") as h:
        h["gyro"] = gyro
        h["board/temp"] = temp
        h["short"] = temp[:10]
    rec = read_record(tmp_path / "r.h5", key="gyro", temperature="board/temp", fs=FS)
    assert rec.n_channels == 2
    np.testing.assert_allclose(rec.temperature, temp)
    with pytest.raises(
        InputError, match=r"no dataset or column 'temp'; datasets: board/temp, gyro, short"
    ):
        read_record(tmp_path / "r.h5", key="gyro", temperature="temp", fs=FS)
    with pytest.raises(InputError, match=r"dataset 'short' has shape \(10,\)"):
        read_record(tmp_path / "r.h5", key="gyro", temperature="short", fs=FS)


def test_unknown_binary_file_is_refused_not_parsed_as_text(tmp_path):
    path = tmp_path / "r.txt"
    path.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(InputError, match="binary file of no format known here, not text"):
        read_record(path)
    cdf5 = tmp_path / "r5.nc"
    cdf5.write_bytes(b"CDF\x05" + bytes(100))
    with pytest.raises(InputError, match="CDF-5"):
        read_record(cdf5)


def _ulog(path: Path, topics: list[tuple[str, list[tuple[str, str]], list[tuple]]]) -> None:
    """Minimal ULog with several topics: header, formats, subscriptions, data messages."""
    codes = {"uint64_t": "Q", "float": "f", "uint32_t": "I"}

    def message(kind: bytes, body: bytes) -> bytes:
        return struct.pack("<HB", len(body), kind[0]) + body

    out = b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0) + message(b"B", bytes(40))
    for topic, fields, _ in topics:
        out += message(b"F", (topic + ":" + "".join(f"{t} {n};" for t, n in fields)).encode())
    for msg_id, (topic, _, _) in enumerate(topics):
        out += message(b"A", struct.pack("<BH", 0, msg_id) + topic.encode())
    for msg_id, (_, fields, rows) in enumerate(topics):
        fmt = "<H" + "".join(codes[t] for t, _ in fields)
        for row in rows:
            out += message(b"D", struct.pack(fmt, msg_id, *row))
    path.write_bytes(out)


def test_ulog_sensor_gyro_temperature_field_and_from_another_topic(tmp_path):
    pytest.importorskip("pyulog")
    fs = 200.0
    stamps = (1_000_000 + np.arange(N) * 1e6 / fs).astype(np.uint64)
    rng = np.random.default_rng(1)
    gyro = rng.normal(0, 0.01, (N, 3))
    temp = 30.0 + np.arange(N) * 0.01
    gyro_fields = [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample")]
    gyro_fields += [("float", a) for a in "xyz"] + [("float", "temperature")]
    gyro_rows = [
        (int(s), int(s), *map(float, g), float(k))
        for s, g, k in zip(stamps, gyro, temp, strict=True)
    ]
    combined = [("uint64_t", "timestamp")] + [("float", f"gyro_rad[{i}]") for i in range(3)]
    combined += [("float", f"accelerometer_m_s2[{i}]") for i in range(3)]
    comb_rows = [(int(s), *map(float, g), 0.0, 0.0, 9.8) for s, g in zip(stamps, gyro, strict=True)]
    _ulog(
        tmp_path / "f.ulg",
        [("sensor_gyro", gyro_fields, gyro_rows), ("sensor_combined", combined, comb_rows)],
    )
    rec = read_record(tmp_path / "f.ulg", topic="sensor_gyro", temperature="temperature")
    assert rec.channels == ("gyro_x", "gyro_y", "gyro_z")
    np.testing.assert_allclose(rec.temperature, temp.astype(np.float32), rtol=1e-6)
    other = read_record(tmp_path / "f.ulg", temperature="sensor_gyro.temperature")
    assert other.channels[:3] == ("gyro_x", "gyro_y", "gyro_z")
    np.testing.assert_allclose(other.temperature, temp.astype(np.float32), rtol=1e-6)
    with pytest.raises(InputError, match=r"no temperature field 'temperature' in sensor_combined"):
        read_record(tmp_path / "f.ulg", temperature="temperature")


def test_ros_temperature_topic_is_resampled_onto_the_imu_stamps(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)
    types = ts.types
    fs = 100.0
    t_imu = 1000.0 + np.arange(N) / fs
    t_temp = 1000.0 + np.arange(0, N / fs, 0.5)
    temp = 25.0 + 2.0 * (t_temp - 1000.0)

    def header(t: float):
        stamp = types["builtin_interfaces/msg/Time"](sec=int(t), nanosec=round((t % 1) * 1e9))
        return types["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="imu")

    vec = types["geometry_msgs/msg/Vector3"]
    with Writer(tmp_path / "b.bag") as writer:
        imu = writer.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=ts)
        therm = writer.add_connection("/imu/temp", "sensor_msgs/msg/Temperature", typestore=ts)
        for k, t in enumerate(t_imu):
            msg = types["sensor_msgs/msg/Imu"](
                header=header(t),
                orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                orientation_covariance=np.zeros(9),
                angular_velocity=vec(x=0.001 * k, y=0.0, z=0.0),
                angular_velocity_covariance=np.zeros(9),
                linear_acceleration=vec(x=0.0, y=0.0, z=9.8),
                linear_acceleration_covariance=np.zeros(9),
            )
            writer.write(imu, int(t * 1e9), ts.serialize_ros1(msg, "sensor_msgs/msg/Imu"))
        for t, k in zip(t_temp, temp, strict=True):
            msg = types["sensor_msgs/msg/Temperature"](
                header=header(t), temperature=k, variance=0.0
            )
            writer.write(therm, int(t * 1e9), ts.serialize_ros1(msg, "sensor_msgs/msg/Temperature"))
    rec = read_record(tmp_path / "b.bag", temperature="imu/temp")  # slash optional, as --topic
    inside = t_imu <= t_temp[-1]
    np.testing.assert_allclose(
        rec.temperature[inside], 25.0 + 2.0 * (t_imu[inside] - 1000.0), atol=1e-6
    )
    with pytest.raises(InputError, match=r"no sensor_msgs/Temperature topic '/temp'.*/imu/temp"):
        read_record(tmp_path / "b.bag", temperature="/temp")


def test_parquet_and_dataframe_temperature_columns(tmp_path, capsys):
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    t, gyro, temp = _table()
    frame = pd.DataFrame({"time": t, "gx": gyro[:, 0], "temp": temp, "note": ["x"] * N})
    rec = read_record(frame, time_column="time", temperature="temp", columns="gx")
    np.testing.assert_allclose(rec.temperature, temp)
    frame.drop(columns="note").to_parquet(tmp_path / "r.parquet")
    rec = read_record(tmp_path / "r.parquet", time_column="time", temperature="temp")
    assert rec.channels == ("gx",)
    np.testing.assert_allclose(rec.temperature, temp)
    frame.assign(temp=["warm"] * N).to_parquet(tmp_path / "s.parquet")
    with pytest.raises(InputError, match=r"column 'temp' is not numeric"):
        read_record(tmp_path / "s.parquet", time_column="time", temperature="temp", columns="gx")
    argv = ["analyze", str(tmp_path / "r.parquet"), "--time-column", "time"]
    assert main([*argv, "--temperature", "temp"]) == 0
    assert "temperature 20 to 22 °C" in capsys.readouterr().out
