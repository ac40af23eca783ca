"""Speed of the compiled overlapping Allan variance against the numpy oracle and allantools.

One run on the same record (white rate noise with a bias, N = 1e7 by default) and the same
grid (the original program's ~100 log-spaced averaging factors) prints and writes to
benchmarks/results/bench_core.json:

* ``core_threads_1`` / ``core_threads_2``: the compiled part alone (``_core.phase`` +
  ``_core.variance``), 1 and 2 worker threads (best of ``--repeat``);
* ``avar_end_to_end``: ``allanite.avar`` including noise identification and EDF;
* ``oracle``: :mod:`allanite.variance.oracle` (numpy, vectorised per tau);
* ``allantools``: ``allantools.oadev`` on the same frequency data and taus;

and the largest relative difference of each result from the compiled one.

Usage: ``python benchmarks/bench_core.py [--n 10000000] [--points 100] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import allanite
from allanite import _core
from allanite.variance import oracle
from allanite.variance.taus import log_grid

RESULTS = Path(__file__).resolve().parent / "results" / "bench_core.json"


def _best(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10_000_000, help="record length")
    parser.add_argument("--points", type=int, default=100, help="points of the log grid")
    parser.add_argument("--repeat", type=int, default=3, help="repeats of the compiled timings")
    parser.add_argument("--skip-allantools", action="store_true")
    args = parser.parse_args()

    rng = np.random.default_rng(12345)
    y = 0.01 + rng.standard_normal(args.n)  # rate samples, fs = 1 Hz
    m = log_grid(args.n, args.points)
    m = m[m <= _core.max_m("overlapping", args.n + 1)]
    x2 = y.reshape(-1, 1)

    def core(threads: int) -> np.ndarray:
        phase = _core.phase(x2, "rate")
        return np.asarray(_core.variance(phase, m, "overlapping", threads))[:, 0]

    timings: dict[str, float] = {}
    timings["core_threads_1"], v1 = _best(lambda: core(1), args.repeat)
    timings["core_threads_2"], v2 = _best(lambda: core(2), args.repeat)
    assert np.array_equal(v1, v2)
    timings["avar_end_to_end"], res = _best(
        lambda: allanite.avar(y, fs=1.0, kind="overlapping", m=m, threads=2), 1
    )

    def numpy_oracle() -> np.ndarray:
        phase = oracle.phase_from_record(y, "rate")
        return np.array([oracle.overlapping_variance(phase, int(k)) for k in m])

    timings["oracle"], v_ref = _best(numpy_oracle, 1)
    diffs = {
        "avar_end_to_end": float(np.max(np.abs(res.var / v1 - 1))),
        "oracle": float(np.max(np.abs(v_ref / v1 - 1))),
    }
    if not args.skip_allantools:
        import allantools

        timings["allantools"], out = _best(
            lambda: allantools.oadev(y, rate=1.0, data_type="freq", taus=m.astype(float)), 1
        )
        tau_at, dev_at = out[0], out[1]
        if tau_at.size == m.size:
            diffs["allantools"] = float(np.max(np.abs(dev_at**2 / v1 - 1)))

    record = {
        "benchmark": "overlapping Allan variance",
        "n_samples": args.n,
        "n_taus": int(m.size),
        "m_min": int(m[0]),
        "m_max": int(m[-1]),
        "seconds": timings,
        "speedup_vs_oracle_1_thread": timings["oracle"] / timings["core_threads_1"],
        "max_relative_difference_from_core": diffs,
        "machine": {
            "python": platform.python_version(),
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "load_average_1min_at_end": os.getloadavg()[0],
        },
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(record, indent=2) + "\n")
    width = max(len(k) for k in timings)
    print(f"overlapping AVAR, N = {args.n:,}, {m.size} taus (m = {m[0]} .. {m[-1]})")
    for name, seconds in timings.items():
        print(f"  {name:<{width}}  {seconds:9.3f} s")
    for name, diff in diffs.items():
        print(f"  max |{name} / core - 1| = {diff:.1e}")
    print(f"written to {RESULTS}")


if __name__ == "__main__":
    main()
