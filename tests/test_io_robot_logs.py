"""ROS 1 / ROS 2 (sqlite3, MCAP) bags and PX4 ULog read without ROS.

The bags are written here with ``rosbags`` itself and the ULog files with a minimal writer of
the documented ULog format, so nothing external is needed.
"""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from allanite.cli import main
from allanite.errors import InputError
from allanite.io import read_record

rosbags = pytest.importorskip("rosbags")
pytest.importorskip("pyulog")

FS = 200.0
N = 600


def _signals(n: int = N, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    out = rng.normal(0.0, 0.01, (n, 6))
    out[:, 5] += 9.81
    return out


def _imu(ts, t: float, row: np.ndarray, frame: str = "imu"):
    types = ts.types
    time = types["builtin_interfaces/msg/Time"](sec=int(t), nanosec=int(np.round((t % 1) * 1e9)))
    vec = types["geometry_msgs/msg/Vector3"]
    seq = {"seq": 0} if "seq" in types["std_msgs/msg/Header"].__dataclass_fields__ else {}
    return types["sensor_msgs/msg/Imu"](
        header=types["std_msgs/msg/Header"](stamp=time, frame_id=frame, **seq),
        orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.zeros(9),
        angular_velocity=vec(x=row[0], y=row[1], z=row[2]),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=vec(x=row[3], y=row[4], z=row[5]),
        linear_acceleration_covariance=np.zeros(9),
    )


def write_bag(
    path, kind: str, data: np.ndarray, times: np.ndarray, topics=("/imu",), order=None, frames=None
):
    """Write ``data`` as sensor_msgs/Imu on ``topics`` (``order``: arrival order of messages;
    ``frames``: a frame_id per message, default ``imu``)."""
    from rosbags.typesys import Stores, get_typestore

    order = np.arange(len(times)) if order is None else order
    frames = ["imu"] * len(times) if frames is None else frames
    if kind == "ros1":
        from rosbags.rosbag1 import Writer

        ts = get_typestore(Stores.ROS1_NOETIC)
        with Writer(path) as writer:
            conns = [writer.add_connection(t, "sensor_msgs/msg/Imu", typestore=ts) for t in topics]
            for k, i in enumerate(order):
                msg = _imu(ts, 1000.0 + times[i], data[i], frames[i])
                raw = ts.serialize_ros1(msg, "sensor_msgs/msg/Imu")
                for c in conns:
                    writer.write(c, int((1000.0 + times[k]) * 1e9), raw)
        return
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conns = [writer.add_connection(t, "sensor_msgs/msg/Imu", typestore=ts) for t in topics]
        for k, i in enumerate(order):
            msg = _imu(ts, 1000.0 + times[i], data[i], frames[i])
            raw = ts.serialize_cdr(msg, "sensor_msgs/msg/Imu")
            for c in conns:
                writer.write(c, int((1000.0 + times[k]) * 1e9), raw)


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_bag_gives_six_axes_with_time_stamps_and_units(tmp_path, kind):
    data = _signals()
    times = np.arange(N) / FS
    path = tmp_path / ("imu.bag" if kind == "ros1" else "imu_bag")
    write_bag(path, kind, data, times)
    rec = read_record(path)
    assert rec.fs == pytest.approx(FS)
    assert rec.channels == ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
    np.testing.assert_allclose(rec.samples, data)
    assert rec.units is None  # mixed: per channel
    assert rec.meta["channel_units"]["accel_z"] == "m/s^2"
    gyro = read_record(path, columns="gyro_x,gyro_y,gyro_z")
    assert gyro.units == "rad/s"
    assert read_record(path, columns=["accel_z"]).units == "m/s^2"
    if kind != "ros1":  # the storage file itself works too
        storage = next(p for p in path.iterdir() if p.suffix in (".mcap", ".db3"))
        np.testing.assert_allclose(read_record(storage).samples, data)


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_messages_read_from_their_bytes_equal_the_deserialized_ones(tmp_path, kind, monkeypatch):
    """The IMU values are read straight from the message bytes when a batch shares one layout
    (several times faster than deserializing each message); frame_ids of other lengths
    (ROS 2: other CDR padding) and batch boundaries fall back or split cleanly, with the
    same samples and stamps."""
    from allanite.io import robot_logs

    monkeypatch.setattr(robot_logs, "BATCH", 128)  # several batches, the last one partial
    data = _signals()
    times = np.arange(N) / FS + 0.123456789
    frames = ["imu"] * N
    frames[300:310] = ["imu_link_long_name"] * 10  # batch 3 falls back to deserializing
    frames[500:505] = ["imu1", "imu22", "imu333", "i", "imu4444"]
    path = tmp_path / ("b.bag" if kind == "ros1" else "b")
    write_bag(path, kind, data, times, frames=frames)
    calls = []
    real_rows = robot_logs._imu_row
    monkeypatch.setattr(robot_logs, "_imu_row", lambda *a: calls.append(1) or real_rows(*a))
    table, names, _ = robot_logs.load_rosbag(path)
    assert names == ("t", *robot_logs.CHANNELS)
    np.testing.assert_array_equal(table[:, 1:], data)
    expected = (1000.0 + times) - (1000.0 + times[0])
    np.testing.assert_allclose(table[:, 0], expected, atol=2e-9)  # stamps in whole ns
    assert len(calls) < N  # most batches were read from the bytes
    assert len(calls) >= 2 * 128  # the two batches with other frame_id lengths were not


def test_messages_in_arrival_order_are_sorted_by_stamp(tmp_path):
    data = _signals()
    times = np.arange(N) / FS
    order = np.arange(N)
    order[[10, 11]] = order[[11, 10]]
    write_bag(tmp_path / "b", "sqlite3", data, times, order=order)
    rec = read_record(tmp_path / "b")
    np.testing.assert_allclose(rec.samples, data)
    assert any("sorted" in w for w in rec.warnings)


def test_gaps_and_jitter_are_reported_as_for_text(tmp_path):
    data = _signals()
    times = np.arange(N) / FS
    keep = np.r_[0:300, 320:N]
    write_bag(tmp_path / "g.bag", "ros1", data[keep], times[keep])
    with pytest.raises(InputError, match="gap"):
        read_record(tmp_path / "g.bag")
    rec = read_record(tmp_path / "g.bag", gaps="split")
    assert len(rec.segments) == 2
    assert rec.timing is not None
    assert rec.timing.gaps[0][2] == 20


def test_several_imu_topics_need_topic(tmp_path):
    write_bag(tmp_path / "two.bag", "ros1", _signals(), np.arange(N) / FS, topics=("/a", "/b"))
    with pytest.raises(InputError, match="--topic"):
        read_record(tmp_path / "two.bag")
    assert read_record(tmp_path / "two.bag", topic="/b").n_samples == N
    with pytest.raises(InputError, match="/a, /b"):
        read_record(tmp_path / "two.bag", topic="/c")


# --- PX4 ULog ------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_topic_with_or_without_its_leading_slash(tmp_path, kind):
    path = tmp_path / ("imu.bag" if kind == "ros1" else "imu_bag")
    topics = ("/imu/data", "/imu/raw") if kind != "mcap" else ("imu/data", "/imu/raw")
    write_bag(path, kind, _signals(), np.arange(N) / FS, topics=topics)
    for given in ("imu/data", "/imu/data", "imu/raw"):
        assert read_record(path, topic=given).n_samples == N
    with pytest.raises(InputError, match="imu/data"):  # the topic list still shows
        read_record(path, topic="imu/dat")


def write_ulog(path, topic: str, fields: list[tuple[str, str]], rows: list[tuple]) -> None:
    """Minimal ULog: header, one format (F), one subscription (A), data messages (D)."""
    codes = {"uint64_t": "Q", "float": "f", "uint32_t": "I", "int32_t": "i"}

    def message(kind: bytes, body: bytes) -> bytes:
        return struct.pack("<HB", len(body), kind[0]) + body

    spec = "".join(f"{t} {n};" for t, n in fields)
    out = b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0)
    out += message(b"B", bytes(40))
    out += message(b"F", f"{topic}:{spec}".encode())
    out += message(b"A", struct.pack("<BH", 0, 0) + topic.encode())
    fmt = "<H" + "".join(codes[t] for t, _ in fields)
    for row in rows:
        out += message(b"D", struct.pack(fmt, 0, *row))
    path.write_bytes(out)


