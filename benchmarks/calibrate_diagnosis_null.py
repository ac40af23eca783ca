"""False-alarm rate of the diagnosis null on records simulated from the model itself (issue 14).

For each record length, the null of :func:`allanite.diagnosis.analysis.analyze` is built once
per ensemble seed (for records longer than ``FULL_REPLICATES_MAX``: the exact tau covariance
plus short and decimated replicates, :mod:`allanite.diagnosis.scaled_null`; below: full-length
replicates), and ``--records`` independent null records (model = truth) are judged against it.
A calibrated test rejects a fraction ``alpha`` of them or fewer (the views combine their
statistics with Bonferroni, so they are conservative; the tau view's ``T`` is not). Reported
per length: the rejection rate of the global test and of each view at ``alpha`` with its
binomial standard error, and the mean of the tau view's ``T`` against its null mean ``T0``.
Run niced on the shared machine::

    nice -n 10 python benchmarks/calibrate_diagnosis_null.py --lengths 17 19 20 21 22

Results are written to ``benchmarks/results/calibrate_diagnosis_null.json``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from allanite.diagnosis.analysis import Plan, ensemble, record_features
from allanite.diagnosis.frequency_view import frequency_view
from allanite.diagnosis.inputs import SimSource
from allanite.diagnosis.scaled_null import uses_scaled_null
from allanite.diagnosis.tau_view import build_tau_model, tau_view
from allanite.diagnosis.time_view import time_view
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

RESULTS = Path(__file__).resolve().parent / "results" / "calibrate_diagnosis_null.json"


def models() -> dict[str, NoiseModel]:
    """The null models: the cost benchmark's sensor and one with a line and quantization."""
    t = TERM_TYPES
    units = {"rate": "deg/s", "time": "s"}
    return {
        "white+flicker+rrw": NoiseModel(
            (t["white"](N=0.05), t["flicker"](B=0.01), t["rrw"](K=0.0008)), units
        ),
        "white+rrw+markov+quantization": NoiseModel(
            (
                t["white"](N=0.01),
                t["rrw"](K=1e-4),
                t["markov"](sigma=0.02, tau_c=5.0),
                t["quantization"](Q=2e-5),
            ),
            units,
        ),
    }


def views(x: np.ndarray, plan: Plan, ens, alpha: float) -> dict[str, float]:  # type: ignore[no-untyped-def]
    """p-values of the three views and the global test of one record against ``ens``."""
    real = record_features(x, plan)
    tm = build_tau_model(
        real, ens, plan.m / plan.fs, 1.0 / plan.fs, ens.ref["avar_lin"], x.size / plan.fs,
        loo=not ens.exact_tau,
    )  # fmt: skip
    a = alpha / 3.0
    tv = tau_view(tm, ens, a)
    fv = frequency_view(x, plan.fs, real, ens, plan.nperseg, a)
    time_v = time_view(x, plan.fs, real, ens, plan.time, a)
    out = {"tau": tv.p_value, "frequency": fv.p_value, "time": time_v.p_value, "T": tv.statistic}
    out["global"] = min(1.0, 3.0 * min(out["tau"], out["frequency"], out["time"]))
    out.update({f"time:{k}": v for k, v in time_v.family_p.items()})
    out["frequency:line"] = fv.line_p_value
    out["frequency:band"] = fv.band_p_value
    out["t0"] = tm.t0
    return out


def main_() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lengths", type=int, nargs="+", default=[17, 19, 20, 21, 22])
    parser.add_argument("--records", type=int, default=40, help="null records per ensemble")
    parser.add_argument("--ensembles", type=int, default=2, help="null ensembles per length")
    parser.add_argument("--n-mc", type=int, default=200)
    parser.add_argument("--alpha", type=float, default=0.05)
    parser.add_argument("--fs", type=float, default=1000.0)
    parser.add_argument("--model", choices=sorted(models()), default="white+flicker+rrw")
    args = parser.parse_args()
    model = models()[args.model]
    rows = []
    for k in args.lengths:
        n = 2**k
        plan = Plan.for_length(n, args.fs)
        source = SimSource(fs=args.fs, model=model)
        ps: list[dict[str, float]] = []
        t_null = 0.0
        for e in range(args.ensembles):
            t0 = time.perf_counter()
            ens = ensemble(source, plan, args.n_mc, seed=1000 + 17 * e)
            t_null += time.perf_counter() - t0
            for r in range(args.records):
                seed = 10_000_000 + 100_000 * k + 1000 * e + r
                x = np.asarray(model.simulate(n, fs=args.fs, seed=seed), dtype=np.float64).ravel()
                ps.append(views(x, plan, ens, args.alpha))
        count = len(ps)
        row: dict[str, object] = {
            "model": args.model,
            "n": n,
            "scaled_null": uses_scaled_null(model, n),
            "n_mc": args.n_mc,
            "alpha": args.alpha,
            "records": count,
            "ensembles": args.ensembles,
            "null_build_s": t_null / args.ensembles,
            "binomial_se_at_alpha": float(np.sqrt(args.alpha * (1 - args.alpha) / count)),
            "mean_T": float(np.mean([p["T"] for p in ps])),
            "mean_T0": float(np.mean([p["t0"] for p in ps])),
            "sd_T_over_mean_T": float(np.std([p["T"] for p in ps], ddof=1) / np.sqrt(count)),
        }
        for key in ps[0]:
            if key in ("T", "t0"):
                continue
            row[f"rejected:{key}"] = float(np.mean([p[key] < args.alpha for p in ps]))
        row["tau_p_uniform_ks"] = float(
            __import__("scipy").stats.kstest([p["tau"] for p in ps], "uniform").pvalue
        )
        print(json.dumps(row), flush=True)
        rows.append(row)
        old = json.loads(RESULTS.read_text()) if RESULTS.exists() else []
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        RESULTS.write_text(json.dumps([*old, row], indent=1))


if __name__ == "__main__":
    main_()
