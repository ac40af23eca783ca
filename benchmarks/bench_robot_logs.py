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
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import allanite

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_io_robot_logs import write_bag  # the bag writer lives with the tests


def write(path: Path, kind: str, n: int, fs: float) -> None:
    """Write ``n`` IMU messages at ``fs`` Hz with the tests' bag writer (ROS 1, sqlite3, mcap)."""
    rows = np.random.default_rng(1).normal(0.0, 1e-3, (n, 6))
    write_bag(path, kind, rows, np.arange(n) / fs, topics=("/imu0",))


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
