"""Kasdin flicker: exact-law tables, 95% chi-square coverage, the long-record plateau, timing.

* ``departure``: the stationary Kasdin Allan variance (:func:`kasdin_avar`) against the
  flicker term's band-limited sampled AVAR at tau = 1, 2, 4, 10, 100, 1000 dt.
* ``truncation``: the zero-history record law against the stationary one at T/100 and T/10.
* ``coverage``: for 10 seeds, 50 channels of 2^14 samples at 100 Hz (``flicker_method=
  "kasdin"``), octave taus up to T/10: the share of (channel, tau) pairs whose 95% band (EDF
  from allanite.avar) contains the record's exact law, and, for contrast, the term's AVAR.
* ``plateau``: 4 channels of 2^21 samples, 16 taus from 10 dt to 2e5 dt: the pooled Allan
  variance over the 0.664 B plateau with its 99% chi-square band.
* ``timing_s``: one synthesis of 2^21 samples x 1 channel, kasdin and spectral (wall clock,
  machine shared, informative only).

Writes ``results/sim_kasdin.json``. Run: ``python benchmarks/sim_kasdin.py``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
from scipy import stats

import allanite
from allanite.simulation import simulate
from allanite.simulation.flicker import flicker_stream
from allanite.terms import Flicker
from allanite.terms.flicker import PLATEAU
from allanite.terms.flicker_laws import kasdin_avar

FS, B = 100.0, 1e-3
DT = 1.0 / FS


def departure() -> list[dict[str, float]]:
    m = np.array([1, 2, 4, 10, 100, 1000])
    kasdin = kasdin_avar(m * DT, DT, 1.0)
    term = Flicker(B=1.0).avar(m * DT, DT)
    return [
        {"m": int(k), "kasdin_avar_per_B2": float(a), "term_avar_per_B2": float(b),
         "ratio": float(a / b)}
        for k, a, b in zip(m, kasdin, term, strict=True)
    ]  # fmt: skip


def truncation() -> list[dict[str, float]]:
    rows = []
    for n in (1 << 14, 1 << 21):
        m = np.array([n // 100, n // 10])
        ratio = kasdin_avar(m * DT, DT, 1.0, n_samples=n) / kasdin_avar(m * DT, DT, 1.0)
        rows += [
            {"n_samples": n, "m": int(k), "record_over_stationary": float(r)}
            for k, r in zip(m, ratio, strict=True)
        ]
    return rows


def coverage(seeds: range = range(10), n: int = 1 << 14, channels: int = 50) -> dict[str, object]:
    own, term_law = [], []
    for seed in seeds:
        x = simulate(
            [Flicker(B=B)], n, fs=FS, n_channels=channels, seed=seed, flicker_method="kasdin"
        )
        r = allanite.avar(x, fs=FS, taus="octave")
        keep = r.tau <= n * DT / 10.0
        lo, hi = r.var_ci(0.95)
        for theory, out in (
            (kasdin_avar(r.tau[keep], DT, B, n_samples=n), own),
            (Flicker(B=B).avar(r.tau[keep], DT), term_law),
        ):
            inside = (lo[keep] <= theory[:, None]) & (theory[:, None] <= hi[keep])
            out.append(float(inside.mean()))
    return {
        "n_samples": n,
        "channels": channels,
        "seeds": list(seeds),
        "against_kasdin_avar": own,
        "against_term_avar": term_law,
        "mean_against_kasdin_avar": float(np.mean(own)),
        "mean_against_term_avar": float(np.mean(term_law)),
    }


def plateau(n: int = 1 << 21, channels: int = 4) -> list[dict[str, float]]:
    stream = flicker_stream(Flicker(B=B), FS, channels, seed=77, n_samples=n, method="kasdin")
    x = stream.next(n)
    m = np.unique(np.round(np.logspace(1, np.log10(2e5), 16))).astype(np.int64)
    r = allanite.avar(x, fs=FS, m=m, alpha=-1)
    edf = r.edf.sum(axis=1)
    pooled = (r.var * r.edf).sum(axis=1) / edf
    lo = pooled * edf / stats.chi2.ppf(0.995, edf)
    hi = pooled * edf / stats.chi2.ppf(0.005, edf)
    exact = kasdin_avar(r.tau, DT, B, n_samples=n)
    level = PLATEAU * B**2
    return [
        {"tau_s": float(t), "m": int(k), "edf": float(e),
         "pooled_over_plateau": float(p / level), "band99_over_plateau": [a / level, b / level],
         "exact_over_plateau": float(v / level), "plateau_in_band": bool(a <= level <= b)}
        for t, k, e, p, a, b, v in zip(r.tau, m, edf, pooled, lo, hi, exact, strict=True)
    ]  # fmt: skip


def timing(n: int = 1 << 21) -> dict[str, float]:
    out = {}
    for method in ("kasdin", "spectral"):
        start = time.perf_counter()
        flicker_stream(Flicker(B=B), FS, 1, seed=1, n_samples=n, method=method).next(n)
        out[method] = time.perf_counter() - start
    return out


def main() -> None:
    table = {
        "departure": departure(),
        "truncation": truncation(),
        "coverage": coverage(),
        "plateau": plateau(),
        "timing_s": timing(),
    }
    out = Path(__file__).resolve().parent / "results" / "sim_kasdin.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(table, indent=1) + "\n")
    print(json.dumps(table, indent=1))


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    ).parse_args()  # --help describes the run instead of starting it
    main()
