"""Validation table of the simulator: per term, the 95% chi-square coverage over 50 seeds.

For each term alone and for three mixtures, simulate 50 channels of 2^14 samples at 100 Hz,
estimate the overlapping AVAR on the octave grid up to T/10 and count the (seed, tau) pairs
whose 95% band contains the term's exact sampled AVAR. The band's EDF is the Greenhall-Riley
EDF that allanite.avar attaches, scaled by the model's ratio of the Gaussian to the full
variance of the estimate (``AllanResult.with_model_edf``): one for the Gaussian terms (their
numbers are those of the plain EDF), below one where the fourth cumulants of spikes, bias steps
and telegraph noise add variance (above one for a telegraph signal at tau >> Tc). Also
reported: the coverage with the plain Greenhall EDF, the Monte Carlo z-scores of the mean, the
model's excess/Gaussian variance ratio of the estimate, and the ratio of the variance of the 50
estimates to the variance the corrected EDF implies (mean of ``2 sigma^4 / edf``).

Second table (``estimate_variance``): for spikes, bias steps and telegraph noise, the variance
of the AVAR estimate over 1000 records against the model's prediction (Gaussian part +
excess), with the Monte Carlo standard error of a variance
``sqrt((mu_4 - s^4 (R-3)/(R-1)) / R)``.
Writes ``results/sim_validation.json``. Run: ``python benchmarks/sim_validation.py``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

import allanite
from allanite.model import NoiseModel
from allanite.terms import (
    BiasSteps,
    Flicker,
    GaussMarkov,
    LowPassWhite,
    Quantization,
    RateRandomWalk,
    Sine,
    Spikes,
    Telegraph,
    White,
)

FS, N, CHANNELS = 100.0, 1 << 14, 50
# new cases go at the end: the seed of a case is 1000 + its position
CASES = {
    "white": [White(N=0.01)],
    "quantization": [Quantization(Q=1e-3)],
    "flicker": [Flicker(B=1e-3)],
    "rrw": [RateRandomWalk(K=1e-3)],
    "markov": [GaussMarkov(sigma=0.01, tau_c=0.5)],
    "lowpass_white": [LowPassWhite(N=0.01, bandwidth=2.0)],
    "telegraph": [Telegraph(amplitude=0.01, tau_c=0.3)],
    "bias_steps": [BiasSteps(size=0.01, interval=5.0)],
    "spikes": [Spikes(amplitude=1.0, rate=0.5)],
    "ieee_mix": [Quantization(Q=2e-4), White(N=3e-3), Flicker(B=1e-3), RateRandomWalk(K=2e-4)],
    "markov_sine_mix": [White(N=2e-3), GaussMarkov(sigma=5e-3, tau_c=2.0), Sine(1e-3, 7.0)],
    "transient_mix": [
        White(N=2e-3),
        Telegraph(amplitude=5e-3, tau_c=1.0),
        Spikes(amplitude=0.2, rate=0.5),
    ],
}


def _coverage(result: allanite.AllanResult, theory: np.ndarray, keep: np.ndarray) -> float:
    lo, hi = result.var_ci(0.95)
    return float(((lo[keep] <= theory[:, None]) & (theory[:, None] <= hi[keep])).mean())


def estimate_variance(records: int = 1000) -> dict[str, dict[str, list[float]]]:
    """Monte Carlo variance of the estimate vs the model's Gaussian part + excess."""
    table = {}
    for name in ("telegraph", "bias_steps", "spikes"):
        model = NoiseModel(tuple(CASES[name]))
        blocks = []
        for block in range(records // CHANNELS):
            x = model.simulate(N, fs=FS, n_channels=CHANNELS, seed=2000 + block)
            r = allanite.avar(x, fs=FS, taus="octave", alpha=0)
            blocks.append(r.var)
        keep = r.tau <= N / FS / 10.0
        est = np.concatenate(blocks, axis=1)[keep]
        tau = r.tau[keep]
        gaussian = model.avar_gaussian_variance(tau, 1.0 / FS, N)
        predicted = gaussian + model.avar_excess_variance(tau, 1.0 / FS, N)
        variance = est.var(axis=1, ddof=1)
        mu4 = np.mean((est - est.mean(axis=1, keepdims=True)) ** 4, axis=1)
        n = est.shape[1]
        se = np.sqrt((mu4 - variance**2 * (n - 3) / (n - 1)) / n)
        table[name] = {
            "tau": tau.tolist(),
            "mc_over_predicted": (variance / predicted).round(4).tolist(),
            "z": ((variance - predicted) / se).round(2).tolist(),
            "mc_over_gaussian_part": (variance / gaussian).round(3).tolist(),
        }
        z = np.abs(table[name]["z"]).max()
        print(f"{name:16s} MC/predicted variance of the estimate: max|z| {z:.2f}")
    return table


def main() -> None:
    table: dict[str, object] = {}
    for i, (name, terms) in enumerate(CASES.items()):
        model = NoiseModel(tuple(terms))
        x = model.simulate(N, fs=FS, n_channels=CHANNELS, seed=1000 + i)
        r = allanite.avar(x, fs=FS, taus="octave")
        keep = r.tau <= N / FS / 10.0
        expected = model.avar(r.tau, 1.0 / FS)
        excess = model.avar_excess_variance(r.tau, 1.0 / FS, N)
        corrected = r.with_model_edf(model)
        theory = expected[keep]
        est = r.var[keep]
        z = (est.mean(axis=1) - theory) / (est.std(axis=1, ddof=1) / np.sqrt(CHANNELS))
        implied = np.mean(2.0 * theory[:, None] ** 2 / corrected.edf[keep], axis=1)
        table[name] = {
            "coverage_95": _coverage(corrected, theory, keep),
            "coverage_95_gaussian_edf": _coverage(r, theory, keep),
            "max_abs_z_of_mean": float(np.abs(z).max()),
            "mean_ratio": (est.mean(axis=1) / theory).round(4).tolist(),
            "mc_var_over_edf_var": (est.var(axis=1, ddof=1) / implied).round(3).tolist(),
            "excess_over_gaussian_var": (excess / model.avar_gaussian_variance(r.tau, 1.0 / FS, N))[
                keep
            ]
            .round(3)
            .tolist(),
            "tau": r.tau[keep].tolist(),
        }
        print(
            f"{name:16s} coverage {table[name]['coverage_95']:.3f} "
            f"(Gaussian EDF {table[name]['coverage_95_gaussian_edf']:.3f})  "
            f"max|z| {np.abs(z).max():.2f}"
        )
    table["estimate_variance"] = estimate_variance()
    out = Path(__file__).resolve().parent / "results" / "sim_validation.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(table, indent=1))


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    ).parse_args()  # --help describes the run instead of starting it
    main()