def test_ulog_sensor_combined_and_sensor_gyro(tmp_path):
    data = _signals()
    stamps = (1_000_000 + np.arange(N) * 1e6 / FS).astype(np.uint64)
    fields = [("uint64_t", "timestamp")]
    fields += [("float", f"gyro_rad[{i}]") for i in range(3)]
    fields += [("float", f"accelerometer_m_s2[{i}]") for i in range(3)]
    rows = [(int(t), *map(float, r)) for t, r in zip(stamps, data, strict=True)]
    write_ulog(tmp_path / "f.ulg", "sensor_combined", fields, rows)
    rec = read_record(tmp_path / "f.ulg")
    assert rec.fs == pytest.approx(FS)
    np.testing.assert_allclose(rec.samples, data.astype(np.float32))
    assert rec.channels[0] == "gyro_x"
    gyro_fields = [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample")]
    gyro_fields += [("float", a) for a in "xyz"]
    rows = [(int(t) + 50, int(t), *map(float, r[:3])) for t, r in zip(stamps, data, strict=True)]
    write_ulog(tmp_path / "g.ulg", "sensor_gyro", gyro_fields, rows)
    rec = read_record(tmp_path / "g.ulg", topic="sensor_gyro")
    assert rec.channels == ("gyro_x", "gyro_y", "gyro_z")
    assert rec.units == "rad/s"
    with pytest.raises(InputError, match="sensor_combined"):
        read_record(tmp_path / "g.ulg", topic="vehicle_attitude")


def test_cli_analyze_reads_a_bag(tmp_path, capsys):
    write_bag(tmp_path / "imu.bag", "ros1", _signals(), np.arange(N) / FS, topics=("/imu0",))
    argv = ["analyze", str(tmp_path / "imu.bag"), "--topic", "/imu0", "--channels", "gyro_z"]
    assert main([*argv, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["record"]["units"] == "rad/s"
    assert data["record"]["channels"] == ["gyro_z"]
    assert data["record"]["fs"] == pytest.approx(FS)


@pytest.mark.parametrize("kind", ["ros1", "sqlite3"])
def test_imu_topic_without_messages_is_refused_naming_it(tmp_path, kind, capsys):
    bag = tmp_path / ("e.bag" if kind == "ros1" else "e")  # ROS 2: a directory
    write_bag(bag, kind, np.zeros((0, 6)), np.zeros(0), topics=("/imu/data",))
    with pytest.raises(InputError, match=r"/imu/data holds no messages"):
        read_record(bag)
    argv = ["fit", str(bag), "-o", str(tmp_path / "m.json")]
    assert main(argv) == 2
    assert "holds no messages" in capsys.readouterr().err
    assert not (tmp_path / "m.json").exists()


def test_corrupt_ulog_is_refused_not_read_as_data(tmp_path):
    # 64 flipped bytes in the middle of the log (issue 31: read as 3.3e23 rad/s, exit 0)
    n = 4000
    data = np.random.default_rng(5).normal(0.0, 0.01, (n, 6))
    stamps = (1_000_000 + np.arange(n) * 1e6 / FS).astype(np.uint64)
    fields = [("uint64_t", "timestamp")]
    fields += [("float", f"gyro_rad[{i}]") for i in range(3)]
    fields += [("float", f"accelerometer_m_s2[{i}]") for i in range(3)]
    rows = [(int(t), *map(float, r)) for t, r in zip(stamps, data, strict=True)]
    path = tmp_path / "bad.ulg"
    write_ulog(path, "sensor_combined", fields, rows)
    raw = bytearray(path.read_bytes())
    mid = len(raw) // 2
    raw[mid : mid + 64] = bytes(b ^ 0xFF for b in raw[mid : mid + 64])
    path.write_bytes(bytes(raw))
    with pytest.raises(InputError, match="corrupt"):
        read_record(path)
