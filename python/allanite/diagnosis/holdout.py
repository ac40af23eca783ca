"""Held-out check: carry the best effect's fitted parameters to data it was not fitted on.

The held-out data is either the end of the real record (``holdout=`` a fraction) or a second
real record. Only the tau view is needed: its Monte Carlo null is rebuilt for the held-out
length, and the shrinkage ``1 - G_after / G_before`` is measured there with the parameters
fitted in-sample. A close agreement with the in-sample shrinkage shows that the added effect
generalises instead of fitting the noise of one record.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from allanite.diagnosis.attribution import Attribution
from allanite.diagnosis.candidates import Candidate
from allanite.diagnosis.inputs import SimSource
from allanite.diagnosis.null import NullEnsemble
from allanite.diagnosis.result import Holdout
from allanite.diagnosis.scaled_null import uses_scaled_null
from allanite.diagnosis.tau_view import (
    TauModel,
    build_tau_model,
    gaussian_tau_null,
    octave_factors,
    tau_features,
)

__all__ = ["holdout_check", "holdout_set", "tau_model_for"]


def tau_model_for(x: NDArray[np.float64], source: SimSource, *, n_mc: int, seed: int) -> TauModel:
    """Build the tau view alone (cheaper than the full analysis) of ``x`` against ``source``."""
    fs = source.fs
    m = octave_factors(x.size)

    def feats(r: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        la = tau_features(r, fs, m)
        return {"log_avar": la, "avar_lin": np.exp(la)}

    if source.kind == "model" and uses_scaled_null(source.model, x.size):
        # a long record: the exact Gaussian AVAR covariance, no replicate
        ref, avar, draws = gaussian_tau_null(
            source.model, m, fs, x.size, n_draw=max(4000, 20 * n_mc), seed=seed
        )
        ens = NullEnsemble(
            ref={"log_avar": ref, "avar_lin": avar}, null={"log_avar": draws}, real_scale=1.0,
            exact_tau=True,
        )  # fmt: skip
        return build_tau_model(feats(x), ens, m / fs, 1.0 / fs, avar, x.size / fs, loo=False)
    if source.kind == "model":
        ens = NullEnsemble.from_model([feats(r) for r in source.replicates(x.size, n_mc, seed)])
    else:
        assert source.record is not None
        reps = [feats(r) for r in source.replicates(x.size, 2 * n_mc, seed)]
        ens = NullEnsemble.from_record(feats(source.record[: x.size]), reps)
    return build_tau_model(feats(x), ens, m / fs, 1.0 / fs, ens.ref["avar_lin"], x.size / fs)


def holdout_check(
    best: Attribution,
    cand: Candidate,
    x_hold: NDArray[np.float64],
    source: SimSource,
    *,
    n_mc: int,
    seed: int,
    alpha: float,
    kind: str,
    tm: TauModel | None = None,
) -> Holdout:
    """Shrinkage of ``best`` (fitted in-sample) on the held-out record ``x_hold``.

    ``tm`` is the held-out tau model when already built (:func:`tau_model_for`).
    """
    if tm is None:
        tm = tau_model_for(x_hold, source, n_mc=n_mc, seed=seed)
    values = {n: best.params[n] for n in cand.free}
    extra = np.asarray(cand.extra_avar(values, tm.tau, tm.dt), dtype=np.float64)
    g_before, g_after = tm.gap(), tm.gap(extra)
    return Holdout(
        effect=best.effect,
        shrinkage=float(1.0 - g_after / g_before) if g_before > 0 else 0.0,
        gap_before=g_before,
        gap_after=g_after,
        consistent_after=bool(tm.p_value(extra) > alpha),
        n_samples=int(x_hold.size),
        source=kind,
    )


def holdout_set(
    effects: list[tuple[Attribution, Candidate]], tm: TauModel, *, alpha: float, kind: str
) -> dict[str, float | bool | str | int | list[str]]:
    """Held-out check of a set of effects: their Allan variances add on the held-out data."""
    extra = np.zeros_like(tm.tau)
    added = []
    for a, c in effects:
        values = {n: a.params[n] for n in c.free}
        extra = extra + np.asarray(c.extra_avar(values, tm.tau, tm.dt), dtype=np.float64)
        added.append(c.added_term(values))
    g_before, g_after = tm.gap(), tm.gap(extra)
    return {
        "effects": [a.effect for a, _ in effects],
        "shrinkage": float(1.0 - g_after / g_before) if g_before > 0 else 0.0,
        "gap_before": g_before,
        "gap_after": g_after,
        "consistent_after": bool(tm.holding(added).p_value(extra) > alpha),
        "n_samples": round(tm.duration / tm.dt),
        "source": kind,
    }
