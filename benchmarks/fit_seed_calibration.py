"""Calibration of the default fit's uncertainty over many record seeds (validate_fit's designs).

A coverage count over the designed grid (``validate_fit.py``: 44 N records in the quick run,
296 in the full one) has a binomial sd of 3.3 % or 1.3 % around 95 %: it cannot tell a
biased or overconfident estimate from chance. This suite asks the two questions directly.

``--case I`` (one design of the grid, ``--seeds K`` records with seeds 5000, 5001, ...):
per term, the mean and sd of ``z = (estimate - truth) / stderr`` (a bias shows as
``mean z != 0``, an underestimated standard error as ``sd z > 1``), the 95 % coverage, and
the same for the *ideal* GLS on the same curve: the true terms' exact shapes weighted by the
covariance of the true model (:func:`allanite.fit.avar_covariance`), with its standard error
from that covariance. ``sd(fit - ideal)`` shows what the default fit's iterated covariance,
term selection and positivity constraint add to the error.

``--grid-reps R``: every record of the quick grid again with ``R`` other seeds
(``seed + 7919 r``), scored by ``validate_fit.run_case`` (the benchmark's own measures),
pooled per term.

Usage::

    nice python benchmarks/fit_seed_calibration.py --case 29 --seeds 200
    nice python benchmarks/fit_seed_calibration.py --case 36 --quick-grid --seeds 100
    nice python benchmarks/fit_seed_calibration.py --grid-reps 4

Results: ``benchmarks/results/fit_seed_calibration_*.{json,md}``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np

import allanite
from allanite.fit import avar_covariance, fit

sys.path.insert(0, str(Path(__file__).resolve().parent))
import validate_fit as vf

RESULTS = Path(__file__).resolve().parent / "results"
LEVEL = 0.95
Z95 = 1.959963984540054


def _curve(case: vf.Case, seed: int) -> allanite.AllanResult:
    model = vf.design(case)
    x = model.simulate(
        case.n, fs=case.fs, output=case.input, seed=seed, flicker_method=vf.FLICKER_METHOD
    )
    kind = cast(Literal["rate", "angle"], case.input)
    return allanite.avar(
        np.asarray(x, dtype=np.float64).ravel(),
        fs=case.fs,
        input=kind,
        taus=case.taus,
        units=case.unit,
    )


def _stats(z: np.ndarray, covered: np.ndarray) -> dict[str, Any]:
    ok = np.isfinite(z)
    k = int(ok.sum())
    return {
        "records": int(z.size),
        "fitted": k,
        "z_mean": float(np.mean(z[ok])) if k else math.nan,
        "z_mean_se": 1.0 / math.sqrt(k) if k else math.nan,
        "z_sd": float(np.std(z[ok], ddof=1)) if k > 1 else math.nan,
        "z_sd_se": 1.0 / math.sqrt(2.0 * (k - 1)) if k > 1 else math.nan,
        "coverage": float(np.mean(covered)),
    }


def run_case(case: vf.Case, seeds: int) -> dict[str, Any]:
    """The default fit against the ideal GLS on ``seeds`` records of one design."""
    model = vf.design(case)
    truth = model.coefficients()
    dt = 1.0 / case.fs
    amps = [truth[s] for s in case.terms]
    rows: list[dict[str, Any]] = []
    ideal_se: dict[str, float] = {}
    start = time.perf_counter()
    for seed in range(5000, 5000 + seeds):
        res = _curve(case, seed)
        f = fit(res)
        m = np.round(f.tau / dt)
        if not ideal_se:
            cov = avar_covariance(model, m, dt, case.n)
            design = np.column_stack(
                [
                    np.asarray(t.avar(m * dt, dt)) / a**2
                    for t, a in zip(model.terms, amps, strict=True)
                ]
            )
            weight = np.linalg.inv(cov)
            normal = design.T @ weight @ design
            gain = np.linalg.solve(normal, design.T @ weight)
            # delta method: the amplitude's relative se is half the squared amplitude's
            ideal_se = {
                s: math.sqrt(np.linalg.inv(normal)[j, j]) / (2.0 * truth[s] ** 2)
                for j, s in enumerate(case.terms)
            }
            fitted_m = m
        y = np.asarray(res.var, dtype=np.float64)[np.isin(res.m, fitted_m)]
        theta = gain @ y
        row: dict[str, Any] = {"seed": seed, "terms": list(f.coefficients), "p": f.p_value}
        for j, s in enumerate(case.terms):
            ideal = math.sqrt(max(float(theta[j]), 0.0))
            entry: dict[str, Any] = {"ideal": ideal}
            if s in f.coefficients:
                c = f.coefficients[s]
                lo, hi = c.ci(LEVEL)
                entry.update(value=c.value, stderr=c.stderr, low=lo, high=hi)
            row[s] = entry
        rows.append(row)
    out: dict[str, Any] = {
        "case": case.__dict__,
        "seeds": seeds,
        "seconds": time.perf_counter() - start,
        "terms": {},
    }
    for s in case.terms:
        t = truth[s]
        value = np.array([r[s].get("value", math.nan) for r in rows])
        stderr = np.array([r[s].get("stderr", math.nan) for r in rows])
        covered = np.array(
            [r[s].get("low", math.inf) <= t <= r[s].get("high", -math.inf) for r in rows]
        )
        ideal = np.array([r[s]["ideal"] for r in rows])
        z_ideal = (ideal - t) / (ideal_se[s] * t)
        out["terms"][s] = {
            "fit": _stats((value - t) / stderr, covered),
            "ideal": _stats(z_ideal, np.abs(z_ideal) <= Z95),
            "relative_sd_fit": float(np.nanstd(value / t, ddof=1)),
            "relative_se_ideal": ideal_se[s],
            "relative_se_fit_median": float(np.nanmedian(stderr / t)),
            "relative_sd_fit_minus_ideal": float(np.nanstd((value - ideal) / t, ddof=1)),
        }
    counts: dict[str, int] = {}
    for r in rows:
        key = "+".join(r["terms"])
        counts[key] = counts.get(key, 0) + 1
    out["chosen_terms"] = counts
    out["rows"] = rows
    return out


def run_grid(reps: int) -> dict[str, Any]:
    """The quick grid with ``reps`` other record seeds per design, pooled per term."""
    rows = []
    start = time.perf_counter()
    for case in vf.grid(quick=True, long=False):
        for r in range(reps):
            rows.append(vf.run_case(replace(case, seed=case.seed + 7919 * (r + 1))))
    pooled: dict[str, Any] = {}
    for s in vf.ORDER:
        entries = [row["terms"][s] for row in rows if s in row["terms"]]
        dom = [e for e in entries if e["dominant"]]
        z = np.array([e["z"] if e.get("z") is not None else math.nan for e in dom])
        pooled[s] = _stats(z, np.array([e["covered"] for e in dom], dtype=bool))
    return {
        "reps": reps,
        "records": len(rows),
        "seconds": time.perf_counter() - start,
        "terms": pooled,
        "rows": rows,
    }


def _line(name: str, st: dict[str, Any]) -> str:
    return (
        f"| {name} | {st['fitted']}/{st['records']} | {st['z_mean']:+.3f} ± {st['z_mean_se']:.3f} "
        f"| {st['z_sd']:.3f} ± {st['z_sd_se']:.3f} | {st['coverage']:.3f} |"
    )


def markdown(result: dict[str, Any], command: str) -> str:
    lines = ["# fit_seed_calibration", "", f"`{command}`", ""]
    head = "| term | fitted | mean z | sd z | 95 % coverage |\n|---|---|---|---|---|"
    if "case" in result:
        lines += [f"Case: `{json.dumps(result['case'])}`, {result['seeds']} seeds.", ""]
        lines += ["Default fit (`fit(result)`) and the ideal GLS (true covariance and shapes):", ""]
        lines.append(head)
        for s, t in result["terms"].items():
            lines.append(_line(f"{s} fit", t["fit"]))
            lines.append(_line(f"{s} ideal", t["ideal"]))
        lines += [
            "",
            "| term | rel. sd of the fit | median rel. stderr | ideal rel. se | sd(fit - ideal) |",
            "|---|---|---|---|---|",
        ]
        for s, t in result["terms"].items():
            lines.append(
                f"| {s} | {t['relative_sd_fit']:.5f} | {t['relative_se_fit_median']:.5f} | "
                f"{t['relative_se_ideal']:.5f} | {t['relative_sd_fit_minus_ideal']:.5f} |"
            )
        lines += ["", f"Chosen terms: {result['chosen_terms']}", ""]
    else:
        lines += [
            f"The quick grid with {result['reps']} other record seeds per design "
            f"({result['records']} records), terms where they dominate at >= 1 fitted tau:",
            "",
            head,
        ]
        for s, st in result["terms"].items():
            lines.append(_line(s, st))
        lines.append("")
    lines.append(f"time {result['seconds']:.0f} s")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", type=int, help="index of a validate_fit grid case")
    parser.add_argument("--quick-grid", action="store_true", help="index into the quick grid")
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--grid-reps", type=int, help="rerun the quick grid with R seeds")
    parser.add_argument("--output", help="results stem")
    args = parser.parse_args(argv)
    command = "python benchmarks/fit_seed_calibration.py " + " ".join(sys.argv[1:])
    if args.grid_reps:
        result = run_grid(args.grid_reps)
        stem = Path(args.output) if args.output else RESULTS / "fit_seed_calibration_grid"
    elif args.case is not None:
        cases = vf.grid(quick=args.quick_grid, long=False)
        result = run_case(cases[args.case], args.seeds)
        tag = f"{'q' if args.quick_grid else ''}{args.case}"
        stem = Path(args.output) if args.output else RESULTS / f"fit_seed_calibration_{tag}"
    else:
        parser.error("give --case I or --grid-reps R")
    stem.with_suffix(".json").write_text(json.dumps(result, indent=1, default=float))
    text = markdown(result, command)
    stem.with_suffix(".md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
