"""Cost of ``allanite diagnose`` against ``allanite analyze`` on the same record (issue 14).

A record is simulated from its own model (white + flicker + rate random walk, 1 kHz), written to
an .npy file, and both CLI commands are timed in this process on it, plus the split of one
null replicate into simulation and features. Run niced on the shared machine::

    nice -n 10 python benchmarks/bench_diagnosis_cost.py --n 1000000 --n-mc 200

Results are appended to ``benchmarks/results/bench_diagnosis_cost.json``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from allanite.cli import main
from allanite.diagnosis.analysis import Plan, record_features
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
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--fs", type=float, default=1000.0)
    parser.add_argument("--n-mc", type=int, default=200)
    parser.add_argument(
        "--gap", action="store_true", help="real record with white noise x1.5 (a gap to explain)"
    )
    args = parser.parse_args()
    m = model()
    with tempfile.TemporaryDirectory() as tmp:
        real = Path(tmp) / "real.npy"
        path = Path(tmp) / "model.json"
        real_model = m
        if args.gap:
            real_model = m.without("white").plus(TERM_TYPES["white"](N=0.075))
        x = np.asarray(real_model.simulate(args.n, args.fs, seed=1), dtype=np.float64).ravel()
        np.save(real, x)
        m.save(path)
        common = [str(real), "--fs", str(args.fs), "--units", "deg/s"]
        t_analyze = timed(["analyze", *common, "-o", str(Path(tmp) / "a.csv")])
        # one replicate: simulation vs features
        t0 = time.perf_counter()
        rep = np.asarray(m.simulate(args.n, args.fs, seed=2), dtype=np.float64).ravel()
        t_sim = time.perf_counter() - t0
        t0 = time.perf_counter()
        record_features(rep, Plan.for_length(args.n, args.fs))
        t_feat = time.perf_counter() - t0
        t_diag = timed(
            ["diagnose", *common, "--sim-model", str(path), "--n-mc", str(args.n_mc),
             "--json", "-o", str(Path(tmp) / "d.json"), "--progress", "off"]
        )  # fmt: skip
        verdict = json.loads((Path(tmp) / "d.json").read_text())
    row = {
        "n": args.n,
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
    }
    print(json.dumps(row, indent=1))
    old = json.loads(RESULTS.read_text()) if RESULTS.exists() else []
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps([*old, row], indent=1))


if __name__ == "__main__":
    main_()
