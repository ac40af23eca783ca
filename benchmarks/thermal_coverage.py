"""Coverage of the thermal sensitivity intervals of ``allanite.fit.thermal`` (issue 29).

Thermal cycles from an independent numpy generator (8 h at 1 Hz; true temperature a 3 h sine
of 8 °C amplitude with a 4 °C rise, read by a sensor quantising to 1/16 °C with 0.02 °C
noise), bias ``c1 x + c2 x^2 + c_rate dT/dt`` of the true temperature, and noise:

* ``white+rrw``: N = 0.01 deg/s*sqrt(s), K = 3e-5 deg/s/sqrt(s) (the model the intervals assume);
* ``white``: N only;
* ``white+flicker``: N and 1/f rate noise B = 1e-3 deg/s (FFT-shaped), which the white +
  random-walk covariance does not model;
* ``null``: white + rrw with c1 = 0 (temperature varies, the sensor is insensitive);
* ``quadratic``: c2 = 5e-4 deg/s/°C^2 on top of c1;
* ``lag``: c_rate = 200 deg/s per °C/s, fitted with ``rate_term=True``.

Per case: the seeds whose 95 % sensitivity interval (``c_rate`` for ``lag``) covers the truth,
the exact (Clopper-Pearson) 95 % interval of that coverage, and how often each degree was
chosen. Usage: ``nice python benchmarks/thermal_coverage.py [--seeds 200]``; results in
``benchmarks/results/thermal_coverage.{json,md}``.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

import allanite
from allanite.fit.thermal import fit_thermal
from allanite.io import Record

RESULTS = Path(__file__).resolve().parent / "results"
C1, C2, LAG = 0.01, 5e-4, 200.0
CASES = ("white+rrw", "white", "white+flicker", "null", "quadratic", "lag")


def _flicker(rng: np.random.Generator, n: int, b: float) -> np.ndarray:
    """1/f rate noise with one-sided PSD B^2/(2 pi f) at 1 Hz (FFT shaping, 2x padded)."""
    m = 2 * n
    f = np.fft.rfftfreq(m, d=1.0)
    amp = np.zeros_like(f)
    amp[1:] = np.sqrt(b**2 / (2 * np.pi * f[1:]))
    spectrum = (rng.normal(size=f.size) + 1j * rng.normal(size=f.size)) * amp
    return np.fft.irfft(spectrum, n=m)[:n] * np.sqrt(m / 2.0)


def record(case: str, seed: int) -> tuple[Record, float]:
    """The case's record and the true value its interval should cover."""
    rng = np.random.default_rng(seed)
    n = 8 * 3600
    t = np.arange(n, dtype=np.float64)
    true_t = 15 + 8 * np.sin(2 * np.pi * t / 10800 + rng.uniform(0, 2 * np.pi)) + 4 * t / t[-1]
    measured = np.round((true_t + rng.normal(0, 0.02, n)) * 16) / 16
    x = true_t - true_t.mean()
    c1 = 0.0 if case == "null" else C1
    y = 0.05 + c1 * x + rng.normal(0, 0.01, n)
    if case == "quadratic":
        y += C2 * x**2
    if case == "lag":
        y += LAG * np.gradient(true_t)
    if case == "white+flicker":
        y += _flicker(rng, n, 1e-3)
    elif case != "white":
        y += np.cumsum(rng.normal(0, 3e-5, n))
    truth = {"null": 0.0, "lag": LAG, "quadratic": C2}.get(case, C1)
    return Record(samples=y, fs=1.0, units="deg/s", temperature=measured), truth


def run_case(case: str, seeds: int) -> dict[str, Any]:
    covered, degrees = 0, []
    for seed in range(seeds):
        rec, truth = record(case, 10_000 + seed)
        if case == "lag":
            (fit,) = fit_thermal(rec, degree=1, rate_term=True, rate_smoothing=120.0)
            lo, hi = fit.coefficients[-1].ci(0.95)
        elif case == "quadratic":
            (fit,) = fit_thermal(rec)
            lo, hi = fit.coefficients[1].ci(0.95) if fit.degree >= 2 else (np.nan, np.nan)
        else:
            (fit,) = fit_thermal(rec)
            lo, hi = fit.sensitivity.ci(0.95)
        covered += bool(lo <= truth <= hi)
        degrees.append(fit.degree)
    low = stats.beta.ppf(0.025, covered, seeds - covered + 1) if covered else 0.0
    high = stats.beta.ppf(0.975, covered + 1, seeds - covered) if covered < seeds else 1.0
    return {
        "case": case,
        "seeds": seeds,
        "covered": covered,
        "coverage": covered / seeds,
        "coverage_ci95": [float(low), float(high)],
        "degrees": {str(d): int(c) for d, c in enumerate(np.bincount(degrees)) if c},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200)
    args = parser.parse_args()
    command = f"nice python benchmarks/thermal_coverage.py --seeds {args.seeds}"
    start = time.time()
    rows = [run_case(case, args.seeds) for case in CASES]
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False
    ).stdout.strip()
    data = {
        "command": command,
        "commit": commit,
        "version": allanite.__version__,
        "machine": f"{platform.machine()} {platform.processor() or ''} {platform.python_version()}",
        "seconds": round(time.time() - start, 1),
        "rows": rows,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "thermal_coverage.json").write_text(json.dumps(data, indent=1) + "\n")
    lines = [
        "# thermal_coverage",
        "",
        f"`{command}` at commit {commit}, allanite {data['version']}, {data['machine']}, "
        f"{data['seconds']} s",
        "",
        "| case | covered | coverage | 95 % interval | degrees chosen |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lo, hi = r["coverage_ci95"]
        degrees = ", ".join(f"{d}: {c}" for d, c in r["degrees"].items())
        lines.append(
            f"| {r['case']} | {r['covered']}/{r['seeds']} | {100 * r['coverage']:.1f} % | "
            f"{100 * lo:.1f}-{100 * hi:.1f} % | {degrees} |"
        )
    (RESULTS / "thermal_coverage.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
