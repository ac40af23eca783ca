"""The default path on every channel of the real-data corpus (issue #27): N against two routes.

For every channel of ``benchmarks/real/manifest.json`` that is readable here (see
``corpus.py``) this runs what a user runs, ``allanite fit FILE --fs FS --units U`` (the Allan
variance on the default log grid, then :func:`allanite.fit` with automatic terms), and
compares its N with two independent routes:

* **PSD plateau**: Welch PSD (scipy, Hann, 2^14-sample segments, linear detrend), averaged in
  log bins (8 per decade); the plateau is the widest run of bins spanning at least half a
  decade whose levels stay within a factor 1.3 (max/min). N = sqrt(S/2) (one-sided PSD
  S = 2 N^2), its interval from the chi-square law of the averaged periodogram (EDF 1.8 per
  segment and frequency, neighbouring frequencies counted 1/1.5 for the Hann window's
  correlation). The roll-off f_c is the first bin above the plateau that falls below half
  its level (else the plateau's top edge, when it ends below 0.9 x Nyquist); the filter's
  time constant is 1/(2 pi f_c).
* **tau-restricted fit**: :func:`allanite.fit` (automatic terms) on the same Allan variance
  kept at tau >= 20 time constants (a first-order filter biases sigma^2 by about 1.5 tau_f/tau,
  under 8 % there); a plateau reaching Nyquist: every tau.

It reports whether the default fit is accepted (chi-square), the filter it found (a model
term whose type names a filter; None while the fit has none), the held-sample items
(:func:`allanite.diagnosis.time_base.held_samples_item` on the whole channel at 0.05, and
those of the diagnosis below) and the false alarms of a half-versus-half diagnosis: the
thermally stable stretch is the record without its first 10 % (the warm-up; the records
carry no temperature), its first half is fitted (the default fit), and
:func:`allanite.diagnose` judges its second half against that model at significance 0.05;
a significant gap is a false alarm (same sensor, same stretch). The summary states the goals
with the WORST channel::

    nice -n 10 python benchmarks/real/run_corpus.py            # ~ a few minutes

Results: benchmarks/results/real_corpus.{json,md} with commit, version, machine, command.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal, stats

sys.path.insert(0, str(Path(__file__).resolve().parent))
import corpus

import allanite
from allanite.diagnosis.time_base import held_samples_item

RESULTS = corpus.REPO / "benchmarks" / "results"
LEVEL = 0.95
SIGNIFICANCE = 0.05
GOAL_N = 0.10
FLAT_RATIO = 1.3
MIN_DECADES = 0.5
TAU_FACTOR = 20.0
WARMUP = 0.10
FILTER_WORDS = ("lowpass", "filter", "bandwidth", "butter", "average", "fir")


def psd_route(x: np.ndarray, fs: float) -> dict[str, Any]:
    """N from the Welch PSD plateau, with its interval, and the roll-off frequency."""
    nperseg = int(min(2**14, 2 ** np.floor(np.log2(x.size / 8))))
    f, p = signal.welch(x, fs=fs, nperseg=nperseg, detrend="linear")
    f, p = f[1:], p[1:]
    edges = 10 ** np.arange(np.log10(4 * f[0]), np.log10(fs / 2), 1 / 8)
    idx = np.digitize(f, edges) - 1
    level = np.array(
        [p[idx == k].mean() if np.any(idx == k) else np.nan for k in range(edges.size - 1)]
    )
    best: tuple[int, int] | None = None
    for i in range(level.size):
        for j in range(i + 1, level.size):
            w = level[i : j + 1]
            if not np.all(np.isfinite(w)) or w.max() / w.min() > FLAT_RATIO:
                break
            span = np.log10(edges[j + 1] / edges[i])
            if span >= MIN_DECADES and (
                best is None or span > np.log10(edges[best[1] + 1] / edges[best[0]])
            ):
                best = (i, j)
    if best is None:
        return {"flat": False, "N": None, "N_ci": None, "band_hz": None, "rolloff_hz": None}
    lo, hi = edges[best[0]], edges[best[1] + 1]
    sel = (f >= lo) & (f < hi)
    s = float(p[sel].mean())
    segments = 2 * x.size / nperseg - 1
    edf = 1.8 * segments * sel.sum() / 1.5
    s_lo, s_hi = s * edf / stats.chi2.ppf([(1 + LEVEL) / 2, (1 - LEVEL) / 2], edf)
    after = np.nonzero(level[best[1] + 1 :] < 0.5 * s)[0]
    rolloff = float(edges[best[1] + 1 + after[0]]) if after.size else None
    return {
        "flat": True,
        "N": float(np.sqrt(s / 2)),
        "N_ci": [float(np.sqrt(s_lo / 2)), float(np.sqrt(s_hi / 2))],
        "band_hz": [float(lo), float(hi)],
        "rolloff_hz": rolloff,
    }


def restrict(result: Any, tau_lo: float) -> Any:
    """The Allan variance kept at tau >= ``tau_lo``."""
    keep = result.tau >= tau_lo
    return replace(
        result,
        tau=result.tau[keep],
        m=result.m[keep],
        var=result.var[keep],
        n_terms=result.n_terms[keep],
        edf=result.edf[keep],
        alpha=result.alpha[keep],
    )


def n_of(fitted: Any) -> dict[str, Any]:
    """N with its interval, accepted or not, terms and the filter term of a fit."""
    coef = fitted.coefficients.get("N")
    terms = [t.type for t in fitted.model.terms]
    filt = [
        t.to_dict() for t in fitted.model.terms if any(w in t.type.lower() for w in FILTER_WORDS)
    ]
    return {
        "N": None if coef is None else float(coef.value),
        "N_ci": None if coef is None else [float(v) for v in coef.ci(LEVEL)],
        "accepted": not bool(fitted.rejected),
        "chi2": float(fitted.chi2),
        "dof": int(fitted.dof),
        "terms": terms,
        "filter": filt[0] if filt else None,
    }


def default_fit(x: np.ndarray, ch: corpus.Channel) -> tuple[Any, Any]:
    """``allanite fit FILE --fs FS --units U``: the log-grid Allan variance and the auto fit."""
    result = allanite.avar(x, fs=ch.fs, taus="log", points=100, units=ch.units)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return result, allanite.fit(result)


def half_versus_half(ch: corpus.Channel, n_mc: int, max_half: int) -> dict[str, Any]:
    """Fit the first half of the stable stretch, diagnose the second half against it.

    Each half is cut to its first ``max_half`` samples (the run-time budget; stated in the
    results).
    """
    x = ch.samples[int(WARMUP * ch.samples.size) :]
    half = min(x.size // 2, max_half)
    _, fitted = default_fit(x[:half], ch)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = allanite.diagnose(
            x[half : 2 * half],
            fitted.model,
            fs=ch.fs,
            units=ch.units,
            n_mc=n_mc,
            significance=SIGNIFICANCE,
            seed=0,
        )
    return {
        "significant": bool(d.significant),
        "p_value": float(d.p_value),
        "closed": bool(d.closed),
        "items": [f"{u.view}:{u.evidence}" for u in d.unexplained],
        "held_items": sum(u.evidence == "held" for u in d.unexplained),
        "headline": d.headline,
    }


def run_channel(ch: corpus.Channel, n_mc: int, max_half: int) -> dict[str, Any]:
    """Every number of one channel."""
    t0 = time.perf_counter()
    x = ch.samples
    result, fitted = default_fit(x, ch)
    psd = psd_route(x, ch.fs)
    tau_lo = float(result.tau[0])
    if psd["flat"]:  # the filter acts from the plateau's top (or its roll-off) up
        edge = psd["rolloff_hz"] or psd["band_hz"][1]
        if edge < 0.9 * ch.fs / 2:
            tau_lo = max(tau_lo, TAU_FACTOR / (2 * np.pi * edge))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            restricted: dict[str, Any] = n_of(allanite.fit(restrict(result, tau_lo)))
    except ValueError as exc:
        restricted = {"N": None, "error": str(exc)}
    held = held_samples_item(x, ch.fs, SIGNIFICANCE)
    out = {
        "channel": ch.label,
        "kind": ch.kind,
        "units": ch.units,
        "classes": list(ch.classes),
        "n_samples": int(x.size),
        "fs": ch.fs,
        "default": n_of(fitted),
        "psd": psd,
        "tau_lo_s": float(tau_lo),
        "restricted": restricted,
        "held_items_record": 0 if held is None else 1,
        "half": half_versus_half(ch, n_mc, max_half),
    }
    out["ratio_default_psd"] = _ratio(out["default"]["N"], psd["N"])
    out["ratio_restricted_psd"] = _ratio(restricted.get("N"), psd["N"])
    out["seconds"] = time.perf_counter() - t0
    return out


def _ratio(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None else float(a / b)


def clopper_pearson(k: int, n: int, level: float = LEVEL) -> list[float]:
    """Exact binomial interval of k/n."""
    a = 1 - level
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(1 - a / 2, k + 1, n - k))
    return [lo, hi]


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The goals, judged on the worst channel."""
    flat = [r for r in rows if r["psd"]["flat"]]
    miss = [r for r in flat if r["ratio_default_psd"] is None]
    errs = [
        (abs(r["ratio_default_psd"] - 1), r["channel"])
        for r in flat
        if r["ratio_default_psd"] is not None
    ]
    worst = max(errs) if errs else None
    within = sum(e <= GOAL_N for e, _ in errs)
    held = sum(r["held_items_record"] + r["half"]["held_items"] for r in rows)
    fa = sum(r["half"]["significant"] for r in rows)
    return {
        "channels": len(rows),
        "flat_plateau_channels": len(flat),
        "n_within_10pct_of_psd": within,
        "n_missing_on_flat": len(miss),
        "worst_n_error": None if worst is None else {"rel_error": worst[0], "channel": worst[1]},
        "goal_n_met": bool(flat) and within == len(flat),
        "held_sample_items": held,
        "goal_held_met": held == 0,
        "false_alarms": fa,
        "false_alarm_rate": fa / len(rows) if rows else None,
        "false_alarm_ci": clopper_pearson(fa, len(rows)) if rows else None,
        "goal_false_alarms_met": bool(rows) and fa / len(rows) <= SIGNIFICANCE,
        "rejected_default_fits": sum(not r["default"]["accepted"] for r in rows),
        "filters_found": sum(r["default"]["filter"] is not None for r in rows),
    }


