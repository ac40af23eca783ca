"""Calibration of the time view's spike (or tail-shape) p-value on null records (issue 14).

For several simulated sensors (the validation's MEMS base with quantization, pure white noise,
white + a short Gauss-Markov process, a navigation-grade model in deg/h with quantization) and
record lengths, a bank of null records is simulated and only the spike statistic is computed
(:func:`allanite.diagnosis.time_view.spike_features`, the function the diagnosis uses). Each
trial takes one bank record as the "real" record and ``n_mc`` other bank records as the
replicates of the null (:meth:`~allanite.diagnosis.null.NullEnsemble.from_model`, as the
diagnosis builds it), and computes the spike p-value with
:func:`~allanite.diagnosis.time_view.spike_test`. Records longer than ``FULL_REPLICATES_MAX``
take the long-record path: replicates of ``SHORT_LENGTH`` samples, whose pooled exceedance
counts the scaled null passes on unchanged
(:func:`~allanite.diagnosis.scaled_null.scaled_ensemble`).

Reported per sensor, length and ``n_mc``: the fraction of trials with ``p`` below 1e-4, 1e-3,
1e-2 and 5e-2 with its 95 % Clopper-Pearson interval (a calibrated or conservative p has a fraction
at or below the level), and the dispersion of the per-record counts of samples beyond high
levels (Poisson: variance / mean = 1). Trials share replicates (random subsets of one bank),
so the intervals are somewhat optimistic. Run niced on the shared machine::

    nice -n 10 python benchmarks/calibrate_spike_null.py --tag _spiketail

``--statistic tail`` calibrates the tail-shape statistic instead
(:func:`~allanite.diagnosis.time_view.tail_features`,
:func:`~allanite.diagnosis.time_view.tail_test`; on the long-record path its shares are
rescaled from the short replicates as the scaled null does,
:func:`~allanite.diagnosis.null.rescaled`).

Results: ``benchmarks/results/calibrate_spike_null<tag>.{json,md}``
(``calibrate_tail_null<tag>`` for the tail shape).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from allanite.diagnosis.null import NullEnsemble, rescaled
from allanite.diagnosis.scaled_null import FULL_REPLICATES_MAX, SHORT_LENGTH
from allanite.diagnosis.time_view import spike_features, spike_test, tail_features, tail_test
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

sys.path.insert(0, str(Path(__file__).resolve().parent))
from validate_diagnosis import base_model

RESULTS = Path(__file__).resolve().parent / "results"
LEVELS = (1e-4, 1e-3, 1e-2, 5e-2)


def sensors() -> dict[str, tuple[NoiseModel, float]]:
    """The null sensors and their sampling rates."""
    t = TERM_TYPES
    s = {"rate": "deg/s", "time": "s"}
    h = {"rate": "deg/h", "time": "s"}
    return {
        "mems": (base_model(100.0), 100.0),
        "white": (NoiseModel((t["white"](N=0.05),), s), 100.0),
        "white+markov": (
            NoiseModel((t["white"](N=0.05), t["markov"](sigma=0.3, tau_c=0.03)), s),
            100.0,
        ),
        "navgrade": (
            NoiseModel(
                (
                    t["white"](N=0.12),
                    t["quantization"](Q=0.01),
                    t["flicker"](B=0.003),
                    t["rrw"](K=1e-4),
                ),
                h,
            ),
            400.0,
        ),
    }


def bank(model: NoiseModel, fs: float, n: int, count: int, seed: int) -> list[dict[str, Any]]:
    """Spike and tail-shape features of ``count`` independent records of ``n`` samples."""
    out: list[dict[str, Any]] = []
    batch = max(1, min(count, 2**22 // n))
    done = 0
    while done < count:
        k = min(batch, count - done)
        x = np.asarray(
            model.simulate(n, fs=fs, n_channels=k, seed=seed + done, allow_aliasing=True)
        ).reshape(n, -1)
        for j in range(k):
            xj = np.ascontiguousarray(x[:, j])
            out.append({**spike_features(xj), "tail": tail_features(xj)})
        done += k
    return out


def interval(hits: int, trials: int) -> tuple[float, float]:
    """95 % Clopper-Pearson interval of a binomial fraction."""
    lo = stats.beta.ppf(0.025, hits, trials - hits + 1) if hits > 0 else 0.0
    hi = stats.beta.ppf(0.975, hits + 1, trials - hits) if hits < trials else 1.0
    return float(lo), float(hi)


def dispersion(records: list[dict[str, Any]]) -> dict[str, float]:
    """Variance / mean of the per-record exceedance counts at a few levels (Poisson: 1)."""
    if "spike_tail" not in records[0]:
        return {}
    from allanite.diagnosis.time_view import SPIKE_GRID

    counts = np.stack([r["spike_tail"] for r in records])
    out = {}
    for level in (4.0, 4.5, 5.0):
        i = int(np.argmin(np.abs(SPIKE_GRID - level)))
        mean = float(counts[:, i].mean())
        if mean > 0:
            out[f"{level:g}"] = float(counts[:, i].var(ddof=1) / mean)
    return out


def p_value(statistic: str, real: dict[str, Any], ens: NullEnsemble, n: int, n_rep: int) -> float:
    """The p-value of ``statistic`` (``spike`` or ``tail``) of one real record."""
    if statistic == "spike":
        return spike_test(real, ens, 0.05)[0]
    if n != n_rep:  # the long-record path: shares rescaled from the short replicates
        ref, null = rescaled(ens, "tail", n_rep / n, log_mean=False)
        ens = NullEnsemble(ref={"tail": ref}, null={"tail": null}, real_scale=1.0)
    return tail_test(real, ens)[0]


def calibrate(
    name: str, n: int, n_mcs: list[int], trials: int, seed: int, statistic: str = "spike"
) -> list[dict[str, Any]]:
    """Calibration rows of one sensor and length (one row per ``n_mc``)."""
    model, fs = sensors()[name]
    long_path = n > FULL_REPLICATES_MAX
    n_rep = SHORT_LENGTH if long_path else n
    t0 = time.perf_counter()
    reals = bank(model, fs, n, trials, seed)
    pool = reals if not long_path else bank(model, fs, n_rep, max(n_mcs) * 3, seed + 5_000_000)
    t_bank = time.perf_counter() - t0
    rng = np.random.default_rng(seed + 1)
    rows = []
    for n_mc in n_mcs:
        ps = np.empty(trials)
        for t in range(trials):
            others = rng.choice(len(pool) - (0 if long_path else 1), n_mc, replace=False)
            if not long_path:
                others = others + (others >= t)  # the real record is not a replicate
            ens = NullEnsemble.from_model([pool[i] for i in others])
            ps[t] = p_value(statistic, reals[t], ens, n, n_rep)

        row: dict[str, Any] = {
            "statistic": statistic, "sensor": name, "n": n, "replicate_n": n_rep, "n_mc": n_mc,
            "trials": trials, "bank_s": round(t_bank, 1), "min_p": float(ps.min()),
        }  # fmt: skip
        for level in LEVELS:
            hits = int(np.count_nonzero(ps < level))
            lo, hi = interval(hits, trials)
            row[f"below_{level:g}"] = {"fraction": hits / trials, "ci95": [lo, hi]}
            row[f"anti_{level:g}"] = lo > level
        row["dispersion"] = dispersion(pool)
        rows.append(row)
    return rows


def markdown(rows: list[dict[str, Any]], command: str, load: str, title: str = "Spike") -> str:
    """The results as a markdown table."""
    head = "| sensor | n | replicates of | n_mc | " + " | ".join(
        f"P(p < {lv:g}) [95 %]" for lv in LEVELS
    )
    lines = [
        f"# {title} p-value calibration on null records",
        "",
        f"`{command}` (load: {load})",
        "",
        head + " | min p | var/mean counts (4, 4.5, 5) |",
        "|" + "---|" * (len(LEVELS) + 6),
    ]
    for r in rows:
        cells = []
        for lv in LEVELS:
            b = r[f"below_{lv:g}"]
            flag = " **anti**" if r[f"anti_{lv:g}"] else ""
            cells.append(f"{b['fraction']:.4f} [{b['ci95'][0]:.4f}, {b['ci95'][1]:.4f}]{flag}")
        disp = ", ".join(f"{v:.2f}" for v in r["dispersion"].values()) or "-"
        lines.append(
            f"| {r['sensor']} | 2^{int(np.log2(r['n']))} | 2^{int(np.log2(r['replicate_n']))} | "
            f"{r['n_mc']} | " + " | ".join(cells) + f" | {r['min_p']:.2g} | {disp} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    names = sorted(sensors())
    parser.add_argument("--sensors", nargs="+", default=names, choices=names)
    parser.add_argument("--lengths", type=int, nargs="+", default=[15, 16, 17])
    parser.add_argument(
        "--long", type=int, nargs="*", default=[19],
        help="log2 lengths of the long-record path (replicates of SHORT_LENGTH samples)",
    )  # fmt: skip
    parser.add_argument("--long-sensors", nargs="+", default=["mems", "navgrade"])
    parser.add_argument("--n-mc", type=int, nargs="+", default=[60, 200])
    parser.add_argument("--trials", type=int, default=1000)
    parser.add_argument("--long-trials", type=int, default=1000)
    parser.add_argument("--tag", default="")
    parser.add_argument("--statistic", choices=("spike", "tail"), default="spike")
    args = parser.parse_args()
    rows: list[dict[str, Any]] = []
    jobs = [(s, 2**k, args.trials) for s in args.sensors for k in args.lengths]
    jobs += [(s, 2**k, args.long_trials) for s in args.long_sensors for k in args.long]
    for i, (name, n, trials) in enumerate(jobs):
        new = calibrate(
            name, n, args.n_mc, trials, seed=7_000_000 + 1000 * i, statistic=args.statistic
        )
        rows.extend(new)
        for r in new:
            print(
                r["sensor"], r["n"], r["n_mc"],
                {f"{lv:g}": r[f"below_{lv:g}"]["fraction"] for lv in LEVELS},
                f"min p {r['min_p']:.2g}", r["dispersion"], flush=True,
            )  # fmt: skip
    command = "python benchmarks/calibrate_spike_null.py " + " ".join(sys.argv[1:])
    with open("/proc/loadavg") as f:
        load = " ".join(f.read().split()[:3])
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / f"calibrate_{args.statistic}_null{args.tag}"
    out.with_suffix(".json").write_text(
        json.dumps({"command": command, "load": load, "rows": rows}, indent=1) + "\n"
    )
    title = "Spike" if args.statistic == "spike" else "Tail-shape"
    out.with_suffix(".md").write_text(markdown(rows, command, load, title))


if __name__ == "__main__":
    main()
