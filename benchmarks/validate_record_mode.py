"""False-alarm rate of the diagnosis when the simulation is given as a record, not a model.

Null cases only: the real record and the simulated record are independent draws of the same
base model (white, quantization, flicker, rate random walk; the one of
``validate_diagnosis.py``), so every significant answer is a false alarm. Record mode builds
its null from Gaussian surrogates of the simulated record (its smoothed periodogram with random
phases), which keep the spectrum but not the run-to-run spread of slow, non-ergodic noise or
non-Gaussian features; this benchmark measures how well that is calibrated.

Run ``python benchmarks/validate_record_mode.py [--cases 30] [--log2n 14,16] [--n-mc 200]``;
the table is printed and written to ``benchmarks/results/validate_record_mode.json``/``.md``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from scipy import stats

from allanite.diagnosis import diagnose

sys.path.insert(0, str(Path(__file__).resolve().parent))
from validate_diagnosis import base_model

RESULTS = Path(__file__).resolve().parent / "results"
FS = 100.0


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float, float]:
    """Rate ``k/n`` and its exact (Clopper-Pearson) two-sided binomial interval."""
    a = (1.0 - level) / 2.0
    lo = float(stats.beta.ppf(a, k, n - k + 1)) if k > 0 else 0.0
    hi = float(stats.beta.ppf(1.0 - a, k + 1, n - k)) if k < n else 1.0
    return k / n, lo, hi


def run_case(n: int, i: int, n_mc: int) -> dict[str, object]:
    """One null case: real and simulated record from the same model, different seeds."""
    base = base_model(FS)
    real = base.simulate(n, fs=FS, seed=50_000 + i)
    sim = base.simulate(n, fs=FS, seed=90_000 + i)
    t0 = time.perf_counter()
    d = diagnose(real, sim, fs=FS, units="deg/s", n_mc=n_mc, seed=i)
    fam = d.time.family_p
    worst = min(fam, key=lambda k: fam[k])
    return {
        "n": n,
        "case": i,
        "seconds": time.perf_counter() - t0,
        "significant": d.significant,
        "p_value": d.p_value,
        "p_tau": d.tau.p_value,
        "p_frequency": d.frequency.p_value,
        "p_time": d.time.p_value,
        "worst_time_statistic": worst,
        "worst_time_p": fam[worst],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=30, help="null cases per record length")
    parser.add_argument("--log2n", default="14,16", help="record lengths as powers of two")
    parser.add_argument("--n-mc", type=int, default=200, help="Monte Carlo replicates")
    args = parser.parse_args()
    rows = []
    for k in (int(v) for v in args.log2n.split(",")):
        for i in range(args.cases):
            row = run_case(2**k, i, args.n_mc)
            rows.append(row)
            print(
                f"N=2^{k} case {i:3d}: significant={row['significant']!s:5} "
                f"p={row['p_value']:.3g} (tau {row['p_tau']:.2g}, freq {row['p_frequency']:.2g}, "
                f"time {row['p_time']:.2g}, worst {row['worst_time_statistic']})",
                flush=True,
            )
    lines = [
        f"`python benchmarks/validate_record_mode.py --cases {args.cases} --log2n {args.log2n} "
        f"--n-mc {args.n_mc}` (alpha = 0.05)",
        "",
        "| N | cases | false alarms | rate (95 % interval) | by view (tau / frequency / time) |",
        "|---|---|---|---|---|",
    ]
    summary = {}
    for n in sorted({r["n"] for r in rows}):
        sel = [r for r in rows if r["n"] == n]
        fa = [r for r in sel if r["significant"]]
        views = [
            sum(float(r[f"p_{v}"]) * 3 < 0.05 for r in fa) for v in ("tau", "frequency", "time")
        ]
        rate, lo, hi = clopper_pearson(len(fa), len(sel))
        summary[str(n)] = {
            "cases": len(sel),
            "false_alarms": len(fa),
            "rate": rate,
            "ci95": [lo, hi],
        }
        lines.append(
            f"| {n} | {len(sel)} | {len(fa)} | {rate:.3f} ({lo:.3f}-{hi:.3f}) "
            f"| {views[0]} / {views[1]} / {views[2]} |"
        )
    total = sum(bool(r["significant"]) for r in rows)
    rate, lo, hi = clopper_pearson(total, len(rows))
    summary["all"] = {"cases": len(rows), "false_alarms": total, "rate": rate, "ci95": [lo, hi]}
    lines.append(f"| all | {len(rows)} | {total} | {rate:.3f} ({lo:.3f}-{hi:.3f}) | |")
    table = "\n".join(lines)
    print(table)
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "validate_record_mode.json").write_text(
        json.dumps({"summary": summary, "cases": rows}, indent=1)
    )
    (RESULTS / "validate_record_mode.md").write_text(
        "# Record-mode diagnosis: false alarms on null cases\n\n" + table + "\n"
    )


if __name__ == "__main__":
    main()
