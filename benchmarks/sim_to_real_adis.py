"""The original synthesis procedure on real data: ADIS16405 run 1 -> model -> simulated twin.

Fit a noise model to the real gyro X record (100 Hz, 1e6 samples, deg/s), simulate a record
of the same length from it, and compare both overlapping Allan deviations with the real
curve's confidence band. Writes ``results/sim_to_real_adis.png`` and ``.json``.

The fit is a clearly labelled SIMPLE STAND-IN (``simple_fit``) until ``allanite.fit`` lands:
non-negative least squares of the Allan variance on the exact sampled curves of a dictionary
of terms (Q, N, B, K, R plus Gauss-Markov and low-pass white families on log grids of their
time constants), each tau weighted by its relative uncertainty sqrt(2/edf); it ignores the
correlation between taus, so it is a point estimate without honest uncertainty.

Run: ``python benchmarks/sim_to_real_adis.py`` (needs ../shared/data and matplotlib).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import nnls

import allanite
from allanite.model import NoiseModel
from allanite.terms import (
    Flicker,
    GaussMarkov,
    LowPassWhite,
    Quantization,
    RateRamp,
    RateRandomWalk,
    Term,
    White,
)

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "imu" / "adis16405" / "run1.npz"
RESULTS = Path(__file__).resolve().parent / "results"
FS = 100.0
LSB = 0.05  # deg/s per count
SEED = 16405
IEEE = (Quantization(Q=1.0), White(N=1.0), Flicker(B=1.0), RateRandomWalk(K=1.0), RateRamp(R=1.0))


def load_gyro_x(path: Path = DATA) -> np.ndarray:
    """Gyro X rate of run 1 in deg/s."""
    with np.load(path) as data:
        return data["gyro_counts"][:, 0].astype(np.float64) * LSB


def _basis() -> list[Term]:
    """Unit-coefficient candidate terms: the five IEEE terms, Gauss-Markov and low-pass white
    families on log grids of their time constants (NNLS picks the few that are needed)."""
    grid: list[Term] = list(IEEE)
    grid += [GaussMarkov(sigma=1.0, tau_c=float(tc)) for tc in np.logspace(-2, 3, 21)]
    grid += [LowPassWhite(N=1.0, bandwidth=float(bw)) for bw in np.logspace(0, 2, 9)]
    return grid


def simple_fit(result: allanite.AllanResult) -> NoiseModel:
    """SIMPLE STAND-IN FIT: relative-error-weighted NNLS of AVAR on a dictionary of terms."""
    dt = 1.0 / result.fs
    keep = result.tau <= result.n_samples * dt / 10.0
    tau, var = result.tau[keep], result.var[keep]
    weight = 1.0 / (var * np.sqrt(2.0 / result.edf[keep]))
    basis = _basis()
    design = np.column_stack([t.avar(tau, dt) for t in basis]) * weight[:, None]
    coef, _ = nnls(design, var * weight, maxiter=50 * len(basis))
    terms = []
    for unit, c in zip(basis, coef, strict=True):
        if c > 0:
            symbol = unit.params[0].name
            terms.append(unit.with_values(**{symbol: float(np.sqrt(c))}))
    return NoiseModel(tuple(terms), {"rate": "deg/s", "time": "s"})


def compare(x: np.ndarray, *, seed: int = SEED, level_fit: float = 0.683, level: float = 0.99):
    """Real and simulated Allan variances, the fitted model and the comparison masks."""
    real = allanite.avar(x, FS, taus="octave")
    model = simple_fit(real)
    sim_x = model.simulate(x.size, FS, seed=seed)
    sim = allanite.avar(sim_x, FS, m=real.m)
    dt = 1.0 / FS
    keep = real.tau <= x.size * dt / 10.0
    theory = model.avar(real.tau, dt)
    lo_fit, hi_fit = real.var_ci(level_fit)
    good = keep & (lo_fit <= theory) & (theory <= hi_fit)
    lo, hi = real.var_ci(level)
    inside = (lo <= sim.var) & (sim.var <= hi)
    return real, sim, model, good, inside


def main() -> int:
    if not DATA.exists():
        print(f"reference data {DATA} not found", file=sys.stderr)
        return 1
    real, sim, model, good, inside = compare(load_gyro_x())
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lo, hi = real.ci(0.99)
    fig, ax = plt.subplots(figsize=(7, 5))
    ax.fill_between(real.tau, lo, hi, color="C0", alpha=0.25, label="real, 99% band")
    ax.loglog(real.tau, real.dev, "o-", color="C0", label="ADIS16405 run 1, gyro X")
    ax.loglog(sim.tau, sim.dev, "s--", color="C1", label="simulated from the fitted model")
    ax.loglog(real.tau, np.sqrt(model.avar(real.tau, 1.0 / FS)), "k:", label="model (simple fit)")
    ax.plot(real.tau[good], real.dev[good], "k|", ms=14, label="fit good here")
    ax.set_xlabel("tau [s]")
    ax.set_ylabel("Allan deviation [deg/s]")
    ax.set_title("Original synthesis procedure on real data (simple stand-in fit)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    RESULTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(RESULTS / "sim_to_real_adis.png", dpi=120, bbox_inches="tight")
    summary = {
        "fit": "simple stand-in: EDF-weighted NNLS on a term dictionary (not allanite.fit)",
        "model": model.to_dict(),
        "tau": real.tau.tolist(),
        "adev_real": real.dev.tolist(),
        "adev_sim": sim.dev.tolist(),
        "fit_good": good.tolist(),
        "sim_inside_real_99": inside.tolist(),
        "all_inside_where_fit_good": bool(np.all(inside[good])),
    }
    (RESULTS / "sim_to_real_adis.json").write_text(json.dumps(summary, indent=1))
    print(json.dumps({k: summary[k] for k in ("model", "all_inside_where_fit_good")}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
