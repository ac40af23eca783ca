"""Cost of ``allanite diagnose`` against ``allanite analyze`` on the same record (issue 14).

A record is simulated from its own model (white + flicker + rate random walk, 1 kHz), written to
an .npy file, and both CLI commands are timed in this process on it, plus the split of one
full-length replicate into simulation and features (what the replicate null of short records
pays per replicate). Several lengths are timed in the same run (the ratio at each length is
from the same conditions); the peak resident memory of the process and the load average are
recorded. Run niced on the shared machine::

    nice -n 10 python benchmarks/bench_diagnosis_cost.py --n 1000000 10000000 --n-mc 200
    nice -n 10 python benchmarks/bench_diagnosis_cost.py --n 100000000 --no-replicate-split

Results are appended to ``benchmarks/results/bench_diagnosis_cost.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from allanite.cli import main
from allanite.diagnosis.analysis import Plan, record_features
from allanite.diagnosis.scaled_null import uses_scaled_null
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

RESULTS = Path(__file__).resolve().parent / "results" / "bench_diagnosis_cost.json"


def model() -> NoiseModel:
    t = TERM_TYPES
    return NoiseModel(
        (t["white"](N=0.05), t["flicker"](B=0.01), t["rrw"](K=0.0008)),
        {"rate": "deg/s", "time": "s"},
    )


def timed(argv: list[str]) -> float:
    t0 = time.perf_counter()
    rc = main(argv)
    if rc != 0:
        raise SystemExit(f"{argv[0]} failed with rc {rc}")
    return time.perf_counter() - t0


def main_() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[1_000_000, 10_000_000])
    parser.add_argument(
        "--no-replicate-split",
        action="store_true",
        help="skip timing one full-length replicate (long records)",
    )
    parser.add_argument("--fs", type=float, default=1000.0)
    parser.add_argument("--n-mc", type=int, default=200)
    parser.add_argument(
        "--gap", action="store_true", help="real record with white noise x1.5 (a gap to explain)"
    )
    parser.add_argument("--note", default=None, help="a note stored with the rows")
    args = parser.parse_args()
    for n in args.n:
        run(n, args)


def run(n: int, args: argparse.Namespace) -> None:
    """Time analyze and diagnose on one record of ``n`` samples and append the row."""
    m = model()
    with tempfile.TemporaryDirectory() as tmp:
        real = Path(tmp) / "real.npy"
        path = Path(tmp) / "model.json"
        real_model = m
        if args.gap:
            real_model = m.without("white").plus(TERM_TYPES["white"](N=0.075))
        x = np.asarray(real_model.simulate(n, fs=args.fs, seed=1), dtype=np.float64).ravel()
        np.save(real, x)
        del x
        m.save(path)
        common = [str(real), "--fs", str(args.fs), "--units", "deg/s"]
        load_before = os.getloadavg()[0]
        t_analyze = timed(["analyze", *common, "-o", str(Path(tmp) / "a.csv")])
        t_sim = t_feat = None
        if not args.no_replicate_split:
            t0 = time.perf_counter()
            rep = np.asarray(m.simulate(n, fs=args.fs, seed=2), dtype=np.float64).ravel()
            t_sim = time.perf_counter() - t0
            t0 = time.perf_counter()
            record_features(rep, Plan.for_length(n, args.fs))
            t_feat = time.perf_counter() - t0
            del rep
        t_diag = timed(
            ["diagnose", *common, "--sim-model", str(path), "--n-mc", str(args.n_mc),
             "--json", "-o", str(Path(tmp) / "d.json"), "--progress", "off"]
        )  # fmt: skip
        verdict = json.loads((Path(tmp) / "d.json").read_text())
    row = {
        "n": n,
        "fs": args.fs,
        "n_mc": args.n_mc,
        "analyze_s": t_analyze,
        "diagnose_s": t_diag,
        "ratio": t_diag / t_analyze,
        "one_replicate_simulation_s": t_sim,
        "one_replicate_features_s": t_feat,
        "gap": bool(args.gap),
        "significant": verdict["gap"]["significant"],
        "closed": verdict["closed"],
        "null": "scaled" if uses_scaled_null(m, n) else "full-length replicates",
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "load_avg_1min": [load_before, os.getloadavg()[0]],
    }
    if args.note:
        row["note"] = args.note
    print(json.dumps(row, indent=1), flush=True)
    old = json.loads(RESULTS.read_text()) if RESULTS.exists() else []
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps([*old, row], indent=1))


if __name__ == "__main__":
    main_()
