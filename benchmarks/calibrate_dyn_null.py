"""Calibration of the time view's per-window noise-level families ``dyn`` and ``hf`` (issue 14).

The false-alarm study (:mod:`calibrate_false_alarms`) found the ``dyn`` family (the log
non-overlapping Allan variance at ``m = L/16`` per window, 15 block-mean differences)
anti-conservative on models with flicker. This benchmark measures the family p-values alone,
cheaply: for each drawn model with a flicker term (:func:`calibrate_false_alarms.draw`, the
study's sensor classes), the null is built as the diagnosis builds it with the default ``n_mc``
(full-length replicates, :class:`~allanite.diagnosis.null.NullEnsemble.from_model`, up to
``2^18`` samples; the long-record null of :func:`~allanite.diagnosis.scaled_null.scaled_ensemble`
at 10^6), then ``--reals`` null records of the same model (other seeds) are judged by
:func:`~allanite.diagnosis.time_view.window_scan` under both laws: ``gaussian`` (one Gumbel
law of ``max_w |r_w / s_w|``) and ``sides`` (a Gumbel law each for the largest and the smallest
score). A
calibrated family has ``P(p < level) <= level``; the records of one model share its null, so
the Clopper-Pearson intervals are approximate (the null's own error is small at ``n_mc = 200``).

Also reported: the skewness of the null's per-window scores ``r_w / s_w`` pooled over windows
and replicates, next to the log-gamma law's ``psi''(a) / psi'(a)^1.5`` at the null's variance.

Usage::

    nohup nice python benchmarks/calibrate_dyn_null.py --models 50 --reals 6 --tag dyntail \
        > /tmp/dyntail-cal.log 2>&1 &
    nohup nice python benchmarks/calibrate_dyn_null.py --long --models 12 --reals 6 \
        --tag dyntail_long > /tmp/dyntail-cal-long.log 2>&1 &

Results: ``benchmarks/results/dyn_null_<tag>.json`` (rows, then the summary; rewritten after
every model).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy import special, stats

from allanite.diagnosis.analysis import Plan, record_features
from allanite.diagnosis.null import NullEnsemble, _log_gamma_shape
from allanite.diagnosis.scaled_null import scaled_ensemble
from allanite.diagnosis.time_view import time_features, window_scan

sys.path.insert(0, str(Path(__file__).resolve().parent))
import calibrate_false_alarms as cf
from validate_record_mode import clopper_pearson

RESULTS = Path(__file__).resolve().parent / "results"
LEVELS = (0.01, 0.05)
LENGTHS = (2**15, 2**16, 2**17)
LONG = 1_000_000
FAMILIES = ("dyn", "hf")
LAWS = ("gaussian", "sides")
#: the time view's share of the level for one family (alpha / 3 views / 7 statistics)
ALPHA = 0.05 / 3 / 7


def flicker_records(count: int, start: int, every: bool = False) -> list[cf.Record]:
    """The first ``count`` draws from ``start`` on whose model has a flicker term (``every``:
    all draws)."""
    out = []
    i = start
    while len(out) < count:
        rec = cf.draw(i)
        if every or any(t.type == "flicker" for t in cf.model_of(rec).terms):
            out.append(rec)
        i += 1
    return out


def null_of(model: Any, n: int, fs: float, n_mc: int, seed: int) -> tuple[NullEnsemble, Plan]:
    """The diagnosis' null of ``n``-sample records against ``model`` (see the module doc)."""
    plan = Plan.for_length(n, fs)
    if n > 2**18:
        ens = scaled_ensemble(model, n, fs, plan.m, plan.nperseg, plan.time, n_mc, seed)
        return ens, plan
    x = model.simulate(n, fs=fs, seed=seed, n_channels=n_mc)
    reps = [time_features(np.ascontiguousarray(x[:, j]), plan.time) for j in range(n_mc)]
    return NullEnsemble.from_model(reps), plan


