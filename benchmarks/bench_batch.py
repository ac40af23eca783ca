"""A production lot through ``allanite.batch``: locally and on a local Dask cluster.

Writes ``--records`` (default 100) simulated gyro records of ``--samples`` (default 1e6)
samples as .npy files (white rate noise plus a rate random walk, a few gyros out of spec), runs
``allanite.batch`` on the paths locally and through a ``distributed.LocalCluster`` (2 worker
processes, 1 thread each) -- overlapping AVAR, ``allanite.fit`` (terms auto) per record,
pass/marginal/fail of N and K against the datasheet with the fit's 95 % interval -- checks
that the two tables are identical, and writes timings to
``benchmarks/results/batch.json`` and ``batch.md``::

    python benchmarks/bench_batch.py
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

RESULTS = Path(__file__).resolve().parent / "results"
FS = 100.0
SHEET = {"N": 0.0012, "K": 0.0005}


def write_lot(directory: str, records: int, samples: int) -> list[str]:
    paths = []
    for i in range(records):
        rng = np.random.default_rng(10_000 + i)
        white = 0.01 * (1.5 if i % 17 == 5 else 1.0)  # every 17th gyro is noisier
        x = white * rng.standard_normal(samples) + 1e-5 * np.cumsum(rng.standard_normal(samples))
        path = os.path.join(directory, f"gyro{i:03d}.npy")
        np.save(path, x)
        paths.append(path)
    return paths


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=100)
    parser.add_argument("--samples", type=int, default=10**6)
    args = parser.parse_args()
    import distributed

    with tempfile.TemporaryDirectory(prefix="allanite-lot-") as tmp:
        paths = write_lot(tmp, args.records, args.samples)
        t0 = time.perf_counter()
        local = allanite.batch(paths, fs=FS, datasheet=SHEET, threads=2)
        t_local = time.perf_counter() - t0
        with (
            distributed.LocalCluster(
                n_workers=2, threads_per_worker=1, dashboard_address=None
            ) as cluster,
            distributed.Client(cluster) as client,
        ):
            t0 = time.perf_counter()
            remote = allanite.batch(paths, fs=FS, datasheet=SHEET, client=client, threads=1)
            t_dask = time.perf_counter() - t0
    identical = remote == local
    result = {
        "records": args.records,
        "samples": args.samples,
        "local_seconds": t_local,
        "dask_seconds": t_dask,
        "tables_identical": identical,
        "failed": [r for r, _ in local.failures],
        "marginal": [
            r
            for r, s in zip(local.column("record"), local.column("status"), strict=True)
            if s == "marginal"
        ],
        "loadavg_at_end": os.getloadavg(),
    }
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "batch.json").write_text(json.dumps(result, indent=2))
    md = (
        f"Batch of {args.records} records x {args.samples:.0e} samples (.npy files): local "
        f"{t_local:.1f} s, local Dask cluster (2 workers x 1 thread) {t_dask:.1f} s; tables "
        f"identical: {identical}; every record fitted (terms auto); out of spec: "
        f"{len(result['failed'])} records, marginal: {len(result['marginal'])}.\n"
    )
    (RESULTS / "batch.md").write_text(md)
    print(md)
    if not identical:
        raise SystemExit("the local and Dask tables differ")


if __name__ == "__main__":
    main()
