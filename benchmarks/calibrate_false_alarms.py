"""False alarms of the diagnosis on null records nobody picked (issue 14).

The validation suites' null cases all use one base sensor (``validate_diagnosis.base_model``).
Here every record is drawn from a sensor nobody chose: a class (:data:`SENSORS`: navigation
grade FOG/RLG, tactical, MEMS, consumer MEMS, with datasheet-order coefficient ranges in
customary units, or ``designed``: ``validate_fit``'s span design, where each term dominates
0.5-3 decades of the fitted taus), a term mix (white always; quantization, flicker, rate
random walk, Gauss-Markov, rate ramp each with a probability), a sampling rate (100-2000 Hz),
a length (2^14-2^18 samples, a few of 10^6 which take the long-record null of
:mod:`allanite.diagnosis.scaled_null`), a rate unit (deg/s, deg/h, rad/s) and a seed. The
"real" record is simulated from the model and :func:`allanite.diagnose` is called as a user
would: ``diagnose(real, model, fs=fs, units=unit)`` with the DEFAULT settings (``n_mc``,
significance, no holdout, seed). Every significant answer is a false alarm.

Per record: significant, the overall p, each view's p (tau; frequency with its line and band
statistics; time with every family of ``TimeView.family_p``), closed, the headline's first
line, seconds. The summary gives the false-alarm rate with its exact (Clopper-Pearson) 95 %
interval, the same per cell (sensor class, length, rate, unit, term present), the worst cell,
and the p-value calibration of every view and family: the fraction of records with ``p <
0.01`` and ``p < 0.05`` with its interval (a calibrated or conservative p has a fraction at
most the level; ``anti_conservative`` lists those whose interval lies above it).

Usage::

    nice python benchmarks/calibrate_false_alarms.py --records 10 --tag smoke
    nohup nice python benchmarks/calibrate_false_alarms.py --records 400 --stop-after 4000 \
        --tag s9 > /tmp/nullcal-run.log 2>&1 &

Results: ``benchmarks/results/false_alarms_<tag>.{json,md}``, rewritten after every record
(rows first, then the summary), so a long run that is stopped keeps what it did.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from allanite.diagnosis import diagnose
from allanite.diagnosis.scaled_null import uses_scaled_null
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES, GaussMarkov, Term
from allanite.units import SYMBOL_POWERS, coefficient_unit, convert

sys.path.insert(0, str(Path(__file__).resolve().parent))
import validate_fit as vf
from validate_record_mode import clopper_pearson

RESULTS = Path(__file__).resolve().parent / "results"
#: the diagnosis' default significance (false alarm = significant at it)
SIGNIFICANCE = 0.05
#: the p-value calibration levels
LEVELS = (0.01, 0.05)
#: a p-value this small is out of reach of a calibrated test on a few hundred records (the
#: chance that any of n records shows one is at most n times it)
EXTREME_P = 1e-6
#: the worst cell is taken among cells of at least this many records
MIN_CELL = 10

#: coefficient ranges per sensor class (log-uniform between the bounds), customary units:
#: N deg/sqrt(h), B deg/h, K deg/h/sqrt(h), R deg/h^2, Q deg (angle quantum / sqrt(12) order).
#: Orders of magnitude of datasheets: ring-laser / fibre-optic navigation gyros (ARW ~ 0.001
#: deg/sqrt(h), bias instability ~ 0.001-0.01 deg/h), tactical (0.05-0.3 deg/sqrt(h), ~1
#: deg/h), MEMS (0.1-1 deg/sqrt(h), a few to tens of deg/h; the ADIS16405 of
#: ../shared/data is about 2 deg/sqrt(h)) and consumer MEMS (0.5-5 deg/sqrt(h), tens to
#: hundreds of deg/h)
SENSORS: dict[str, dict[str, tuple[float, float]]] = {
    "navigation": {
        "N": (3e-4, 5e-3),
        "B": (3e-4, 1e-2),
        "K": (1e-5, 1e-3),
        "R": (1e-5, 1e-3),
        "Q": (3e-5, 3e-4),
    },
    "tactical": {
        "N": (0.02, 0.3),
        "B": (0.1, 3.0),
        "K": (3e-3, 0.3),
        "R": (1e-3, 0.1),
        "Q": (1e-4, 1e-3),
    },
    "mems": {
        "N": (0.1, 2.0),
        "B": (2.0, 30.0),
        "K": (0.3, 10.0),
        "R": (0.1, 10.0),
        "Q": (3e-4, 3e-3),
    },
    "consumer": {
        "N": (0.5, 5.0),
        "B": (10.0, 200.0),
        "K": (3.0, 100.0),
        "R": (1.0, 100.0),
        "Q": (1e-3, 1e-2),
    },
}
CUSTOMARY = {"N": "deg/sqrt(h)", "B": "deg/h", "K": "deg/h/sqrt(h)", "R": "deg/h^2", "Q": "deg"}
#: the class of every record: the four sensor classes and validate_fit's span design
CLASSES = (*SENSORS, "designed")
#: probability that a term beyond white noise is in the model
TERM_PROBABILITY = {"Q": 0.4, "B": 0.7, "K": 0.6, "markov": 0.3, "R": 0.15}
TERM_KIND = {"N": "white", "Q": "quantization", "B": "flicker", "K": "rrw", "R": "ramp"}
RATES = (100.0, 125.0, 200.0, 250.0, 400.0, 500.0, 800.0, 1000.0, 2000.0)
LENGTHS = (2**14, 2**15, 2**16, 2**17, 2**18)
#: a record of this length (the long-record null) with this probability
LONG_LENGTH, LONG_SHARE = 1_000_000, 0.06
UNITS = ("deg/s", "deg/h", "rad/s")


@dataclass(frozen=True)
class Record:
    """One null record: what was drawn, from which everything else follows."""

    index: int
    sensor: str
    terms: tuple[str, ...]
    n: int
    fs: float
    unit: str
    seed: int


def draw(index: int, grid_seed: int = 14, length: int | None = None) -> Record:
    """The ``index``-th record of the draw ``grid_seed`` (deterministic).

    ``length`` fixes the number of samples (the other draws stay those of the index).
    """
    rng = np.random.default_rng([grid_seed, index])
    sensor = str(rng.choice(CLASSES))
    n = LONG_LENGTH if rng.uniform() < LONG_SHARE else int(rng.choice(LENGTHS))
    n = n if length is None else int(length)
    fs = float(rng.choice(RATES))
    unit = str(rng.choice(UNITS))
    seed = int(rng.integers(1 << 31))
    if sensor != "designed":
        terms = ("N", *(s for s, p in TERM_PROBABILITY.items() if rng.uniform() < p))
        return Record(index, sensor, terms, n, fs, unit, seed)
    # validate_fit's subsets in a random order: the first that its span design can place on
    # this record's fitted taus (a short record has too few decades for four or five terms)
    for j in rng.permutation(len(vf.SUBSETS)):
        record = Record(index, sensor, tuple(vf.SUBSETS[j]), n, fs, unit, seed)
        try:
            model_of(record)
        except RuntimeError:
            continue
        return record
    raise RuntimeError(f"no subset of validate_fit.SUBSETS fits record {index} (n {n}, fs {fs})")


def _in_unit(value: float, symbol: str, unit: str) -> float:
    """A customary coefficient in the unit a model in rate ``unit`` stores it."""
    return convert(value, CUSTOMARY[symbol], coefficient_unit(unit, *SYMBOL_POWERS[symbol]))


def model_of(record: Record) -> NoiseModel:
    """The record's sensor model (the "simulation" the user passes, and the truth).

    A sensor class draws each coefficient log-uniformly in its range (:data:`SENSORS`); a
    Gauss-Markov process gets ``sigma`` between 0.5 and 5 times the class's bias instability
    draw and a correlation time log-uniform between 20 samples and a third of the record.
    ``designed`` is ``validate_fit.design_span`` on the record's length, rate and unit (its
    fitted taus on the log grid, rate input).
    """
    if record.sensor == "designed":
        case = vf.Case(
            index=record.index,
            terms=record.terms,
            n=record.n,
            fs=record.fs,
            taus="log",
            input="rate",
            unit=record.unit,
            seed=record.seed,
        )
        return vf.design_span(case)
    rng = np.random.default_rng([record.seed, 3])
    ranges = SENSORS[record.sensor]

    def log_uniform(lo: float, hi: float) -> float:
        return float(10.0 ** rng.uniform(math.log10(lo), math.log10(hi)))

    terms: list[Term] = []
    for symbol in record.terms:
        if symbol == "markov":
            sigma = log_uniform(*ranges["B"]) * log_uniform(0.5, 5.0)
            duration = record.n / record.fs
            tau_c = log_uniform(20.0 / record.fs, duration / 3.0)
            terms.append(GaussMarkov(sigma=_in_unit(sigma, "B", record.unit), tau_c=tau_c))
            continue
        value = _in_unit(log_uniform(*ranges[symbol]), symbol, record.unit)
        terms.append(TERM_TYPES[TERM_KIND[symbol]](**{symbol: value}))
    return NoiseModel(tuple(terms), {"rate": record.unit, "time": "s"})


def evaluate(record: Record, n_mc: int | None = None) -> dict[str, Any]:
    """Simulate the record from its model and diagnose it against the model (defaults).

    ``n_mc`` overrides the default number of replicates (the tests' tiny records only).
    """
    model = model_of(record)
    real = model.simulate(record.n, fs=record.fs, seed=record.seed)
    options: dict[str, Any] = {} if n_mc is None else {"n_mc": n_mc}
    t0 = time.perf_counter()
    d = diagnose(real, model, fs=record.fs, units=record.unit, **options)
    seconds = time.perf_counter() - t0
    views = {
        "tau": d.tau.p_value,
        "frequency": d.frequency.p_value,
        "time": d.time.p_value,
    }
    families = {
        "tau:T": d.tau.p_value,
        "frequency:line": d.frequency.line_p_value,
        "frequency:band": d.frequency.band_p_value,
        **{f"time:{k}": float(v) for k, v in d.time.family_p.items()},
    }
    return {
        **asdict(record),
        "model": model.to_dict(),
        "n_mc": d.meta.get("n_mc"),
        "null": "scaled" if uses_scaled_null(model, record.n) else "full",
        "n_null": d.meta.get("n_null"),
        "significant": bool(d.significant),
        "p_value": float(d.p_value),
        "views": views,
        "families": families,
        "closed": bool(d.closed),
        "unexplained": sorted({u.view for u in d.unexplained}),
        "headline": d.headline.splitlines()[0] if d.headline else "",
        "seconds": seconds,
    }


def rate(k: int, n: int) -> dict[str, Any]:
    """``k`` of ``n`` with the exact (Clopper-Pearson) 95 % interval."""
    if n == 0:
        return {"k": 0, "n": 0, "rate": None, "low": None, "high": None}
    r, lo, hi = clopper_pearson(k, n)
    return {"k": k, "n": n, "rate": r, "low": lo, "high": hi}


def _length_label(n: int) -> str:
    return f"2^{int(math.log2(n))}" if n & (n - 1) == 0 else f"{n:.0e}".replace("+0", "")


def _cell_order(label: str) -> tuple[float, str]:
    """Numeric cells (rates, lengths) in numeric order, the others by name."""
    base, _, power = label.partition("^")  # "2^14", "1e6", "100", "deg/s"
    try:
        value = float(base) ** float(power or 1.0)
    except ValueError:
        value = math.inf
    return value, label


def cells(row: dict[str, Any]) -> dict[str, list[str]]:
    """The cells a row belongs to, per grouping."""
    present = [TERM_KIND.get(s, s) for s in row["terms"]]
    return {
        "sensor": [row["sensor"]],
        "length": [_length_label(row["n"])],
        "fs": [f"{row['fs']:g}"],
        "unit": [row["unit"]],
        "term": present,
        "null": [row["null"]],
    }


def _p_of(row: dict[str, Any], statistic: str) -> float:
    """The p-value of a view (``tau``) or of a family (``time:spike``) in a row."""
    return float(row["views" if statistic in row["views"] else "families"].get(statistic, 1.0))


def reproducer(rows: list[dict[str, Any]], statistic: str, level: float) -> dict[str, Any]:
    """The shortest record (then the smallest p) whose ``statistic`` has ``p < level``."""
    hits = [r for r in rows if _p_of(r, statistic) < level]
    r = min(hits, key=lambda r: (r["n"], _p_of(r, statistic)))
    keys = ("index", "sensor", "n", "fs", "unit", "seed", "model")
    return {**{k: r[k] for k in keys}, "p": _p_of(r, statistic)}


def calibration(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per view and family: the fraction of records with ``p`` below each level, the least p."""
    out: dict[str, Any] = {}
    for kind in ("views", "families"):
        for name in sorted({k for r in rows for k in r[kind]}):
            ps = [r[kind][name] for r in rows if name in r[kind]]
            out[name] = {f"p<{a:g}": rate(sum(p < a for p in ps), len(ps)) for a in LEVELS}
            out[name]["min_p"] = float(min(ps))
    return out


def summarize(rows: list[dict[str, Any]], significance: float = SIGNIFICANCE) -> dict[str, Any]:
    """False-alarm rates (overall, per cell, the worst cell) and p-value calibration."""
    n = len(rows)
    out: dict[str, Any] = {
        "records": n,
        "significance": significance,
        "false_alarms": rate(sum(r["significant"] for r in rows), n),
        "closed": rate(sum(r["closed"] for r in rows), n),
    }
    groups: dict[str, dict[str, list[dict[str, Any]]]] = {}
    for r in rows:
        for grouping, labels in cells(r).items():
            for label in labels:
                groups.setdefault(grouping, {}).setdefault(label, []).append(r)
    per_cell = {
        g: {
            lab: rate(sum(r["significant"] for r in c[lab]), len(c[lab]))
            for lab in sorted(c, key=_cell_order)
        }
        for g, c in groups.items()
    }
    out["cells"] = per_cell
    flat = [(g, lab, v) for g, c in per_cell.items() for lab, v in c.items() if v["n"]]
    sized = [t for t in flat if t[2]["n"] >= MIN_CELL]
    if sized:
        g, lab, v = max(sized, key=lambda t: (t[2]["rate"], t[2]["low"], t[2]["n"]))
        out["worst_cell"] = {"grouping": g, "cell": lab, **v}
    out["cells_above_goal"] = [
        {"grouping": g, "cell": lab, **v} for g, lab, v in flat if v["low"] > significance
    ]
    out["calibration"] = calibration(rows)
    # the full-length and the long-record (scaled) null apart: one can hide the other
    by_null = {k: [r for r in rows if r["null"] == k] for k in sorted({r["null"] for r in rows})}
    out["calibration_by_null"] = {k: calibration(sel) for k, sel in by_null.items()}
    out["anti_conservative"] = [
        {
            "statistic": name,
            "null": null,
            "level": a,
            **v[f"p<{a:g}"],
            "reproducer": reproducer(sel, name, a),
        }
        for null, sel in (("all", rows), *by_null.items())
        for name, v in (
            out["calibration"] if null == "all" else out["calibration_by_null"][null]
        ).items()
        for a in LEVELS
        if v[f"p<{a:g}"]["low"] > a
    ]
    # a calibrated p falls below EXTREME_P in any of n records with probability <= n EXTREME_P
    out["extreme_p"] = [
        {
            "statistic": name,
            "null": null,
            "count": sum(_p_of(r, name) < EXTREME_P for r in sel),
            "of": len(sel),
            "chance": len(sel) * EXTREME_P,
            "reproducer": reproducer(sel, name, EXTREME_P),
        }
        for null, sel in by_null.items()
        for name in out["calibration_by_null"][null]
        if out["calibration_by_null"][null][name]["min_p"] < EXTREME_P
    ]
    seconds = [r["seconds"] for r in rows]
    out["seconds"] = {
        "total": float(sum(seconds)),
        "median": float(np.median(seconds)) if seconds else None,
        "max": float(max(seconds)) if seconds else None,
    }
    return out


def _pct(v: dict[str, Any]) -> str:
    if not v["n"]:
        return "-"
    return f"{v['k']}/{v['n']} = {v['rate']:.3f} [{v['low']:.3f}, {v['high']:.3f}]"


def markdown(rows: list[dict[str, Any]], summary: dict[str, Any], command: str) -> str:
    """The summary tables, then the false alarms (rows) with their reproducers."""
    s = summary
    lines = [
        "# False alarms on null records nobody picked",
        "",
        f"`{command}`",
        "",
        f"{s['records']} records, default `diagnose` settings (significance "
        f"{s['significance']}); rates with the exact (Clopper-Pearson) 95 % interval.",
        "",
        f"- false alarms: **{_pct(s['false_alarms'])}** (goal <= 0.05)",
        f"- closed: {_pct(s['closed'])}",
    ]
    if "worst_cell" in s:
        w = s["worst_cell"]
        lines.append(f"- worst cell: {w['grouping']} = {w['cell']}: {_pct(w)}")
    above = ", ".join(f"{c['grouping']}={c['cell']}" for c in s["cells_above_goal"]) or "none"
    lines.append(f"- cells whose interval lies above {s['significance']}: {above}")
    lines.append(
        "- p-values whose fraction below a level lies above it: "
        + ("none" if not s["anti_conservative"] else "")
    )
    for a in s["anti_conservative"]:
        r = a["reproducer"]
        lines.append(
            f"  - {a['statistic']} p < {a['level']:g} ({a['null']} null): {_pct(a)}; shortest "
            f"record: #{r['index']} "
            f"({r['sensor']}, n {r['n']}, fs {r['fs']:g}, {r['unit']}, seed {r['seed']}) p "
            f"{r['p']:.3g}, model `{json.dumps(r['model']['terms'])}`"
        )
    lines.append(
        f"- p-values below {EXTREME_P:g} (chance: records x {EXTREME_P:g}): "
        + ("none" if not s["extreme_p"] else "")
    )
    for e in s["extreme_p"]:
        r = e["reproducer"]
        lines.append(
            f"  - {e['statistic']} ({e['null']} null): {e['count']} of {e['of']} records "
            f"(chance {e['chance']:.1g}); shortest record: #{r['index']} ({r['sensor']}, n "
            f"{r['n']}, fs {r['fs']:g}, {r['unit']}, seed {r['seed']}) p {r['p']:.3g}, model "
            f"`{json.dumps(r['model']['terms'])}`"
        )
    sec = s["seconds"]
    if sec["median"] is not None:
        lines.append(
            f"- diagnosis time: median {sec['median']:.1f} s, max {sec['max']:.1f} s, "
            f"total {sec['total']:.0f} s"
        )
    lines += ["", "## False-alarm rate per cell", "", "| grouping | cell | false alarms |"]
    lines.append("|---|---|---|")
    for g, c in s["cells"].items():
        for lab, v in c.items():
            lines.append(f"| {g} | {lab} | {_pct(v)} |")
    lines += ["", "## p-value calibration (fraction of records below the level)", ""]
    lines += ["| statistic | p < 0.01 | p < 0.05 | min p |", "|---|---|---|---|"]
    for name, v in s["calibration"].items():
        lines.append(f"| {name} | {_pct(v['p<0.01'])} | {_pct(v['p<0.05'])} | {v['min_p']:.2g} |")
    by_null = s["calibration_by_null"]
    lines += ["", "## p < 0.01 by null (full-length replicates; long-record scaled null)", ""]
    lines += ["| statistic | " + " | ".join(by_null) + " |", "|---|" + "---|" * len(by_null)]
    for name in s["calibration"]:
        cols = [_pct(c[name]["p<0.01"]) if name in c else "-" for c in by_null.values()]
        lines.append(f"| {name} | " + " | ".join(cols) + " |")
    alarms = [r for r in rows if r["significant"]]
    lines += ["", f"## False alarms ({len(alarms)})", ""]
    for r in alarms:
        worst = min(r["families"], key=lambda k: r["families"][k])
        lines.append(
            f"- record {r['index']} ({r['sensor']}, {'+'.join(r['terms'])}, n {r['n']}, "
            f"fs {r['fs']:g}, {r['unit']}, seed {r['seed']}): p {r['p_value']:.3g}, smallest "
            f'{worst} p {r["families"][worst]:.3g}; "{r["headline"]}"'
        )
    return "\n".join(lines) + "\n"


def write(stem: Path, rows: list[dict[str, Any]], command: str) -> dict[str, Any]:
    """Write ``stem.json`` (rows, then the summary) and ``stem.md``; return the summary."""
    summary = summarize(rows)
    stem.with_suffix(".json").write_text(
        json.dumps({"command": command, "rows": rows, "summary": summary}, indent=1)
    )
    stem.with_suffix(".md").write_text(markdown(rows, summary, command))
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=200, help="records to draw")
    parser.add_argument("--start", type=int, default=0, help="index of the first record")
    parser.add_argument("--grid-seed", type=int, default=14, help="another draw of records")
    parser.add_argument(
        "--stop-after", type=float, default=math.inf, help="draw no new record after S seconds"
    )
    parser.add_argument(
        "--length", type=int, help="every record this many samples (e.g. 1000000: long records)"
    )
    parser.add_argument("--tag", default="run", help="results: false_alarms_<tag>.{json,md}")
    parser.add_argument(
        "--summarize",
        metavar="JSON",
        nargs="+",
        help="rewrite the summary of a results file's rows; of several files, pooled into <tag>",
    )
    args = parser.parse_args(argv)
    if args.summarize:
        paths = [Path(p) for p in args.summarize]
        stored = [json.loads(p.read_text()) for p in paths]
        pooled = [r for st in stored for r in st["rows"]]
        if len({(r["index"], r["n"]) for r in pooled}) < len(pooled):
            raise ValueError("the files share records (same index and length): pool distinct runs")
        stem = paths[0].with_suffix("") if len(paths) == 1 else RESULTS / f"false_alarms_{args.tag}"
        write(stem, pooled, " + ".join(st["command"] for st in stored))
        print(stem.with_suffix(".md").read_text())
        return 0
    command = "python benchmarks/calibrate_false_alarms.py " + " ".join(
        sys.argv[1:] if argv is None else argv
    )
    stem = RESULTS / f"false_alarms_{args.tag}"
    rows: list[dict[str, Any]] = []
    start = time.perf_counter()
    for i in range(args.start, args.start + args.records):
        if time.perf_counter() - start > args.stop_after:
            print(f"stopped after {len(rows)} records (--stop-after {args.stop_after:g} s)")
            break
        record = draw(i, args.grid_seed, args.length)
        row = evaluate(record)
        rows.append(row)
        summary = write(stem, rows, command)
        fa = summary["false_alarms"]
        print(
            f"[{len(rows)}/{args.records}] #{i} {record.sensor} {'+'.join(record.terms)} "
            f"n={record.n} fs={record.fs:g} {record.unit}: p={row['p_value']:.3f} "
            f"{'ALARM' if row['significant'] else 'ok'} {row['seconds']:.1f}s "
            f"(false alarms {fa['k']}/{fa['n']}, elapsed {time.perf_counter() - start:.0f}s)",
            flush=True,
        )
    print(markdown(rows, summarize(rows), command))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
