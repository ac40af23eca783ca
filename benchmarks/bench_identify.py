"""Cost of noise identification (``alpha=None``) against the variance kernel it accompanies.

On white rate noise (N = 1e7 by default, ``--channels`` columns) and the default log grid
(~94 taus) this measures, best of ``--repeat``:

* ``kernel``: ``_core.variance`` alone (overlapping, all cores);
* ``avar_alpha_0``: ``allanite.avar(x, fs, alpha=0)`` (no identification);
* ``avar_alpha_none``: ``allanite.avar(x, fs)`` (Stable32 noise identification at every tau);
* ``identify``: :func:`allanite.variance.edf.identify_alpha` alone, with its two compiled parts
  ``lag1_acf`` (lag-1 statistics, taus with >= 30 averages) and ``rn_all`` (R(n) at every
  tau with fewer, an upper bound: it is only evaluated where B1 points to phase noise);
* ``identify_traced_peak_bytes``: the largest numpy allocation total during identification
  (tracemalloc), i.e. its extra memory beyond the record and the phase.

Writes benchmarks/results/bench_identify.json. Usage:
``python benchmarks/bench_identify.py [--n 10000000] [--channels 1] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import allanite
from allanite import _core
from allanite.variance.edf import ACF_MIN_POINTS, identify_alpha

RESULTS = Path(__file__).resolve().parent / "results" / "bench_identify.json"


def _best(fn: Callable[[], Any], repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    """Run the measurements and write the JSON file."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=float, default=1e7)
    parser.add_argument("--channels", type=int, default=1)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    n, nc = int(args.n), args.channels
    rng = np.random.default_rng(0)
    x = rng.standard_normal((n, nc)) if nc > 1 else rng.standard_normal(n)
    fs = 100.0
    res = allanite.avar(x, fs=fs, alpha=0)
    phase = np.asarray(_core.phase(x.reshape(n, -1), "rate"))
    factors = res.m
    n_series = (phase.shape[0] - 1) // factors
    acf_m = factors[n_series >= ACF_MIN_POINTS]
    rn_m = factors[(n_series < ACF_MIN_POINTS) & (3 * factors <= phase.shape[0])]
    out: dict[str, Any] = {
        "n": n,
        "channels": nc,
        "taus": int(factors.size),
        "kernel": _best(lambda: _core.variance(phase, factors, "overlapping", 0), args.repeat),
        "avar_alpha_0": _best(lambda: allanite.avar(x, fs=fs, alpha=0), args.repeat),
        "avar_alpha_none": _best(lambda: allanite.avar(x, fs=fs), args.repeat),
        "identify": _best(lambda: identify_alpha(phase, factors, "overlapping"), args.repeat),
        "lag1_acf": _best(lambda: _core.lag1_acf(phase, acf_m, "frequency", 3, 0), args.repeat),
        "rn_all": _best(lambda: _core.mvar_avar_ratio(phase, rn_m, 0), args.repeat),
    }
    tracemalloc.start()
    identify_alpha(phase, factors, "overlapping")
    out["identify_traced_peak_bytes"] = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    out["phase_bytes"] = phase.nbytes
    out["machine"] = {
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
        "load_average": os.getloadavg(),
    }
    for key, value in out.items():
        print(f"{key:28s} {value:.4g}" if isinstance(value, float) else f"{key:28s} {value}")
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
