"""One pass of the three views: features of the real record against the simulated sensor.

The features of the real record and of every Monte Carlo replicate are computed by the same
function (:func:`record_features`), replicate by replicate so that memory stays at one record.
The global p-value is the Bonferroni combination ``min(1, 3 min(p_tau, p_freq, p_time))``
of the three views (each view combines its own statistics the same way), so the false-alarm
rate on a correctly simulated sensor is at most ``alpha``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from allanite.diagnosis.frequency_view import (
    FrequencyView,
    frequency_features,
    frequency_view,
    welch_size,
)
from allanite.diagnosis.inputs import SimSource
from allanite.diagnosis.null import NullEnsemble
from allanite.diagnosis.scaled_null import (
    ReplicateStore,
    piecewise_block_kurtosis,
    piecewise_kurtosis_model,
    scaled_ensemble,
    uses_scaled_null,
)
from allanite.diagnosis.tau_view import (
    TauModel,
    TauView,
    build_tau_model,
    octave_factors,
    tau_features,
    tau_view,
)
from allanite.diagnosis.time_view import (
    TimePlan,
    TimeView,
    kurtosis_blocks,
    time_features,
    time_plan,
    time_view,
)

__all__ = ["Analysis", "Plan", "Progress", "analyze", "record_features"]

Features = dict[str, NDArray[np.float64]]


@dataclass(frozen=True)
class Plan:
    """Analysis layout for records of ``n`` samples at ``fs``."""

    fs: float
    n: int
    m: NDArray[np.int64]
    nperseg: int
    time: TimePlan

    @classmethod
    def for_length(cls, n: int, fs: float) -> Plan:
        """Build the layout for ``n`` samples."""
        return cls(fs=fs, n=n, m=octave_factors(n), nperseg=welch_size(n), time=time_plan(n))


def record_features(x: NDArray[np.float64], plan: Plan) -> Features:
    """All features of one rate record (the same function for real and simulated records)."""
    log_avar = tau_features(x, plan.fs, plan.m)
    feats: Features = {"log_avar": log_avar, "avar_lin": np.exp(log_avar)}
    feats.update(frequency_features(x, plan.fs, plan.nperseg))
    feats.update(time_features(x, plan.time))
    return feats


@dataclass(frozen=True)
class Analysis:
    """The three views of one real record against the simulated sensor."""

    tau: TauView
    frequency: FrequencyView
    time: TimeView
    tau_model: TauModel
    n_null: int

    @property
    def p_value(self) -> float:
        """Bonferroni combination of the three views."""
        return min(1.0, 3.0 * min(self.tau.p_value, self.frequency.p_value, self.time.p_value))


#: a progress callback receives (stage, done, total)
Progress = Callable[[str, int, int], None]


def _features_of(
    records: Iterator[NDArray[np.float64]],
    plan: Plan,
    total: int,
    progress: Progress | None,
    stage: str,
) -> list[Features]:
    out = []
    step = max(1, total // 10)
    for i, r in enumerate(records, start=1):
        out.append(record_features(r, plan))
        if progress is not None and (i % step == 0 or i == total):
            progress(stage, i, total)
    return out


def ensemble(
    source: SimSource,
    plan: Plan,
    n_mc: int,
    seed: int,
    progress: Progress | None = None,
    stage: str = "null replicates",
    store: ReplicateStore | None = None,
) -> NullEnsemble:
    """Null ensemble of ``n_mc`` replicates (``2 n_mc`` for a simulated record).

    A long record against a model gets the null of short and decimated replicates and the
    exact tau covariance instead (:mod:`allanite.diagnosis.scaled_null`); ``store`` keeps
    or shares their blocks (:class:`~allanite.diagnosis.scaled_null.ReplicateStore`).
    """
    if (
        source.kind == "model"
        and uses_scaled_null(source.model, plan.n)
        and piecewise_kurtosis_model(source.model)
    ):
        return scaled_ensemble(
            source.model, plan.n, plan.fs, plan.m, plan.nperseg, plan.time, n_mc, seed,
            progress, stage, store,
        )  # fmt: skip
    if source.kind == "model":
        reps = _features_of(source.replicates(plan.n, n_mc, seed), plan, n_mc, progress, stage)
        return NullEnsemble.from_model(reps)
    assert source.record is not None
    sim = record_features(source.record[: plan.n], plan)
    reps = _features_of(source.replicates(plan.n, 2 * n_mc, seed), plan, 2 * n_mc, progress, stage)
    return NullEnsemble.from_record(sim, reps)


def analyze(
    x: NDArray[np.float64],
    source: SimSource,
    *,
    n_mc: int,
    seed: int,
    alpha: float,
    progress: Progress | None = None,
    stage: str = "null replicates",
    store: ReplicateStore | None = None,
) -> Analysis:
    """Run the three views on the rate record ``x`` (``progress`` reports the replicates).

    ``store`` (long records against a model) keeps the null's replicate blocks, or supplies
    them with added effects (see :func:`ensemble`).
    """
    plan = Plan.for_length(x.size, source.fs)
    ens = ensemble(source, plan, n_mc, seed, progress, stage, store)
    if progress is not None:
        progress("features of the record", 0, 1)
    real = record_features(x, plan)
    if (
        source.kind == "model"
        and uses_scaled_null(source.model, plan.n)
        and piecewise_kurtosis_model(source.model)
    ):
        # the short replicates' 8-sample block kurtosis is matched piece by piece
        blocks = kurtosis_blocks(plan.time)
        real["kurt_lf"] = real["kurt_lf"].copy()
        real["kurt_lf"][0] = piecewise_block_kurtosis(x, blocks[0])
    if progress is not None:
        progress("features of the record", 1, 1)
    tau = plan.m / plan.fs
    tmodel = build_tau_model(
        real, ens, tau, 1.0 / plan.fs, ens.ref["avar_lin"], x.size / plan.fs, loo=not ens.exact_tau
    )
    # localisation thresholds share the Bonferroni budget of the global test, so a reported
    # band, line or segment implies (approximately) a significant global gap
    view_alpha = alpha / 3.0
    return Analysis(
        tau=tau_view(tmodel, ens, view_alpha),
        frequency=frequency_view(x, plan.fs, real, ens, plan.nperseg, view_alpha),
        time=time_view(x, plan.fs, real, ens, plan.time, view_alpha),
        tau_model=tmodel,
        n_null=ens.n_null,
    )
