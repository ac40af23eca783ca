"""Validation of the streaming flicker generator (AR(1) bank + random walk + FIR residual).

Three parts, written to ``results/sim_flicker_stream.json`` and ``.md``:

* ``design``: the largest relative deviation of the generator's exact Allan variance
  (:func:`allanite.terms.flicker_laws.bank_avar`) from the term's
  (:meth:`allanite.terms.Flicker.avar`) over 200 log-spaced tau from ``dt`` to half the record,
  for several record lengths (and two cutoffs ``f0`` below Nyquist, where it is approximate),
  next to the old point-sampled Gauss-Markov bank's and the half-width of the 95% chi-square
  band at ``tau = dt`` (Greenhall EDF, flicker FM) of one record;
* ``monte_carlo``: 32 records of 2^22 samples (``flicker_method="auto"``): per tau the share
  of 95% bands (the EDF allanite.avar attaches) that hold the term's AVAR and the z-score of the
  mean AVAR ratio (standard error from the 32 records);
* ``validate_fit``: the records of ``validate_fit.py``'s interrupted run with the old bank
  (``results/validate_fit_bank_flicker.json``) that have a flicker term and more than 2^21
  samples, simulated again with ``flicker_method="auto"`` (now this generator) and fitted:
  rejections (p < 0.001) before and after, same seeds;
* ``monte_carlo_f0``: the same with a cutoff ``f0 = fs/4`` (16 records; the bank low-passed);
* ``stream``: one channel of ``--stream`` samples (default 1e8) in chunks of 2^20: time, peak
  resident memory, and the overlapping AVAR at ``tau = dt`` accumulated on the fly against the
  term's (its 95% band from the Greenhall EDF).

Run: ``nice python benchmarks/sim_flicker_stream.py [--stream N] [--part PART]`` (about 10
min on 2 shared cores; ``--part stream`` alone in a fresh process measures its peak memory).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import time
from pathlib import Path

import numpy as np
from scipy import stats

import allanite
from allanite.simulation.flicker import flicker_bank, flicker_stream
from allanite.terms import Flicker, GaussMarkov, White
from allanite.terms.flicker_laws import bank_avar
from allanite.variance.edf import greenhall_edf

RESULTS = Path(__file__).parent / "results"


def _old_bank_avar(m: np.ndarray, n: int) -> np.ndarray:
    """Exact AVAR of the previous simulation method (point-sampled Gauss-Markov bank + white)."""
    tcs, sigma, white_n = flicker_bank(1.0, 1.0, n_samples=n)
    total = White(N=white_n).avar(m, 1.0)
    for tc, s in zip(tcs, sigma, strict=True):
        total = total + GaussMarkov(sigma=float(s), tau_c=float(tc)).avar(m, 1.0)
    return np.asarray(total)


def _band(edf: float) -> float:
    """Relative half-width of the 95% chi-square band of an AVAR estimate with this EDF."""
    return 0.5 * (edf / stats.chi2.ppf(0.025, edf) - edf / stats.chi2.ppf(0.975, edf))


def design() -> list[dict]:
    rows = []
    cases = (
        (1 << 22, None),
        (10**8, None),
        (10**9, None),
        (10**8, 0.4),
        (10**8, 0.1),
        (10**8, 0.01),
    )
    for n, f0 in cases:
        m = np.unique(np.round(np.logspace(0, math.log10(n / 2), 200)))
        term = Flicker(B=1.0, f0=f0)
        error = bank_avar(m, 1.0, 1.0, n_samples=n, cutoff_hz=f0) / term.avar(m, 1.0) - 1.0
        old = _old_bank_avar(m, n) / term.avar(m, 1.0) - 1.0 if f0 is None else None
        rows.append(
            {
                "n": n,
                "f0_fs": f0,
                "max_rel_error": float(np.max(np.abs(error))),
                "at_m": float(m[np.argmax(np.abs(error))]),
                "rel_error_m1": float(error[0]),
                "max_rel_error_m_le_1000": float(np.max(np.abs(error[m <= 1000]))),
                "old_bank_rel_error_m1": None if old is None else float(old[0]),
                "old_bank_max_rel_error": None if old is None else float(np.max(np.abs(old))),
                "band95_m1": _band(
                    greenhall_edf(-1, 2, 1, n + 1, overlapping=True, modified=False)
                ),
            }
        )
        print(rows[-1], flush=True)
    return rows


def monte_carlo(records: int = 32, channels: int = 8, f0: float | None = None) -> dict:
    fs, n = 1.0, 1 << 22
    term = Flicker(B=1.0, f0=f0)
    m = np.unique(np.round(np.logspace(0, math.log10(n / 16), 16))).astype(np.int64)
    ratios, covered = [], []
    for call in range(records // channels):
        stream = flicker_stream(term, fs, channels, seed=500 + call, n_samples=n)
        x = stream.next(n)
        r = allanite.avar(x, fs=fs, m=m, alpha=-1)
        exact = term.avar(r.tau, 1.0 / fs)[:, None]
        lo, hi = r.var_ci(0.95)
        covered.append((lo <= exact) & (exact <= hi))
        ratios.append(r.var / exact)
        print("monte carlo", call, flush=True)
    ratio = np.concatenate(ratios, axis=1)
    cover = np.concatenate(covered, axis=1)
    mean = ratio.mean(axis=1)
    se = ratio.std(axis=1, ddof=1) / math.sqrt(ratio.shape[1])
    return {
        "n": n,
        "f0_fs": f0,
        "records": int(ratio.shape[1]),
        "m": m.tolist(),
        "coverage95": cover.mean(axis=1).tolist(),
        "coverage95_all": float(cover.mean()),
        "mean_ratio": mean.tolist(),
        "z_mean": ((mean - 1.0) / se).tolist(),
    }


def validate_fit_rerun() -> dict:
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    import validate_fit

    validate_fit.FLICKER_METHOD = "auto"
    stored = json.loads((RESULTS / "validate_fit_bank_flicker.json").read_text())
    old = {
        r["case"]["index"]: r
        for r in stored["rows"]
        if "B" in r["case"]["terms"] and r["case"]["n"] > (1 << 21)
    }
    rows = []
    for case in validate_fit.grid(False):
        if case.index not in old:
            continue
        row = validate_fit.run_case(case)
        before = old[case.index]
        rows.append(
            {
                "index": case.index,
                "n": case.n,
                "terms": list(case.terms),
                "p_old_bank": before["p_value"],
                "p_new": row["p_value"],
                "rejected_old_bank": bool(before["rejected"]),
                "rejected_new": bool(row["rejected"]),
            }
        )
        print(rows[-1], flush=True)
    return {
        "records": len(rows),
        "rejected_old_bank": sum(r["rejected_old_bank"] for r in rows),
        "rejected_new": sum(r["rejected_new"] for r in rows),
        "rows": rows,
    }


def stream(n: int, chunk: int = 1 << 20) -> dict:
    term = Flicker(B=1.0)
    s = flicker_stream(term, 1.0, 1, seed=7)  # length unknown: designed for 1e9 samples
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    start = time.perf_counter()
    total, count, last = 0.0, 0, None
    done = 0
    while done < n:
        x = s.next(min(chunk, n - done))[:, 0]
        d = np.diff(x) if last is None else np.diff(np.concatenate(([last], x)))
        total += float(np.dot(d, d))
        count += d.size
        last = x[-1]
        done += x.size
    seconds = time.perf_counter() - start
    avar1 = 0.5 * total / count
    exact = float(term.avar(np.array([1.0]), 1.0)[0])
    edf = greenhall_edf(-1, 2, 1, n + 1, overlapping=True, modified=False)
    return {
        "n": n,
        "chunk": chunk,
        "seconds": seconds,
        "ns_per_sample": 1e9 * seconds / n,
        "peak_rss_mb_before": rss_before,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "avar_m1_ratio": avar1 / exact,
        "band95_m1": _band(edf),
        "load": os.getloadavg(),
    }


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{value:+.2%}"


def markdown(d: dict) -> str:
    """The results as a Markdown report."""
    lines = [
        "# Streaming flicker generator (AR(1) bank + random walk + FIR residual): validation",
        "",
        "`nice python benchmarks/sim_flicker_stream.py` (2 shared cores, load in the stream rows).",
        "",
        "## Design: generator's exact AVAR vs Flicker.avar (200 tau from dt to half the record)",
        "",
        "| samples | f0 | max rel. error | at m | error at m=1 | max for m<=1000 "
        "| old bank at m=1 | old bank max | 95% band half-width at m=1 |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in d["design"]:
        f0 = "Nyquist" if r["f0_fs"] is None else f"{r['f0_fs']}/dt"
        oldm = r["old_bank_max_rel_error"]
        lines.append(
            f"| {r['n']:.3g} | {f0} | {r['max_rel_error']:.2e} | {r['at_m']:.3g} "
            f"| {r['rel_error_m1']:+.1e} | {r['max_rel_error_m_le_1000']:.1e} "
            f"| {_pct(r['old_bank_rel_error_m1'])} | {'-' if oldm is None else f'{oldm:.2%}'} "
            f"| {r['band95_m1']:.1e} |"
        )
    for key in ("monte_carlo", "monte_carlo_f0"):
        if key not in d:
            continue
        mc = d[key]
        cutoff = "" if mc.get("f0_fs") is None else f", cutoff f0 = {mc['f0_fs']}/dt"
        lines += [
            "",
            f"## Monte Carlo: {mc['records']} records of {mc['n']} samples (flicker_method=auto"
            f"{cutoff})",
            "",
            "95% bands (EDF attached by allanite.avar) holding Flicker.avar: "
            f"{mc['coverage95_all']:.1%} over all (record, tau).",
            "",
            "| m | coverage 95% | mean AVAR / term | z of the mean |",
            "|---|---|---|---|",
        ]
        for m, c, r, z in zip(
            mc["m"], mc["coverage95"], mc["mean_ratio"], mc["z_mean"], strict=True
        ):
            lines.append(f"| {m} | {c:.0%} | {r:.5f} | {z:+.2f} |")
    for key, title in (
        ("stream", "after the Monte Carlo, same process"),
        ("stream_fresh_process", "alone in a fresh process (`--part stream`)"),
    ):
        s = d[key]
        load = ", ".join(f"{x:.1f}" for x in s["load"])
        lines += [
            "",
            f"## Stream of {s['n']:.3g} samples, one channel, chunks of {s['chunk']}, {title}",
            "",
            f"- time {s['seconds']:.0f} s ({s['ns_per_sample']:.0f} ns/sample; load {load})",
            "- overlapping AVAR at tau = dt accumulated on the fly / Flicker.avar = "
            f"{s['avar_m1_ratio']:.5f} (95% band +-{s['band95_m1']:.1e})",
        ]
        if key == "stream_fresh_process":
            lines.append(
                f"- peak resident memory {s['peak_rss_mb']:.0f} MB, of which "
                f"{s['peak_rss_mb_before']:.0f} MB before the first sample (Python, numpy, "
                f"scipy, allanite, the filter design); the record is {8 * s['n'] / 2**20:.0f} MB"
            )
    v = d.get("validate_fit")
    if v:
        lines += [
            "",
            "## validate_fit records with flicker and > 2^21 samples, again with auto",
            "",
            "Records of the interrupted old-bank run (`validate_fit_bank_flicker.json`), same "
            f"seeds: rejected (p < 0.001) with the old bank {v['rejected_old_bank']}/"
            f"{v['records']}, with this generator {v['rejected_new']}/{v['records']}.",
            "",
            "| index | samples | terms | p old bank | p now |",
            "|---|---|---|---|---|",
        ]
        for r in v["rows"]:
            lines.append(
                f"| {r['index']} | {r['n']:.3g} | {' '.join(r['terms'])} "
                f"| {r['p_old_bank']:.2g} | {r['p_new']:.2g} |"
            )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stream", type=int, default=10**8, help="samples of the stream test")
    parser.add_argument(
        "--part",
        choices=("all", "design", "monte_carlo", "monte_carlo_f0", "validate_fit", "stream"),
        default="all",
        help="run one part (in a fresh process for the stream's peak memory) and merge it",
    )
    args = parser.parse_args()
    path = RESULTS / "sim_flicker_stream.json"
    out = json.loads(path.read_text()) if path.exists() and args.part != "all" else {}
    if args.part in ("all", "design"):
        out["design"] = design()
    if args.part in ("all", "monte_carlo"):
        out["monte_carlo"] = monte_carlo()
    if args.part in ("all", "monte_carlo_f0"):
        out["monte_carlo_f0"] = monte_carlo(16, 8, f0=0.25)
    if args.part in ("all", "validate_fit"):
        out["validate_fit"] = validate_fit_rerun()
    if args.part == "all":
        out["stream"] = stream(args.stream)
    if args.part == "stream":  # alone in a fresh process: its peak memory means something
        out["stream_fresh_process"] = stream(args.stream)
    RESULTS.mkdir(exist_ok=True)
    path.write_text(json.dumps(out, indent=1))
    if {"design", "monte_carlo", "stream", "stream_fresh_process"} <= set(out):
        path.with_suffix(".md").write_text(markdown(out))
    print(json.dumps(out.get("stream"), indent=1))


if __name__ == "__main__":
    main()
