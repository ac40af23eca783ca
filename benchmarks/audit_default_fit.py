"""Audit of the default fit through the CLI on records nobody picked (``allanite fit FILE``).

``validate_fit.py`` designs its records so that every term dominates 0.5-3 decades of the
fitted taus. Here the records are drawn as sensors come: a class (the gyro classes of
``calibrate_false_alarms.SENSORS``, navigation grade to consumer MEMS, with datasheet-order
coefficients in deg/sqrt(h), deg/h, deg/h/sqrt(h), ...; and an accelerometer class,
:data:`ACCELEROMETER`, in m/s/sqrt(h), ug, m/s^2/sqrt(s)), white noise always and Q, B, K, R
each with a probability (:data:`TERM_PROBABILITY`), 1e4-1e7 samples (log-uniform), 100-2000
Hz, rate, angle or angle-increment samples, deg/s, deg/h, rad/s or mrad/s (gyros), m/s^2
(accelerometer), one or three axes (three independent draws of the same sensor). Each record
is written as a user has it (:func:`write_record`): a CSV with a header naming each column's
unit (``gx [deg/s]``; angle records ``theta_x [deg]``), with a time column ``t [s]`` or not;
a CSV without a header; records above :data:`CSV_MAX` samples as npy (a 1e7-row CSV is not
how such records come). The CLI is run as a user runs it: ``allanite fit FILE`` with only the
flags the file cannot state (:func:`user_flags`): ``--time-column`` for a time column (the
CLI does not guess it and says so), ``--fs`` without one, ``--input angle|increment`` for
angle samples, ``--units`` when no header states them. For small records the bare
``allanite fit FILE`` is run first and its error must name the missing flag.

Per channel (``--json``): every true term is scored against what the CLI reports for it:
its 95 % interval when fitted, its 95 % upper limit (``"undetected"``) when left out
(a term the record cannot show must still be bounded above its truth); the ratio
estimate/truth in customary units; whether the units shown are the customary ones
(:data:`GYRO_UNITS`, :data:`ACCEL_UNITS`); goodness-of-fit rejection (p < 0.001); terms
carrying most of the exact Allan variance at some fitted tau but missing; terms added that
are not in the truth; errors. The text output (``allanite fit FILE``, records up to
:data:`TEXT_MAX` samples) must show the same coefficients and units as the JSON. The
summary gives coverage with exact binomial (Clopper-Pearson) 95 % intervals per class and
overall, and the worst case per class.

Usage::

    nohup nice python benchmarks/audit_default_fit.py --records 160 --tag fitaudit \
        > /tmp/audit.log 2>&1 &

Results: ``benchmarks/results/audit_default_fit_<tag>.{json,md}``, rewritten every few
records (an interrupted run keeps what it did).
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES, Term
from allanite.units import ACCELEROMETER_CUSTOMARY, SYMBOL_POWERS, coefficient_unit, convert

sys.path.insert(0, str(Path(__file__).resolve().parent))
import calibrate_false_alarms as cfa
import validate_fit as vf
from validate_record_mode import clopper_pearson

RESULTS = Path(__file__).resolve().parent / "results"
#: accelerometer coefficient ranges (log-uniform), :data:`ACCEL_UNITS`: velocity random walk
#: (navigation grade ~0.005 m/s/sqrt(h), MEMS ~0.05-0.3), bias instability (a few to hundreds
#: of ug), acceleration random walk (Kalibr-style m/s^3/sqrt(Hz)), velocity quantum, ramp
ACCELEROMETER: dict[str, tuple[float, float]] = {
    "N": (3e-3, 0.3),
    "B": (3.0, 300.0),
    "K": (1e-6, 3e-4),
    "R": (1e-5, 1e-3),
    "Q": (1e-6, 1e-4),
}
SENSORS: dict[str, dict[str, tuple[float, float]]] = {**cfa.SENSORS, "accelerometer": ACCELEROMETER}
CLASSES = tuple(SENSORS)
#: the customary units the CLI must show: gyros (whatever the record's angle unit) and
#: accelerometers
GYRO_UNITS = cfa.CUSTOMARY
ACCEL_UNITS = {s: ACCELEROMETER_CUSTOMARY[s] for s in "QNBKR"}
#: probability that a term beyond white noise is in the sensor (the diagnosis study's, without
#: its Gauss-Markov term: the default fit's candidates are the IEEE terms Q, N, B, K, R)
TERM_PROBABILITY = {s: p for s, p in cfa.TERM_PROBABILITY.items() if s != "markov"}
RATES = cfa.RATES
GYRO_RATE_UNITS = ("deg/s", "deg/h", "rad/s", "mrad/s")
#: the angle unit a user's angle file has for a rate unit, and the factor from the
#: simulator's integral (rate unit x s) to it
ANGLE_UNIT = {**vf.ANGLE_UNIT, "mrad/s": ("mrad", 1.0)}
#: CSV up to this many samples; longer records as npy
CSV_MAX = 1_000_000
#: the text output is checked against the JSON for records up to this many samples
TEXT_MAX = 300_000
#: the bare ``allanite fit FILE`` (no flag) is run on records up to this many samples
BARE_MAX = 100_000
LEVEL = 0.95
Z95 = 1.959963984540054


@dataclass(frozen=True)
class Draw:
    """One record: what was drawn, from which everything else follows."""

    index: int
    sensor: str
    terms: tuple[str, ...]
    n: int
    fs: float
    input: str
    unit: str
    axes: int
    form: str  # "csv_time", "csv_header", "csv_plain" or "npy"
    seed: int


def draw(index: int, grid_seed: int = 1010) -> Draw:
    """The ``index``-th record of the draw ``grid_seed`` (deterministic)."""
    rng = np.random.default_rng([grid_seed, index])
    sensor = str(rng.choice(CLASSES))
    terms = ("N", *(s for s, p in TERM_PROBABILITY.items() if rng.uniform() < p))
    n = round(10.0 ** rng.uniform(4.0, 7.0))
    fs = float(rng.choice(RATES))
    kind = str(rng.choice(["rate", "angle", "increment"], p=[0.6, 0.2, 0.2]))
    unit = "m/s^2" if sensor == "accelerometer" else str(rng.choice(GYRO_RATE_UNITS))
    axes = int(rng.choice([1, 3]))
    form = str(rng.choice(["csv_time", "csv_header", "csv_plain"]))
    if n > CSV_MAX:
        form = "npy"
    seed = int(rng.integers(1 << 31))
    return Draw(
        index, sensor, tuple(sorted(terms, key="QNBKR".index)), n, fs, kind, unit, axes, form, seed
    )


def customary(sensor: str) -> dict[str, str]:
    """The customary unit of each coefficient for the class."""
    return ACCEL_UNITS if sensor == "accelerometer" else GYRO_UNITS


def truth_of(d: Draw) -> dict[str, float]:
    """The true coefficients in customary units (log-uniform in the class's ranges)."""
    rng = np.random.default_rng([d.seed, 3])
    ranges = SENSORS[d.sensor]
    return {s: float(10.0 ** rng.uniform(*np.log10(ranges[s]))) for s in d.terms}


def model_of(d: Draw) -> NoiseModel:
    """The sensor model in the record's rate unit."""
    units = customary(d.sensor)
    terms: list[Term] = []
    for s, value in truth_of(d).items():
        own = convert(value, units[s], coefficient_unit(d.unit, *SYMBOL_POWERS[s]))
        terms.append(TERM_TYPES[cfa.TERM_KIND[s]](**{s: own}))
    return NoiseModel(tuple(terms), {"rate": d.unit, "time": "s"})


def file_unit(d: Draw) -> tuple[str, float]:
    """The unit the file's samples are in, and the factor from the simulator's output."""
    return ANGLE_UNIT[d.unit] if d.input != "rate" else (d.unit, 1.0)


def channel_names(d: Draw) -> list[str]:
    """The file's channel names (without units)."""
    accel = d.sensor == "accelerometer"
    base = {"rate": "a" if accel else "g", "angle": "v" if accel else "theta_"}
    stem = base.get(d.input, "dv" if accel else "dtheta_")
    return [f"{stem}{axis}" for axis in "xyz"[: d.axes]]


def write_record(d: Draw, x: np.ndarray, folder: Path) -> Path:
    """Write the samples (``n`` x ``axes``) as the user has them (:attr:`Draw.form`)."""
    unit, factor = file_unit(d)
    data = x * factor
    if d.form == "npy":
        path = folder / f"rec{d.index}.npy"
        np.save(path, data if d.axes > 1 else data[:, 0])
        return path
    path = folder / f"rec{d.index}.csv"
    names = [f"{c} [{unit}]" for c in channel_names(d)]
    columns = [data]
    if d.form == "csv_time":
        columns.insert(0, (np.arange(d.n) / d.fs)[:, None])
        names = ["t [s]", *names]
    header = ",".join(names) if d.form != "csv_plain" else ""
    np.savetxt(path, np.hstack(columns), delimiter=",", fmt="%.10g", header=header, comments="")
    return path


def user_flags(d: Draw) -> list[str]:
    """The flags a user must give for this file (what it cannot state itself)."""
    flags = ["--time-column", "t [s]"] if d.form == "csv_time" else ["--fs", f"{d.fs:g}"]
    if d.input != "rate":
        flags += ["--input", d.input]
    if d.form in ("csv_plain", "npy"):
        flags += ["--units", file_unit(d)[0]]
    return flags


def exact_dominance(model: NoiseModel, d: Draw) -> tuple[dict[str, bool], dict[str, float]]:
    """Where each true term carries more than half of the exact Allan variance of the sum.

    Returns whether it does at some fitted tau, and over how many decades of a dense set of
    taus between the first and last fitted one (-1: nowhere;
    :func:`validate_fit.dominated_decades`). The fitted taus are those of the CLI's default
    grid (log, 100 points) for this record (:func:`validate_fit.fitted_factors`).
    """
    case = vf.Case(d.index, d.terms, d.n, d.fs, "log", "rate", d.unit, d.seed)
    factors = vf.fitted_factors(case)
    tau = factors / d.fs
    comp = {
        s: np.asarray(t.avar(tau, 1.0 / d.fs), dtype=np.float64)
        for s, t in zip(d.terms, model.terms, strict=True)
    }
    total = sum(comp.values())
    dense = vf.dominated_decades(model, vf._fine(factors), d.fs)
    return (
        {s: bool(np.any(c > 0.5 * total)) for s, c in comp.items()},
        dict(zip(d.terms, dense, strict=True)),
    )


def run_cli(argv: list[str]) -> tuple[int, str, str, float]:
    """``allanite ARGV``: exit code, stdout, stderr, seconds."""
    t0 = time.perf_counter()
    proc = vf.run_cli(argv)
    return proc.returncode, proc.stdout, proc.stderr, time.perf_counter() - t0


def score_channel(
    ch: dict[str, Any],
    d: Draw,
    truth: dict[str, float],
    dominance: tuple[dict[str, bool], dict[str, float]],
) -> dict[str, Any]:
    """One channel of ``--json`` against the truth (customary units)."""
    want = customary(d.sensor)
    rows = {r["symbol"]: r for r in ch["coefficients"]}
    upper = {u["symbol"]: u for u in ch.get("undetected", [])}
    # a term left out that the record cannot tell from a fitted one (AMBIGUOUS: its interval
    # from the fit with both)
    swapped = {
        a["symbol_in"]: a
        for a in ch.get("alternatives", [])
        if a["symbol_in"] not in rows and a["symbol_in"] not in upper
    }
    problems: list[str] = []
    expected_rate = d.unit if d.input == "rate" else f"{file_unit(d)[0]}/s"
    if d.unit == "m/s^2" and d.input != "rate":
        expected_rate = "m/s^2"
    if ch["units"] != expected_rate:
        problems.append(f"units {ch['units']!r}, expected {expected_rate!r}")
    for s, r in {**rows, **upper}.items():
        if s in want and r["unit"] != want[s]:
            problems.append(f"{s} in {r['unit']!r}, expected {want[s]!r}")
    terms: dict[str, Any] = {}
    for s, value in truth.items():
        e: dict[str, Any] = {
            "truth": value,
            "dominant": dominance[0][s],
            "dominant_decades": dominance[1][s],
        }
        if s in rows:
            r = rows[s]
            lo, hi = (convert(r[k], r["unit"], want[s]) for k in ("low", "high"))
            v = convert(r["value"], r["unit"], want[s])
            half = (hi - lo) / (2.0 * Z95)
            e.update(
                fitted=True,
                value=v,
                low=lo,
                high=hi,
                covered=bool(lo <= value <= hi),
                ratio=v / value,
                z=(v - value) / half if half > 0 else math.inf,
            )
        elif s in swapped:
            a = swapped[s]
            lo, hi = (convert(a[k], a["unit"], want[s]) for k in ("low", "high"))
            e.update(fitted=False, ambiguous=True, low=lo, high=hi, covered=bool(lo <= value <= hi))
        elif s in upper:
            hi = convert(upper[s]["high"], upper[s]["unit"], want[s])
            e.update(fitted=False, high=hi, covered=bool(value <= hi), ratio_upper=hi / value)
        else:
            e.update(fitted=False, covered=False, unbounded=True)
            problems.append(f"{s} neither fitted nor bounded")
        terms[s] = e
    return {
        "channel": ch["channel"],
        "fitted": list(rows),
        "extra": [s for s in rows if s not in truth],
        "extra_rows": {s: r for s, r in rows.items() if s not in truth},
        "missing_dominant": [s for s in truth if dominance[0][s] and s not in rows],
        "rejected": bool(ch.get("rejected")),
        "p_value": ch.get("p_value"),
        "terms": terms,
        "unit_problems": problems,
        "warnings": ch.get("warnings", []),
    }


def text_agrees(text: str, chans: list[dict[str, Any]]) -> list[str]:
    """Differences between the text output and the JSON (values at 4 digits, units)."""
    out = []
    for ch in chans:
        if f"channel {ch['channel']} (" not in text:
            out.append(f"no text block for channel {ch['channel']}")
        for r in ch["coefficients"]:
            shown = f"{r['symbol']:>6} = {r['value']:.4g} {r['unit']}"
            if shown not in text:
                out.append(f"text lacks {shown.strip()!r}")
    return out


def evaluate(d: Draw, folder: Path) -> dict[str, Any]:
    """Simulate, write, run the CLI as a user does, score."""
    model = model_of(d)
    truth = truth_of(d)
    x = np.asarray(
        model.simulate(
            d.n,
            fs=d.fs,
            output=d.input,
            n_channels=d.axes,
            seed=d.seed,
            flicker_method=vf.FLICKER_METHOD,
        ),
        dtype=np.float64,
    ).reshape(d.n, d.axes)
    path = write_record(d, x, folder)
    del x
    row: dict[str, Any] = {**asdict(d), "truth": truth, "flags": user_flags(d)}
    row["command"] = shlex.join(["allanite", "fit", path.name, *user_flags(d)])
    if d.n <= BARE_MAX:  # what the bare command says: it must name the flag it needs
        code, _, err, _ = run_cli(["fit", str(path)])
        needed = "--time-column" if d.form == "csv_time" else "--fs"
        row["bare"] = {
            "returncode": code,
            "stderr": err.strip()[-600:],
            "names_fix": code == 2 and needed in err,
        }
    code, out, err, seconds = run_cli(["fit", str(path), *user_flags(d), "--json"])
    row.update(returncode=code, stderr=err.strip()[-1500:], cli_s=seconds)
    if code != 0:
        path.unlink()
        row["error"] = err.strip()[-600:]
        return row
    chans = json.loads(out)["channels"]
    dominance = exact_dominance(model, d)
    row["channels"] = [score_channel(ch, d, truth, dominance) for ch in chans]
    if len(chans) != d.axes:
        row["channel_problem"] = f"{len(chans)} channels for {d.axes} axes"
    if d.n <= TEXT_MAX:
        code_t, text, _, _ = run_cli(["fit", str(path), *user_flags(d)])
        row["text_problems"] = text_agrees(text, chans) if code_t == 0 else [f"text exit {code_t}"]
    path.unlink()
    return row


def with_dominance(row: dict[str, Any], grid_seed: int) -> dict[str, Any]:
    """A stored row with the dominance spans (recomputed from its draw: exact, no simulation)."""
    d = draw(row["index"], grid_seed)
    dominant, decades = exact_dominance(model_of(d), d)
    for c in row.get("channels", []):
        for s, e in c["terms"].items():
            e["dominant"], e["dominant_decades"] = dominant[s], decades[s]
    return row


# --- summary ------------------------------------------------------------------------------------
def _cp(k: int, n: int) -> dict[str, Any]:
    if n == 0:
        return {"count": 0, "of": 0}
    rate, lo, hi = clopper_pearson(k, n)
    return {"count": k, "of": n, "fraction": rate, "low": lo, "high": hi}


def _coverage(chans: list[dict[str, Any]]) -> dict[str, Any]:
    """Per symbol: interval coverage (fitted), upper-limit coverage (left out), dominant."""
    out: dict[str, Any] = {}
    for s in "QNBKR":
        entries = [c["terms"][s] for c in chans if s in c["terms"]]
        if not entries:
            continue
        fitted = [e for e in entries if e["fitted"]]
        left = [e for e in entries if not e["fitted"] and not e.get("ambiguous")]
        swapped = [e for e in entries if e.get("ambiguous")]
        dom = [e for e in entries if e["dominant"]]
        clear = [e for e in entries if e["dominant_decades"] >= vf.CLEAR_DECADES]
        out[s] = {
            "interval": _cp(sum(e["covered"] for e in fitted), len(fitted)),
            "upper_limit": _cp(sum(e["covered"] for e in left), len(left)),
            "ambiguous": _cp(sum(e["covered"] for e in swapped), len(swapped)),
            "dominant": _cp(sum(e["covered"] and e["fitted"] for e in dom), len(dom)),
            "clear": _cp(sum(e["covered"] and e["fitted"] for e in clear), len(clear)),
            "all": _cp(sum(e["covered"] for e in entries), len(entries)),
        }
    return out


def _missing_clear(c: dict[str, Any]) -> list[str]:
    """The true terms dominating >= 0.5 decade of the fitted taus that were not fitted."""
    return [
        s
        for s, e in c["terms"].items()
        if e["dominant_decades"] >= vf.CLEAR_DECADES and not e["fitted"]
    ]


def _channel_items(
    records: list[dict[str, Any]], keep: Callable[[dict[str, Any]], Any], **fields: Any
) -> list[dict[str, Any]]:
    """One entry per channel ``keep`` selects: its record, channel and the ``fields`` of it."""
    return [
        {
            "index": r["index"],
            "channel": c["channel"],
            "terms": "+".join(r["terms"]),
            "sensor": r["sensor"],
            "n": r["n"],
            "fitted": c["fitted"],
            **{k: f(c) for k, f in fields.items()},
        }
        for r in records
        for c in r["channels"]
        if keep(c)
    ]


def _ratios(chans: list[dict[str, Any]]) -> dict[str, Any]:
    """Estimate/truth of N, B, K: every fitted one, and those resolved (interval above 0)."""
    out = {}
    for s in "NBK":
        fitted = [c["terms"][s] for c in chans if s in c["terms"] and "ratio" in c["terms"][s]]
        for key, sel in (("fitted", fitted), ("resolved", [e for e in fitted if e["low"] > 0])):
            r = [e["ratio"] for e in sel]
            if r:
                out[f"{s} {key}"] = {
                    "n": len(r),
                    "min": min(r),
                    "median": float(np.median(r)),
                    "max": max(r),
                }
    return out


def _worst(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The record's channel term with the largest |z| (or an uncovered upper limit)."""
    best: dict[str, Any] | None = None
    for r in rows:
        for c in r.get("channels", []):
            for s, e in c["terms"].items():
                bad = abs(e["z"]) if e["fitted"] else (-1.0 if e["covered"] else math.inf)
                if best is None or bad > best["badness"]:
                    best = {
                        "badness": bad,
                        "index": r["index"],
                        "command": r["command"],
                        "sensor": r["sensor"],
                        "truth_terms": "+".join(r["terms"]),
                        "n": r["n"],
                        "fs": r["fs"],
                        "channel": c["channel"],
                        "term": s,
                        **{k: e.get(k) for k in ("truth", "value", "low", "high", "z", "ratio")},
                        "fitted_terms": c["fitted"],
                        "p_value": c["p_value"],
                    }
    return best


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Coverage per class and overall, the worst case per class, every failure listed."""
    ok = [r for r in rows if "channels" in r]
    chans = [c for r in ok for c in r["channels"]]

    def block(sel: list[dict[str, Any]]) -> dict[str, Any]:
        cs = [c for r in sel for c in r.get("channels", [])]
        return {
            "records": len(sel),
            "channels": len(cs),
            "errors": sum("error" in r for r in sel),
            "rejected": _cp(sum(c["rejected"] for c in cs), len(cs)),
            "missing_dominant": sum(bool(c["missing_dominant"]) for c in cs),
            "missing_clear": sum(bool(_missing_clear(c)) for c in cs),
            "extra": sum(bool(c["extra"]) for c in cs),
            "unit_problems": sum(bool(c["unit_problems"]) for c in cs),
            "coverage": _coverage(cs),
            "ratios": _ratios(cs),
            "worst": _worst(sel),
        }

    return {
        "records": len(rows),
        "channels": len(chans),
        "overall": block(rows),
        "per_class": {k: block([r for r in rows if r["sensor"] == k]) for k in CLASSES},
        "failures": {
            "errors": [
                {"index": r["index"], "command": r["command"], "error": r["error"]}
                for r in rows
                if "error" in r
            ],
            "rejected": _channel_items(ok, lambda c: c["rejected"], p=lambda c: c["p_value"]),
            "missing_dominant": _channel_items(
                ok, lambda c: c["missing_dominant"], missing=lambda c: c["missing_dominant"]
            ),
            "missing_clear": _channel_items(ok, _missing_clear, missing=_missing_clear),
            "extra": _channel_items(
                ok, lambda c: c["extra"], extra=lambda c: c["extra"], rows=lambda c: c["extra_rows"]
            ),
            "units": [
                {"index": r["index"], "problems": c["unit_problems"]}
                for r in ok
                for c in r["channels"]
                if c["unit_problems"]
            ],
            "text": [
                {"index": r["index"], "problems": r["text_problems"]}
                for r in ok
                if r.get("text_problems")
            ],
            "bare_without_fix": [
                {"index": r["index"], "form": r["form"], "stderr": r["bare"]["stderr"]}
                for r in rows
                if "bare" in r and not r["bare"]["names_fix"]
            ],
            "uncovered": [
                {
                    "index": r["index"],
                    "sensor": r["sensor"],
                    "channel": c["channel"],
                    "term": s,
                    **{k: e.get(k) for k in ("truth", "value", "low", "high", "z", "fitted")},
                }
                for r in ok
                for c in r["channels"]
                for s, e in c["terms"].items()
                if not e["covered"]
            ],
        },
        "bare_checked": sum("bare" in r for r in rows),
        "text_checked": sum("text_problems" in r for r in rows),
        "cover": {
            k: {
                str(v): sum(str(r[k]) == str(v) for r in rows)
                for v in sorted({str(r[k]) for r in rows})
            }
            for k in ("sensor", "form", "input", "unit", "axes")
        },
        "cli_seconds": {
            "median": float(np.median([r["cli_s"] for r in rows])) if rows else math.nan,
            "max": float(np.max([r["cli_s"] for r in rows])) if rows else math.nan,
        },
    }


def _fmt(c: dict[str, Any]) -> str:
    if not c["of"]:
        return "-"
    pct = f"{100 * c['fraction']:.1f} %, {100 * c['low']:.1f}-{100 * c['high']:.1f}"
    return f"{c['count']}/{c['of']} ({pct})"


def markdown(s: dict[str, Any], command: str) -> str:
    """The summary as a markdown page."""
    lines = [
        f"# audit_default_fit ({s['records']} records, {s['channels']} channels)",
        "",
        f"`{command}`",
        "",
        "Records by "
        + "; ".join(
            f"{k}: " + ", ".join(f"{n} {v}" for v, n in cov.items())
            for k, cov in s["cover"].items()
        ),
        "",
        "| class | records | channels | errors | rejected | dominant missing (>= 0.5 decade) "
        "| extra term | unit problems |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, b in [("all", s["overall"]), *s["per_class"].items()]:
        lines.append(
            f"| {name} | {b['records']} | {b['channels']} | {b['errors']} | "
            f"{b['rejected']['count'] if b['channels'] else 0} | "
            f"{b['missing_dominant']} ({b['missing_clear']}) | "
            f"{b['extra']} | {b['unit_problems']} |"
        )
    lines += [
        "",
        "## 95 % coverage (exact binomial 95 % interval)",
        "",
        "interval: truth inside the reported interval of a fitted term; upper limit: truth below "
        "the reported upper limit of a term left out; ambiguous: truth inside the AMBIGUOUS "
        "interval of a term left out that the record cannot tell from a fitted one; dominant: "
        "a term carrying most of the exact Allan variance at a fitted tau, fitted and covered "
        "(clear: over >= 0.5 decade of the fitted taus); all: any of these.",
        "",
        "| class | term | interval | upper limit | ambiguous | dominant | clear | all |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, b in [("all", s["overall"]), *s["per_class"].items()]:
        for sym, cov in b["coverage"].items():
            lines.append(
                f"| {name} | {sym} | {_fmt(cov['interval'])} | {_fmt(cov['upper_limit'])} | "
                f"{_fmt(cov['ambiguous'])} | "
                f"{_fmt(cov['dominant'])} | {_fmt(cov['clear'])} | {_fmt(cov['all'])} |"
            )
    lines += [
        "",
        "## estimate / truth (customary units; fitted terms, and those whose interval excludes 0)",
        "",
    ]
    lines += ["| class | term | n | min | median | max |", "|---|---|---|---|---|---|"]
    for name, b in [("all", s["overall"]), *s["per_class"].items()]:
        for sym, r in b["ratios"].items():
            lines.append(
                f"| {name} | {sym} | {r['n']} | {r['min']:.3g} | {r['median']:.3g} "
                f"| {r['max']:.3g} |"
            )
    lines += [
        "",
        "## worst case per class (largest |z| of a fitted term, or an uncovered upper limit)",
        "",
    ]
    for name, b in [("all", s["overall"]), *s["per_class"].items()]:
        lines.append(f"- {name}: {json.dumps(b['worst'], default=str)}")
    lines += [
        "",
        f"Text output checked against the JSON on {s['text_checked']} records; the bare "
        f"`allanite fit FILE` on {s['bare_checked']} (must exit 2 naming the missing flag). CLI "
        f"wall time per record: median {s['cli_seconds']['median']:.1f} s, max "
        f"{s['cli_seconds']['max']:.1f} s.",
        "",
        "## failures",
    ]
    for key, items in s["failures"].items():
        lines += ["", f"### {key} ({len(items)})"]
        lines += [f"- {json.dumps(i, default=str)}" for i in items] or ["none"]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Draw, run and score the records; write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=160)
    parser.add_argument("--start", type=int, default=0, help="first record index")
    parser.add_argument("--grid-seed", type=int, default=1010)
    parser.add_argument("--tag", default="fitaudit")
    parser.add_argument("--stop-after", type=float, help="stop after this many seconds")
    parser.add_argument("--summarise", action="store_true", help="only rewrite the summary")
    args = parser.parse_args(argv)
    stem = RESULTS / f"audit_default_fit_{args.tag}"
    command = "python benchmarks/audit_default_fit.py " + " ".join(
        argv if argv is not None else sys.argv[1:]
    )
    if args.summarise:
        stored = json.loads(stem.with_suffix(".json").read_text(encoding="utf-8"))["rows"]
        save(stem, [with_dominance(r, args.grid_seed) for r in stored], command)
        return 0
    rows: list[dict[str, Any]] = []
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="audit_default_fit_") as tmp:
        for i in range(args.start, args.start + args.records):
            d = draw(i, args.grid_seed)
            row = evaluate(d, Path(tmp))
            rows.append(row)
            chans = row.get("channels", [])
            bad = [
                f"{c['channel']}:{s}"
                for c in chans
                for s, e in c["terms"].items()
                if not e["covered"]
            ]
            print(
                f"[{len(rows)}/{args.records}] #{i} {d.sensor:<13} {'+'.join(d.terms):<10} "
                f"n={d.n:<8} fs={d.fs:<6g} {d.input:<9} {d.unit:<6} {d.axes}ax {d.form:<10} -> "
                + (
                    row.get("error", "")[:120]
                    if "error" in row
                    else f"{','.join(chans[0]['fitted'])} rej={sum(c['rejected'] for c in chans)} "
                    f"uncovered={bad} {row['cli_s']:.1f}s"
                ),
                flush=True,
            )
            if len(rows) % 4 == 0:
                save(stem, rows, command)
            if args.stop_after and time.perf_counter() - start > args.stop_after:
                break
    save(stem, rows, command)
    print(markdown(summarise(rows), command))
    return 0


def save(stem: Path, rows: list[dict[str, Any]], command: str) -> None:
    """Write ``stem.json`` (summary and rows) and ``stem.md``."""
    summary = summarise(rows)
    stem.parent.mkdir(parents=True, exist_ok=True)
    stem.with_suffix(".json").write_text(
        json.dumps({"summary": summary, "rows": rows}, indent=1, default=str), encoding="utf-8"
    )
    stem.with_suffix(".md").write_text(markdown(summary, command), encoding="utf-8")


if __name__ == "__main__":
    raise SystemExit(main())
