"""Robot logs read directly, without ROS: ROS 1 ``.bag``, ROS 2 (sqlite3, MCAP) and PX4 ULog.

``sensor_msgs/Imu`` messages of a ROS bag are read with the pure-Python ``rosbags`` package
(extra ``[bags]``), PX4 flight logs with ``pyulog`` (extra ``[ulog]``). Both loaders return a
table whose first column is the message time stamp in seconds (the message header's stamp
for ROS, ``timestamp_sample`` or ``timestamp`` for ULog), followed by the six axes
``gyro_x gyro_y gyro_z`` (rad/s) and ``accel_x accel_y accel_z`` (m/s^2); the record is then
built like any text file with a time column, so gaps and jitter are reported the same way.
Messages are sorted by their stamps (bags are stored in arrival order).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.errors import InputError, choose_one
from allanite.extras import require

__all__ = [
    "CHANNELS",
    "CHANNEL_UNITS",
    "LOG_SUFFIXES",
    "is_ros2_bag_dir",
    "load_rosbag",
    "load_ulog",
    "resample",
]

CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
CHANNEL_UNITS = {c: ("rad/s" if c.startswith("gyro") else "m/s^2") for c in CHANNELS}
LOG_SUFFIXES = {"rosbag": (".bag", ".db3", ".mcap"), "ulog": (".ulg", ".ulog")}
IMU_TYPES = ("sensor_msgs/msg/Imu", "sensor_msgs/Imu")
TEMPERATURE_TYPES = ("sensor_msgs/msg/Temperature", "sensor_msgs/Temperature")
#: the column a temperature read from a log becomes (``Record.temperature``)
TEMPERATURE = "temperature"
#: ULog topic -> (time field, gyro fields, accel fields)
ULOG_TOPICS: dict[str, tuple[str, tuple[str, ...], tuple[str, ...]]] = {
    "sensor_combined": (
        "timestamp",
        ("gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]"),
        ("accelerometer_m_s2[0]", "accelerometer_m_s2[1]", "accelerometer_m_s2[2]"),
    ),
    "sensor_gyro": ("timestamp_sample", ("x", "y", "z"), ()),
    "sensor_accel": ("timestamp_sample", (), ("x", "y", "z")),
}


def is_ros2_bag_dir(path: Path) -> bool:
    """Whether ``path`` is a ROS 2 bag directory (it holds ``metadata.yaml``)."""
    return path.is_dir() and (path / "metadata.yaml").is_file()


def _sorted(t: NDArray[np.float64], rows: NDArray[np.float64], warnings: list[str]) -> Any:
    order = np.argsort(t, kind="stable")
    moved = int(np.count_nonzero(order != np.arange(t.size)))
    if moved:
        warnings.append(f"{moved} messages were out of time-stamp order and were sorted")
    return t[order], rows[order]


def _as_in_bag(topic: str | None, topics: list[str]) -> str | None:
    """``topic`` as the bag spells it: ``imu/data`` is ``/imu/data`` (and the reverse).

    A ROS name without its leading slash is the same topic at the root namespace; the user
    types it either way, ROS 1 and ROS 2 bags store it with the slash (MCAP as recorded).
    """
    if topic is None or topic in topics:
        return topic
    bare = topic.lstrip("/")
    same = [t for t in topics if t.lstrip("/") == bare]
    return same[0] if len(same) == 1 else topic


def load_rosbag(
    path: Path, topic: str | None = None, temperature: str | None = None
) -> tuple[NDArray[Any], tuple[str, ...], list[str]]:
    """Read the ``sensor_msgs/Imu`` messages of a ROS 1 or ROS 2 bag.

    Returns ``(table, names, warnings)``: columns ``t`` and :data:`CHANNELS`, and with
    ``temperature`` (a ``sensor_msgs/Temperature`` topic) a column ``temperature``: its
    readings interpolated onto the IMU stamps.
    """
    highlevel = require("rosbags.highlevel", extra="bags", purpose="reading ROS bags")
    typesys = require("rosbags.typesys", extra="bags", purpose="reading ROS bags")
    AnyReader, Stores, get_typestore = highlevel.AnyReader, typesys.Stores, typesys.get_typestore
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as exc:  # rosbags raises its own error types
        raise InputError(f"not a readable ROS bag ({exc})", path=str(path)) from exc
    try:
        imu = [c for c in reader.connections if c.msgtype in IMU_TYPES]
        topics = sorted({c.topic for c in imu})
        if not topics:
            found = ", ".join(sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections}))
            raise InputError(
                f"no sensor_msgs/Imu topic in the bag; it has {found or 'no topics'}",
                path=str(path),
            )
        topic = choose_one(
            _as_in_bag(topic, topics),
            topics,
            what="IMU topic",
            option="topic= (CLI: --topic NAME)",
            path=str(path),
        )
        chosen = [c for c in imu if c.topic == topic]
        parts: list[NDArray[np.float64]] = []
        batch: list[tuple[Any, bytes]] = []
        for conn, _, raw in reader.messages(connections=chosen):
            batch.append((conn, raw))
            if len(batch) == BATCH:
                parts.append(_imu_table(reader, batch))
                batch = []
        if batch:
            parts.append(_imu_table(reader, batch))
        readings = None if temperature is None else _temperature_topic(reader, temperature, path)
    finally:
        reader.close()
    if not parts:
        raise InputError(
            f"the IMU topic {topic} holds no messages; record the IMU into the bag (check the "
            "recorder's topic list), or choose another topic with --topic",
            path=str(path),
        )
    table = np.concatenate(parts)
    warnings: list[str] = []
    t, data = _sorted(table[:, 0], table[:, 1:], warnings)
    if readings is None:
        return np.column_stack([t - t[0], data]), ("t", *CHANNELS), warnings
    celsius = resample(t, readings[:, 0], readings[:, 1], str(temperature), warnings)
    return np.column_stack([t - t[0], data, celsius]), ("t", *CHANNELS, TEMPERATURE), warnings


def _temperature_topic(reader: Any, topic: str, path: Path) -> NDArray[np.float64]:
    """Rows ``(stamp s, degrees C)`` of a ``sensor_msgs/Temperature`` topic of an open bag."""
    kinds = [c for c in reader.connections if c.msgtype in TEMPERATURE_TYPES]
    names = sorted({c.topic for c in kinds})
    wanted = _as_in_bag(topic, names)
    chosen = [c for c in kinds if c.topic == wanted]
    if not chosen:
        others = ", ".join(sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections}))
        raise InputError(
            f"no sensor_msgs/Temperature topic {topic!r} in the bag; its topics: {others}",
            path=str(path),
        )
    rows = []
    for conn, _, raw in reader.messages(connections=chosen):
        msg: Any = reader.deserialize(raw, conn.msgtype)
        stamp = msg.header.stamp
        rows.append((stamp.sec + stamp.nanosec * 1e-9, float(msg.temperature)))
    if not rows:
        raise InputError(f"the temperature topic {wanted} holds no messages", path=str(path))
    return np.asarray(rows, dtype=np.float64)


def resample(
    t: NDArray[np.float64],
    t_source: NDArray[np.float64],
    values: NDArray[np.float64],
    name: str,
    warnings: list[str],
) -> NDArray[np.float64]:
    """``values`` logged at ``t_source`` interpolated onto the times ``t`` (ends held).

    A note is added when the readings cover less than the samples' time span (the ends take
    the nearest reading).
    """
    order = np.argsort(t_source, kind="stable")
    ts, vs = t_source[order], np.asarray(values, dtype=np.float64)[order]
    keep = np.isfinite(ts) & np.isfinite(vs)
    ts, vs = ts[keep], vs[keep]
    if ts.size == 0:
        raise InputError(f"the temperature {name} holds no finite reading")
    outside = float(np.mean((t < ts[0]) | (t > ts[-1])))
    if outside > 0.01:
        warnings.append(
            f"the temperature {name} covers {100 * (1 - outside):.3g} % of the samples' time "
            "span; the rest takes the nearest reading"
        )
    return np.interp(t, ts, vs)


#: messages parsed at a time (bounded memory for long bags)
BATCH = 65536


def _imu_table(reader: Any, batch: list[tuple[Any, bytes]]) -> NDArray[np.float64]:
    """Rows ``(stamp s, wx, wy, wz, ax, ay, az)`` of serialized ``sensor_msgs/Imu`` messages.

    The messages of one IMU topic have one layout: a header (stamp at bytes 4-12, then the
    ``frame_id`` string, its length at bytes 12-16), the orientation and its covariance, the
    angular velocity, its covariance and the linear acceleration, as doubles. When every
    message of the batch has the same length and ``frame_id`` length (ROS 1, or little-endian
    CDR for ROS 2, whose doubles are aligned to 8 bytes after the 4-byte encapsulation
    header), the values are read straight from the bytes, which is several times faster than
    deserializing each message; the first and last messages are checked against the
    deserializer, and anything else (other lengths, big-endian CDR) is deserialized.
    """
    raws = [raw for _, raw in batch]
    fast = _imu_bytes(raws, bool(getattr(reader, "is2", False)))
    if fast is not None:
        check = [0, len(raws) - 1]
        if all(np.array_equal(fast[i], _imu_row(reader, *batch[i]), equal_nan=True) for i in check):
            return fast
    return np.array([_imu_row(reader, conn, raw) for conn, raw in batch], dtype=np.float64)


def _imu_row(reader: Any, conn: Any, raw: bytes) -> NDArray[np.float64]:
    msg: Any = reader.deserialize(raw, conn.msgtype)
    stamp = msg.header.stamp
    w, a = msg.angular_velocity, msg.linear_acceleration
    return np.array([stamp.sec + stamp.nanosec * 1e-9, w.x, w.y, w.z, a.x, a.y, a.z])


def _imu_bytes(raws: list[bytes], ros2: bool) -> NDArray[np.float64] | None:
    """The rows read straight from equal-layout messages, or None (see :func:`_imu_table`)."""
    size = len(raws[0])
    if size < 16 or any(len(r) != size for r in raws):
        return None
    buf = np.frombuffer(b"".join(raws), dtype=np.uint8).reshape(len(raws), size)

    def field(start: int, dtype: str) -> NDArray[Any]:
        width = np.dtype(dtype).itemsize
        return np.ascontiguousarray(buf[:, start : start + width]).view(dtype)[:, 0]

    name_len = field(12, "<u4")
    if np.any(name_len != name_len[0]):
        return None
    if ros2:
        if np.any(buf[:, 0] != 0) or np.any(buf[:, 1] != 1):  # little-endian CDR only
            return None
        start = 4 + -(-(12 + int(name_len[0])) // 8) * 8  # aligned to 8 after the header
    else:
        start = 16 + int(name_len[0])
    if start + 224 > size:
        return None
    sec = field(4, "<i4" if ros2 else "<u4").astype(np.float64)
    out = np.empty((len(raws), 7))
    out[:, 0] = sec + field(8, "<u4") * 1e-9
    for i, offset in enumerate((104, 112, 120, 200, 208, 216)):  # w x,y,z then a x,y,z
        out[:, 1 + i] = field(start + offset, "<f8")
    return out


def load_ulog(
    path: Path, topic: str | None = None, temperature: str | None = None
) -> tuple[NDArray[Any], tuple[str, ...], list[str]]:
    """Read ``sensor_combined`` (default), ``sensor_gyro`` or ``sensor_accel`` of a ULog.

    ``topic`` may carry an instance, ``sensor_gyro:1`` (default instance 0). Returns
    ``(table, names, warnings)``: columns ``t`` and the axes the topic has, and with
    ``temperature`` a column ``temperature``: a field of the IMU topic (``temperature`` of
    ``sensor_gyro``/``sensor_accel``), or ``TOPIC[:instance].FIELD`` of another topic
    (``sensor_gyro.temperature`` for ``sensor_combined``, which has none), interpolated onto
    the samples' time stamps.
    """
    ULog = require("pyulog", extra="ulog", purpose="reading PX4 ULog").ULog
    name, _, inst = (topic or "").partition(":")
    instance = int(inst) if inst.isdigit() else 0
    wanted = [name] if name else list(ULOG_TOPICS)
    other = _ulog_field(temperature)
    unknown = [n for n in wanted if n not in ULOG_TOPICS]
    if unknown:
        raise InputError(
            f"ULog topic {unknown[0]!r} is not an IMU topic; use one of {', '.join(ULOG_TOPICS)}",
            path=str(path),
        )
    try:  # our own handle: pyulog leaves its file open when it fails on a damaged log
        with path.open("rb") as handle:
            log = ULog(handle, message_name_filter_list=[*wanted, *(other[:1] if other else [])])
    except Exception as exc:  # pyulog raises assorted errors on broken files
        raise InputError(f"not a readable ULog file ({exc})", path=str(path)) from exc
    if getattr(log, "file_corruption", False):
        raise InputError(
            "the ULog file is corrupt (damaged messages were skipped, so the samples cannot be "
            "trusted); copy the log from the vehicle again",
            path=str(path),
        )
    present = {(d.name, d.multi_id): d for d in log.data_list}
    for n in wanted:
        if (n, instance) in present:
            data = present[(n, instance)]
            break
    else:
        if len(wanted) < len(ULOG_TOPICS):  # the filter hid the other IMU topics: list them
            with path.open("rb") as handle:
                every = ULog(handle, message_name_filter_list=list(ULOG_TOPICS)).data_list
            present = {(d.name, d.multi_id): d for d in every}
        found = ", ".join(f"{n}:{i}" for n, i in sorted(present)) or "none"
        raise InputError(
            f"no IMU topic {' / '.join(wanted)} (instance {instance}) in the log; found {found}",
            path=str(path),
        )
    time_field, gyro, accel = ULOG_TOPICS[data.name]
    if time_field not in data.data:
        time_field = "timestamp"
    names = [c for c, f in zip(CHANNELS[:3], gyro, strict=False)] + [
        c for c, f in zip(CHANNELS[3:], accel, strict=False)
    ]
    columns = [np.asarray(data.data[f], dtype=np.float64) for f in (*gyro, *accel)]
    warnings: list[str] = []
    t, rows = _sorted(
        np.asarray(data.data[time_field], dtype=np.float64) * 1e-6,
        np.column_stack(columns),
        warnings,
    )
    others = sorted(i for n, i in present if n == data.name and i != instance)
    if others:
        warnings.append(f"{data.name} has other instances {others}; read instance {instance}")
    if temperature is None:
        return np.column_stack([t - t[0], rows]), ("t", *names), warnings
    source = data if other is None else present.get((other[0], other[1]))
    field = temperature if other is None else other[2]
    if source is None or field not in source.data:
        where = f"{data.name}" if other is None else f"{other[0]}:{other[1]}"
        fields = "" if source is None else ", ".join(sorted(source.data))
        raise InputError(
            f"no temperature field {field!r} in {where}"
            + (f" (its fields: {fields})" if fields else " (no such topic in the log)")
            + "; sensor_combined has no temperature: give --topic sensor_gyro with "
            "--temperature temperature, or --temperature sensor_gyro.temperature",
            path=str(path),
        )
    t_field = "timestamp_sample" if "timestamp_sample" in source.data else "timestamp"
    celsius = resample(
        t,
        np.asarray(source.data[t_field], dtype=np.float64) * 1e-6,
        np.asarray(source.data[field], dtype=np.float64),
        temperature,
        warnings,
    )
    return np.column_stack([t - t[0], rows, celsius]), ("t", *names, TEMPERATURE), warnings


def _ulog_field(spec: str | None) -> tuple[str, int, str] | None:
    """``(topic, instance, field)`` of ``TOPIC[:instance].FIELD``, None for a plain field."""
    if spec is None or "." not in spec:
        return None
    topic, _, field = spec.partition(".")
    name, _, inst = topic.partition(":")
    return name, int(inst) if inst.isdigit() else 0, field
