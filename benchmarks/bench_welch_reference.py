"""Cost of the long-record Welch reference (issue 14): diagnose with and without it, same process.

A 1e7-sample record is simulated from its own model (the cost benchmark's white + flicker +
rate random walk at 1 kHz); ``allanite analyze`` and ``allanite diagnose`` (``n_mc = 200``) are
timed alternately, ``diagnose`` once without the extra reference replicates
(``REFERENCE_SHARE`` set out of reach) and once with the share given, so both see the same
machine load. Run niced on the shared machine::

    nice python benchmarks/bench_welch_reference.py --share 0.2 --repeats 1

Rows are appended to ``benchmarks/results/bench_welch_reference.json``.
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

import allanite.diagnosis.scaled_null as scaled_null
from allanite.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_diagnosis_cost import model

RESULTS = Path(__file__).resolve().parent / "results" / "bench_welch_reference.json"


def main_() -> None:
    """Time analyze, diagnose without and with the Welch reference; append the rows."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10_000_000)
    parser.add_argument("--share", type=float, default=scaled_null.REFERENCE_SHARE)
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    m = model()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        real, path = Path(tmp) / "real.npy", Path(tmp) / "model.json"
        np.save(real, np.asarray(m.simulate(args.n, fs=1000.0, seed=1)).ravel())
        m.save(path)
        common = [str(real), "--fs", "1000", "--units", "deg/s"]

        def timed(argv: list[str]) -> float:
            t0 = time.perf_counter()
            main(argv)
            return time.perf_counter() - t0

        def diagnose(tag: str) -> float:
            out = str(Path(tmp) / f"d{tag}.json")
            return timed(["diagnose", *common, "--sim-model", str(path), "--n-mc", "200",
                          "--json", "-o", out, "--progress", "off"])  # fmt: skip

        analyze = ["analyze", *common, "-o", str(Path(tmp) / "a.csv")]
        for _ in range(args.repeats):
            load = os.getloadavg()[0]
            a1 = timed(analyze)
            scaled_null.REFERENCE_SHARE = 1e9
            without = diagnose("off")
            a2 = timed(analyze)
            scaled_null.REFERENCE_SHARE = args.share
            with_ref = diagnose("on")
            a3 = timed(analyze)
            views = {
                tag: json.loads((Path(tmp) / f"d{tag}.json").read_text())["gap"]["view_p_values"]
                for tag in ("off", "on")
            }
            analyze_s = float(np.mean([a1, a2, a3]))
            row = {
                "n": args.n,
                "share": args.share,
                "reference_replicates": scaled_null.reference_replicates(args.n, 4096, 200),
                "analyze_s": [a1, a2, a3],
                "diagnose_without_s": without,
                "diagnose_with_s": with_ref,
                "ratio_without": without / analyze_s,
                "ratio_with": with_ref / analyze_s,
                "view_p_values": views,
                "load_avg_1min": [load, os.getloadavg()[0]],
            }
            print(json.dumps(row), flush=True)
            rows.append(row)
    old = json.loads(RESULTS.read_text()) if RESULTS.exists() else []
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps([*old, *rows], indent=1))


if __name__ == "__main__":
    main_()