def skew_check(null: np.ndarray) -> tuple[float, float]:
    """Pooled skewness of the median-removed null scores and the log-gamma law's."""
    c = null - np.median(null, axis=1, keepdims=True)
    c = c - c.mean(axis=0)
    var = c.var(axis=0, ddof=1)
    a = _log_gamma_shape(var)
    law = special.polygamma(2, a) / special.polygamma(1, a) ** 1.5
    return float(stats.skew((c / np.sqrt(var)).ravel())), float(np.mean(law))


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {"records": len(rows)}
    for fam in FAMILIES:
        for law in LAWS:
            ps = np.array([r["p"][fam][law] for r in rows])
            for level in LEVELS:
                k = int(np.sum(ps < level))
                rate, lo, hi = clopper_pearson(k, len(rows))
                out[f"{fam}_{law}_p<{level}"] = {"k": k, "rate": rate, "ci95": [lo, hi]}
            out[f"{fam}_{law}_min_p"] = float(ps.min())
    for fam in FAMILIES:
        out[f"{fam}_null_skew_mean"] = float(np.mean([r["skew"][fam][0] for r in rows]))
        out[f"{fam}_law_skew_mean"] = float(np.mean([r["skew"][fam][1] for r in rows]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", type=int, default=50, help="flicker models to draw")
    ap.add_argument("--reals", type=int, default=6, help="null records per model")
    ap.add_argument("--start", type=int, default=0, help="first draw index")
    ap.add_argument("--n-mc", type=int, default=200, help="replicates of the null (default's)")
    ap.add_argument("--long", action="store_true", help=f"records of {LONG} samples")
    ap.add_argument("--every", action="store_true", help="every drawn model, not only flicker")
    ap.add_argument("--tag", default="smoke")
    args = ap.parse_args()
    out = RESULTS / f"dyn_null_{args.tag}.json"
    rows: list[dict[str, Any]] = []
    for j, rec in enumerate(flicker_records(args.models, args.start, args.every)):
        t0 = time.time()
        n = LONG if args.long else LENGTHS[j % len(LENGTHS)]
        model = cf.model_of(rec)
        ens, plan = null_of(model, n, rec.fs, args.n_mc, rec.seed + 1)
        skew = {fam: skew_check(ens.null[fam]) for fam in FAMILIES}
        for k in range(args.reals):
            x = model.simulate(n, fs=rec.fs, seed=rec.seed + 1_000_003 + k)
            real = time_features(x, plan.time) if n <= 2**18 else record_features(x, plan)
            scans = {
                fam: {
                    law: window_scan(
                        ens.residual(real, fam),
                        ens.null[fam],
                        ALPHA,
                        sides=law == "sides",
                        median=True,
                    )
                    for law in LAWS
                }
                for fam in FAMILIES
            }
            p = {fam: {law: s.p_value for law, s in v.items()} for fam, v in scans.items()}
            # the extreme scores of each side (which tail the small p-values come from)
            z = {
                fam: {law: [float(s.z.min()), float(s.z.max())] for law, s in v.items()}
                for fam, v in scans.items()
            }
            rows.append(
                {"index": rec.index, "sensor": rec.sensor, "terms": list(rec.terms), "n": n,
                 "fs": rec.fs, "real": k, "p": p, "z_min_max": z, "skew": skew}
            )  # fmt: skip
        print(
            f"model {j} (draw {rec.index}, {rec.sensor}, {'+'.join(rec.terms)}, n {n}): "
            f"dyn p gauss {min(r['p']['dyn']['gaussian'] for r in rows[-args.reals :]):.3g} "
            f"sides {min(r['p']['dyn']['sides'] for r in rows[-args.reals :]):.3g}, "
            f"skew {skew['dyn'][0]:.3f} (law {skew['dyn'][1]:.3f}), {time.time() - t0:.1f} s",
            flush=True,
        )
        out.write_text(json.dumps({"rows": rows, "summary": summary(rows)}, indent=1))
    print(json.dumps(summary(rows), indent=1))


if __name__ == "__main__":
    main()
