"""Step power of the diagnosis' step scan against a CUSUM of block means (issue #28).

Records come from an independent generator (:func:`independent_record`: numpy white noise,
FFT-shaped flicker, a cumulative sum for the rate random walk), NOT from
``allanite.simulation``. The null replicates are the model's own (``NoiseModel.simulate``, 200
seeds), as the diagnosis uses them. Per model (white + flicker, white + rate random walk; 2^16
samples at 10 Hz), per step size (0, 1, 2, 3, 4, 6, 8, 10 sigma of the half-mean difference,
sigma from the replicates) and per position (0.15, 0.4, 0.7 of the record) the same records
are judged by

* ``scan``: :func:`allanite.diagnosis.changepoint.step_scan` on the differences of the
  time view's window means minus the replicates' mean (what :func:`time_view` runs), at the
  reference's level 0.05 (standalone), and at ``0.05 / 48``, its share inside the diagnosis
  (3 views, 8 time statistics, 2 statistics of the jump family: Bonferroni);
* ``ref``: the reference, ``max_k |sum_{i<k} (m_i - mean)|`` of 1-minute block means against
  the 95 % quantile of the same statistic over the replicates.

Power and false alarms carry exact (Clopper-Pearson) 95 % intervals.

Usage::

    nice -n 10 python benchmarks/validate_steps.py --records 40

Results: ``benchmarks/results/validate_steps.{json,md}``.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import allanite
from allanite.diagnosis.changepoint import step_scan
from allanite.diagnosis.time_view import time_plan
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES as T

sys.path.insert(0, str(Path(__file__).resolve().parent))
from validate_record_mode import clopper_pearson

RESULTS = Path(__file__).resolve().parent / "results"
UNITS = {"rate": "deg/h", "time": "s"}
FS, N = 10.0, 2**16
#: step sizes in sigmas of the half-mean difference
SIZES = (0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0)
POSITIONS = (0.15, 0.4, 0.7)
LEVEL = 0.05
#: the scan's share of the diagnosis' level (3 views x 8 time statistics x 2 in the jump family)
IN_DIAGNOSIS = LEVEL / 48.0
MODELS: dict[str, tuple[tuple[Any, ...], dict[str, float]]] = {
    "white+flicker": ((T["white"](N=0.18), T["flicker"](B=0.004)), {"n_white": 0.18, "b": 0.004}),
    "white+rrw": ((T["white"](N=0.18), T["rrw"](K=2e-4)), {"n_white": 0.18, "k": 2e-4}),
}


def independent_record(
    n: int, fs: float, *, n_white: float, b: float = 0.0, k: float = 0.0, seed: int
) -> np.ndarray:
    """White (``N``) + flicker (one-sided PSD ``B^2 / (pi f)``) + rate random walk (``K``)."""
    rng = np.random.default_rng(seed)
    x = n_white * np.sqrt(fs) * rng.standard_normal(n)
    if b:
        m = 2 * n
        f = np.fft.rfftfreq(m, 1.0 / fs)
        s = np.zeros_like(f)
        s[1:] = b**2 / (np.pi * f[1:])
        spec = np.sqrt(s * m * fs / 4.0) * (
            rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)
        )
        x += np.fft.irfft(spec, m)[:n]
    if k:
        x += np.cumsum(rng.standard_normal(n)) * k / np.sqrt(fs)
    return x


def window_means(x: np.ndarray, w: int, length: int) -> np.ndarray:
    """Means of ``w`` consecutive windows of ``length`` samples (last axis)."""
    return x[..., : w * length].reshape(*x.shape[:-1], w, length).mean(axis=-1)


def block_cusum(means: np.ndarray) -> np.ndarray:
    """The reference statistic ``max_k |sum_{i<k} (m_i - mean)|`` of block means (per row)."""
    c = np.cumsum(means - means.mean(axis=-1, keepdims=True), axis=-1)
    return np.abs(c).max(axis=-1)


class StepJudges:
    """The scan and the reference for one model, calibrated on the model's replicates."""

    def __init__(self, model: NoiseModel, n: int, fs: float, replicates: int = 200) -> None:
        plan = time_plan(n)
        self.w, self.length, self.fs = plan.n_windows, plan.length, fs
        self.block = int(60 * fs)
        sims = np.array(
            [np.asarray(model.simulate(n, fs=fs, seed=s)).ravel() for s in range(replicates)]
        )
        wm = window_means(sims, self.w, self.length)
        self.ref = wm.mean(axis=0)
        self.null_jumps = np.diff(wm - self.ref, axis=1)
        half = sims[:, n // 2 :].mean(axis=1) - sims[:, : n // 2].mean(axis=1)
        self.sd_half = float(half.std(ddof=1))
        null_ref = block_cusum(window_means(sims, n // self.block, self.block))
        self.thr_ref = float(np.quantile(null_ref, 1.0 - LEVEL))

    def scan_p(self, x: np.ndarray) -> float:
        """p-value of the step scan (as the time view runs it)."""
        jumps = np.diff(window_means(x, self.w, self.length) - self.ref)
        return step_scan(jumps, self.null_jumps, self.length / self.fs, LEVEL).p_value

    def ref_alarm(self, x: np.ndarray) -> bool:
        """The reference's decision at :data:`LEVEL`."""
        n_blocks = x.size // self.block
        return bool(block_cusum(window_means(x, n_blocks, self.block)) > self.thr_ref)


def run_model(name: str, records: int) -> list[dict[str, Any]]:
    """Rows (size, position) of one model: hit counts of the three decisions."""
    terms, rec = MODELS[name]
    judges = StepJudges(NoiseModel(terms, UNITS), N, FS)
    rows = []
    for pos in POSITIONS:
        for size in SIZES:
            hits = {"scan": 0, "scan_in_diagnosis": 0, "ref": 0}
            for i in range(records):
                x = independent_record(N, FS, seed=10_000 + i, **rec)
                x[int(pos * N) :] += size * judges.sd_half
                p = judges.scan_p(x)
                hits["scan"] += p < LEVEL
                hits["scan_in_diagnosis"] += p < IN_DIAGNOSIS
                hits["ref"] += judges.ref_alarm(x)
            row: dict[str, Any] = {"model": name, "position": pos, "size_sigma": size}
            row["sd_half"] = judges.sd_half
            for key, k in hits.items():
                row[key] = clopper_pearson(k, records)
            rows.append(row)
            print(name, pos, size, {k: v for k, v in hits.items()}, flush=True)
    return rows


def _meta(argv: list[str], seconds: float) -> dict[str, Any]:
    root = Path(__file__).resolve().parents[1]
    commit = subprocess.run(
        ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, check=False
    ).stdout.strip()
    return {
        "command": "python benchmarks/validate_steps.py " + " ".join(argv),
        "commit": commit,
        "version": allanite.__version__,
        "machine": platform.platform(),
        "seconds": seconds,
    }


def _markdown(rows: list[dict[str, Any]], meta: dict[str, Any], records: int) -> str:
    out = [
        "# Step power: step scan vs CUSUM of block means",
        "",
        f"`{meta['command']}` at {meta['commit'][:10]} (allanite {meta['version']}), "
        f"{records} records per row, {meta['seconds']:.0f} s.",
        "",
        "| model | position | step (sigma) | scan @0.05 | scan @0.05/48 | CUSUM ref @0.05 |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        cells = [
            f"{r[k][0]:.2f} [{r[k][1]:.2f}, {r[k][2]:.2f}]"
            for k in ("scan", "scan_in_diagnosis", "ref")
        ]
        out.append(
            f"| {r['model']} | {r['position']} | {r['size_sigma']:g} | " + " | ".join(cells) + " |"
        )
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Run the suite and write ``results/validate_steps.{json,md}``."""
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=40, help="records per (size, position)")
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    args = parser.parse_args(argv)
    t0 = time.time()
    rows = [r for m in args.models for r in run_model(m, args.records)]
    meta = _meta(argv, time.time() - t0)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "validate_steps.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    (RESULTS / "validate_steps.md").write_text(_markdown(rows, meta, args.records))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
