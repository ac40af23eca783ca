"""Time reading a ROS bag's IMU topic (ROS 1 .bag, ROS 2 sqlite3 and MCAP) with read_record.

A six-axis record (white noise, 400 Hz) is written as ``sensor_msgs/Imu`` with ``rosbags``
into a temporary folder, then read ``--repeat`` times; the best time per format is printed
and, with ``--out``, written as JSON. Only the public ``allanite.read_record`` is used, so the
same script times an older installed version for comparison::

    python benchmarks/bench_robot_logs.py --messages 200000 --repeat 3
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

import allanite


def _imu(ts, t: float, row: np.ndarray):  # type: ignore[no-untyped-def]
    types = ts.types
    sec = int(t)
    stamp = types["builtin_interfaces/msg/Time"](sec=sec, nanosec=int((t - sec) * 1e9))
    vec = types["geometry_msgs/msg/Vector3"]
    seq = {"seq": 0} if "seq" in types["std_msgs/msg/Header"].__dataclass_fields__ else {}
    return types["sensor_msgs/msg/Imu"](
        header=types["std_msgs/msg/Header"](stamp=stamp, frame_id="imu_link", **seq),
        orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.zeros(9),
        angular_velocity=vec(x=row[0], y=row[1], z=row[2]),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=vec(x=row[3], y=row[4], z=row[5]),
        linear_acceleration_covariance=np.zeros(9),
    )


def write(path: Path, kind: str, n: int, fs: float) -> None:
    """Write ``n`` IMU messages at ``fs`` Hz as a ROS 1 bag or a ROS 2 bag (sqlite3 / mcap)."""
    from rosbags.typesys import Stores, get_typestore

    rows = np.random.default_rng(1).normal(0.0, 1e-3, (n, 6))
    times = 1.7e9 + np.arange(n) / fs
    if kind == "ros1":
        from rosbags.rosbag1 import Writer

        ts = get_typestore(Stores.ROS1_NOETIC)
        with Writer(path) as w:
            c = w.add_connection("/imu0", "sensor_msgs/msg/Imu", typestore=ts)
            for t, r in zip(times, rows, strict=True):
                w.write(c, int(t * 1e9), ts.serialize_ros1(_imu(ts, t, r), "sensor_msgs/msg/Imu"))
        return
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as w:
        c = w.add_connection("/imu0", "sensor_msgs/msg/Imu", typestore=ts)
        for t, r in zip(times, rows, strict=True):
            w.write(c, int(t * 1e9), ts.serialize_cdr(_imu(ts, t, r), "sensor_msgs/msg/Imu"))


def main() -> None:
    """Write the bags, time the reads, print (and save) the best time per format."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--messages", type=int, default=200_000)
    parser.add_argument("--fs", type=float, default=400.0)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", help="JSON file for the results")
    args = parser.parse_args()
    results = {"messages": args.messages, "load_before": os.getloadavg()[0], "seconds": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for kind in ("ros1", "sqlite3", "mcap"):
            path = Path(tmp) / ("imu.bag" if kind == "ros1" else kind)
            write(path, kind, args.messages, args.fs)
            best = np.inf
            for _ in range(args.repeat):
                start = time.perf_counter()
                rec = allanite.read_record(path)
                best = min(best, time.perf_counter() - start)
            assert rec.n_samples == args.messages
            results["seconds"][kind] = round(best, 3)
            print(f"{kind}: {args.messages} messages read in {best:.2f} s (best of {args.repeat})")
    results["load_after"] = os.getloadavg()[0]
    print(f"load average {results['load_before']:.1f} -> {results['load_after']:.1f}")
    if args.out:
        Path(args.out).write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
