"""Coverage of the 95 % intervals of deterministic components: rate ramp R and sine amplitude.

* ramp: white N = 0.01 deg/sqrt(s) + ramp R = 1e-5 deg/s^2, 200 Hz, 1e4 s (issue 12), default
  fit (``terms="auto"``); the interval must carry the ramp x noise cross term;
* sine: white N = 0.01 deg/sqrt(s) + sine 0.02 deg/s at 0.05 Hz, 100 Hz, 2000 s,
  ``terms=["white", "sine"]``;
* ramp designs of the validation grid (``--designs``): N + R and N + K + R as
  ``benchmarks/validate_fit.py`` designs them (3e5 samples at 1 kHz, R dominating the long
  taus), fitted with their true terms, one seed per record; the grid itself has too few R
  records (59) to tell 100 % coverage from 95 %.

Usage: ``nice python benchmarks/fit_deterministic_coverage.py [--seeds 100] [--designs 300]``,
or ``--sine-seeds 500`` for the sine part alone (the stored other parts are kept);
results in
``benchmarks/results/fit_deterministic_coverage.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

import allanite
from allanite.fit import fit
from allanite.model import NoiseModel
from allanite.terms import Sine, White

RESULTS = Path(__file__).resolve().parent / "results" / "fit_deterministic_coverage.json"


def ramp(seeds: int) -> dict[str, float]:
    """Coverage of R and the spread of its standardised error."""
    fs, n, big_r, big_n = 200.0, 2_000_000, 1e-5, 0.01
    covered, z, half = 0, [], []
    for seed in range(seeds):
        rng = np.random.default_rng(100 + seed)
        x = big_n * math.sqrt(fs) * rng.standard_normal(n) + big_r * np.arange(n) / fs
        f = fit(allanite.avar(x, fs=fs, units="deg/s"))
        lo, hi = f["R"].ci(0.95)
        covered += lo <= big_r <= hi
        z.append((f["R"].value - big_r) / f["R"].stderr)
        half.append((hi - lo) / 2 / big_r)
    return {
        "seeds": seeds,
        "covered": covered,
        "z_mean": float(np.mean(z)),
        "z_sd": float(np.std(z)),
        "relative_half_width": float(np.median(half)),
    }


def ramp_design(
    terms: tuple[str, ...], design_seed: int, records: int, design: str = "legacy"
) -> dict[str, Any]:
    """Coverage of R on a validation-grid design, one simulation seed per record.

    ``design`` is the grid's design: "legacy" (the first grid's) or "span" (each term
    dominating 0.5-3 decades of the fitted taus, :func:`validate_fit.design_span`).
    """
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import validate_fit as vf

    n, fs = 300_000, 1000.0
    case = vf.Case(0, terms, n, fs, "octave", "rate", "deg/s", design_seed, design=design)
    model = vf.design(case)
    truth = model.coefficients()["R"]
    covered, z = 0, []
    for seed in range(records):
        x = np.asarray(model.simulate(n, fs=fs, seed=5000 + seed)).ravel()
        f = fit(allanite.avar(x, fs=fs, taus="octave", units="deg/s"), list(terms))
        lo, hi = f["R"].ci(0.95)
        covered += lo <= truth <= hi
        z.append((f["R"].value - truth) / f["R"].stderr)
    return {
        "terms": list(terms),
        "design": design,
        "design_seed": design_seed,
        "decades": dict(zip(terms, vf.dominated_decades(model, f.tau * fs, fs), strict=True)),
        "records": records,
        "covered": covered,
        "z_mean": float(np.mean(z)),
        "z_sd": float(np.std(z)),
    }


def sine(seeds: int) -> dict[str, float]:
    """Coverage of the sine amplitude, simulation seeds ``0 .. seeds - 1``.

    The first 100 seeds covered 89 (z sd 1.16) and every later look at this term reused
    seeds from 0 to 149 (sd 1.14-1.30): not independent confirmations. On 150 fresh seeds
    (1000-1149) and 150 records of a plain NumPy sine + white generator, z sd 0.93 and 0.99,
    covered 144 and 142; on seeds 0-499: 473 covered (94.6 %), z sd 0.99.
    """
    amplitude, f0, fs, n = 0.02, 0.05, 100.0, 200_000
    model = NoiseModel(
        (White(N=0.01), Sine(amplitude=amplitude, frequency=f0)), {"rate": "deg/s", "time": "s"}
    )
    covered, z = 0, []
    for seed in range(seeds):
        x = np.asarray(model.simulate(n, fs=fs, seed=seed)).ravel()
        f = fit(allanite.avar(x, fs=fs, units="deg/s"), ["white", "sine"])
        name = next(k for k in f.coefficients if k.startswith("amp"))
        lo, hi = f[name].ci(0.95)
        covered += lo <= amplitude <= hi
        z.append((f[name].value - amplitude) / f[name].stderr)
    return {
        "seeds": seeds,
        "covered": covered,
        "z_mean": float(np.mean(z)),
        "z_sd": float(np.std(z)),
    }


def main() -> int:
    """Run both and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument(
        "--designs", type=int, default=0, help="records per validation-grid ramp design"
    )
    parser.add_argument(
        "--span-designs",
        type=int,
        default=0,
        help="only the ramp designs of the span grid (N + R, N + K + R), this many records each",
    )
    parser.add_argument(
        "--sine-seeds", type=int, default=0, help="only the sine part, on this many seeds"
    )
    args = parser.parse_args()
    out: dict[str, Any] = (
        json.loads(RESULTS.read_text(encoding="utf-8"))
        if args.sine_seeds and RESULTS.exists()
        else {}
    )
    if args.span_designs:  # only the span grid's ramp designs; the other parts are kept
        out = json.loads(RESULTS.read_text(encoding="utf-8")) if RESULTS.exists() else {}
        out["ramp_span_designs"] = [
            ramp_design(terms, seed, args.span_designs, design="span")
            for terms in (("N", "R"), ("N", "K", "R"))
            for seed in (8, 5)
        ]
    elif args.sine_seeds:  # only the sine, on more seeds; the other parts are kept
        out["sine"] = sine(args.sine_seeds)
    else:
        out = {"ramp": ramp(args.seeds), "sine": sine(args.seeds)}
    if args.designs and not args.sine_seeds and not args.span_designs:
        out["ramp_designs"] = [
            ramp_design(("N", "R"), 8, args.designs),
            ramp_design(("N", "K", "R"), 5, args.designs),
        ]
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(out, indent=1), encoding="utf-8")
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
