"""Coverage of the Allan-deviation intervals at long taus, with and without the few-point cap.

Beyond the last averaging factor with at least 30 decimated points, Stable32's B1/R(n) rule
often reads a random walk as phase noise at one tau, which inflates that tau's EDF. allanite
caps the exponent there at the one of the longest lag-1 factor
(:func:`allanite.variance.edf.cap_few_point_alpha`). This benchmark simulates 300 records of the
built-in example model (30 min at 100 Hz, angle input), computes the 68.3 % intervals of the
overlapping Allan variance with the identified noise type, and counts how often they contain
the model's exact Allan variance at the few-point taus, with the cap and with Stable32's plain
rule. It also reports the coverage over all taus for the default identification (the cap and
the smoothing of isolated flips, :func:`allanite.variance.edf.smooth_isolated_alpha`), for the cap
without the smoothing (``alpha="stable32"``) and for Stable32's plain rule.
Run ``python benchmarks/edf_few_points.py``; writes
``benchmarks/results/edf_few_points.json``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

import allanite
import allanite.variance.edf as edf
from allanite.examples import EXAMPLE_FS, example_model

RESULTS = Path(__file__).resolve().parent / "results"
LEVEL = 0.683


def coverage(records: int = 300, batch: int = 100, alpha: str | None = None) -> dict[str, Any]:
    """Per-tau coverage of the few-point taus, and over all taus (``alpha`` of ``avar``)."""
    model = example_model()
    n = int(30 * 60 * EXAMPLE_FS)
    hits = []
    everywhere = []
    for s in range(records // batch):
        x = model.simulate(n, fs=EXAMPLE_FS, n_channels=batch, seed=100 + s, output="angle")
        r = allanite.avar(x, fs=EXAMPLE_FS, input="angle", alpha=alpha)
        few = (r.n_samples - 1) // r.m < edf.ACF_MIN_POINTS
        theory = model.avar(r.tau, 1.0 / EXAMPLE_FS)[:, None]
        lo, hi = r.var_ci(LEVEL)
        hits.append(((lo <= theory) & (theory <= hi))[few])
        everywhere.append((lo <= theory) & (theory <= hi))
    inside = np.concatenate(hits, axis=1)
    every = np.concatenate(everywhere, axis=1)
    return {
        "tau_s": r.tau[few].round(2).tolist(),
        "coverage_all_taus": float(every.mean()),
        "coverage": float(inside.mean()),
        "coverage_per_tau": inside.mean(axis=1).round(3).tolist(),
    }


def main() -> None:
    default = coverage()
    capped = coverage(alpha="stable32")
    original = edf.cap_few_point_alpha
    edf.cap_few_point_alpha = lambda a, f, p: np.array(a, copy=True)  # Stable32's plain rule
    try:
        plain = coverage(alpha="stable32")
    finally:
        edf.cap_few_point_alpha = original
    out = {
        "level": LEVEL,
        "records": 300,
        "default": default,
        "capped": capped,
        "stable32_rule": plain,
    }
    for name in ("default", "capped", "stable32_rule"):
        c = out[name]
        print(
            f"{name:14s} all taus {c['coverage_all_taus']:.3f}, few-point taus "
            f"{c['coverage']:.3f} (nominal {LEVEL}); last five taus {c['coverage_per_tau'][-5:]}"
        )
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "edf_few_points.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    ).parse_args()  # --help describes the run instead of starting it
    main()