def provenance(command: list[str], seconds: float) -> dict[str, Any]:
    """Commit, version, machine and command of the run."""
    commit = subprocess.run(
        ["git", "-C", str(corpus.REPO), "rev-parse", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    return {
        "commit": commit,
        "allanite_version": allanite.__version__,
        "machine": (
            f"{platform.node()} {platform.machine()} {os.cpu_count()} cpus, "
            f"Python {platform.python_version()}"
        ),
        "command": " ".join(command),
        "runtime_s": seconds,
    }


def _fmt(v: float | None, spec: str = ".3g") -> str:
    return "—" if v is None else format(v, spec)


def markdown(
    rows: list[dict[str, Any]], summ: dict[str, Any], skipped: list[Any], prov: dict[str, Any]
) -> str:
    """The results table (one line per channel) and the goals on the worst channel."""
    lines = [
        "# Real-data corpus: the default path on real static IMU records (issue #27)",
        "",
        f"commit `{prov['commit']}`, allanite {prov['allanite_version']}, {prov['machine']}; "
        f"command `{prov['command']}`; runtime {prov['runtime_s']:.0f} s.",
        "",
        "N in the channel's unit x sqrt(s) (gyro: deg/s or rad/s x sqrt(s); "
        "accel: m/s^2 x sqrt(s)); "
        "intervals 95 %. PSD = Welch plateau route; tau>= = fit restricted to tau >= 20 filter "
        "time constants; half = half-versus-half diagnosis at 0.05 (FA = significant gap).",
        "",
        "| channel | N default [95 %] | fit | N PSD [95 %] | plateau Hz | roll-off Hz "
        "| N tau>= (fit) | default/PSD | held | half: FA (p) | items |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        d, p, t, h = r["default"], r["psd"], r["restricted"], r["half"]
        dci = "" if d["N_ci"] is None else f" [{d['N_ci'][0]:.3g}, {d['N_ci'][1]:.3g}]"
        pci = "" if p["N_ci"] is None else f" [{p['N_ci'][0]:.3g}, {p['N_ci'][1]:.3g}]"
        band = (
            "no flat plateau" if not p["flat"] else f"{p['band_hz'][0]:.2g}-{p['band_hz'][1]:.2g}"
        )
        fit_word = ("accepted" if d["accepted"] else "REJECTED") + f" {'+'.join(d['terms'])}"
        tfit = "" if "accepted" not in t else (" acc" if t["accepted"] else " REJ")
        lines.append(
            f"| {r['channel']} | {_fmt(d['N'])}{dci} | {fit_word} | {_fmt(p['N'])}{pci} | {band} | "
            f"{_fmt(p['rolloff_hz'])} | {_fmt(t.get('N'))}{tfit} | "
            f"{_fmt(r['ratio_default_psd'])} | "
            f"{r['held_items_record'] + h['held_items']} | {'yes' if h['significant'] else 'no'} "
            f"({h['p_value']:.2g}) | {', '.join(h['items']) or '—'} |"
        )
    s = summ
    worst = s["worst_n_error"]
    lines += [
        "",
        "## Goals (worst case)",
        "",
        f"- N within 10 % of the PSD route on every channel with a flat plateau: "
        f"{s['n_within_10pct_of_psd']}/{s['flat_plateau_channels']} "
        f"({s['n_missing_on_flat']} with no N); worst "
        + ("—" if worst is None else f"{100 * worst['rel_error']:.0f} % ({worst['channel']})")
        + f" — {'MET' if s['goal_n_met'] else 'NOT MET'}",
        f"- false held-sample items: {s['held_sample_items']} — "
        f"{'MET' if s['goal_held_met'] else 'NOT MET'}",
        f"- half-versus-half false alarms at 0.05: {s['false_alarms']}/{s['channels']} = "
        f"{_fmt(s['false_alarm_rate'], '.3f')} "
        f"[{s['false_alarm_ci'][0]:.3f}, {s['false_alarm_ci'][1]:.3f}] "
        f"— {'MET' if s['goal_false_alarms_met'] else 'NOT MET'} (goal <= 0.05)",
        f"- default fits rejected: {s['rejected_default_fits']}/{s['channels']}; "
        f"filters found: {s['filters_found']}/{s['channels']}",
        "",
        "Skipped records (fetch step in benchmarks/real/manifest.json):",
        "",
    ]
    lines += [f"- {rid}: {why}" for rid, why in skipped] or ["- none"]
    return "\n".join(lines) + "\n"


def _write(
    out: Path, rows: list[dict[str, Any]], skipped: list[Any], t0: float, argv: list[str] | None
) -> str:
    """Write the JSON and markdown results; return the markdown."""
    summ = summary(rows)
    given = sys.argv[1:] if argv is None else argv
    prov = provenance(["python", "benchmarks/real/run_corpus.py", *given], time.perf_counter() - t0)
    out.parent.mkdir(parents=True, exist_ok=True)
    payload = {"provenance": prov, "summary": summ, "skipped": skipped, "channels": rows}
    out.with_suffix(".json").write_text(json.dumps(payload, indent=1) + "\n", encoding="utf-8")
    text = markdown(rows, summ, skipped, prov)
    out.with_suffix(".md").write_text(text, encoding="utf-8")
    return text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--n-mc",
        type=int,
        default=50,
        help="diagnosis Monte Carlo size (default 50, the time budget)",
    )
    parser.add_argument(
        "--max-half",
        type=int,
        default=2**16,
        help="samples per half of the half-versus-half diagnosis (default 2^16, the time budget)",
    )
    parser.add_argument("--only", help="run only channels whose label contains this text")
    parser.add_argument("--out", type=Path, default=RESULTS / "real_corpus", help="results stem")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    skipped: list[tuple[str, str]] = []
    rows = []
    for ch in corpus.channels(skipped=skipped):
        if args.only and args.only not in ch.label:
            continue
        row = run_channel(ch, args.n_mc, args.max_half)
        rows.append(row)
        _write(args.out, rows, skipped, t0, argv)  # after every channel: a partial run is kept
        print(
            f"{row['channel']}: N default {_fmt(row['default']['N'])} "
            f"({'acc' if row['default']['accepted'] else 'REJ'}), PSD {_fmt(row['psd']['N'])}, "
            f"tau>= {_fmt(row['restricted'].get('N'))}, half FA {row['half']['significant']} "
            f"[{row['seconds']:.0f} s]",
            flush=True,
        )
    print(_write(args.out, rows, skipped, t0, argv))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
