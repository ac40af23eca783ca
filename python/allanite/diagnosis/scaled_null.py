r"""The null of a long record without full-length Monte Carlo replicates.

The replicate null (:func:`allanite.diagnosis.analysis.ensemble`) simulates ``n_mc`` records
of the real length ``N``: its cost grows with ``n_mc x N``. For a model and a record longer
than :data:`FULL_REPLICATES_MAX` samples, each view gets a null whose cost does not depend on
``N``:

* tau view: no replicate at all, draws from the model's exact Gaussian AVAR covariance
  (:func:`allanite.diagnosis.tau_view.gaussian_tau_null`);
* frequency view and the sample-scale statistics of the time view (``hf``, ``spike``,
  ``tail``, ``kurt_hf``, ``kurt_lf`` over 8 samples): ``n_mc`` *short* replicates at the real
  rate, of :data:`SHORT_LENGTH` samples, with the same Welch segment length and 32 windows; a
  feature that is a mean over ``k`` pieces (segments, differences) has its null residuals scaled by
  ``sqrt(k_short / k)`` and its log-of-mean bias moved (:func:`allanite.diagnosis.null.rescaled`;
  the Welch log PSD is mapped quantile by quantile between log-gamma laws, which also moves
  its skewness: :func:`allanite.diagnosis.null.rescaled_log_gamma`); the 8-sample block
  kurtosis of the record is taken piece by piece, pieces of a short replicate's length
  (:func:`piecewise_block_kurtosis`: over the whole record the block means carry a ramp's or a
  random walk's whole span, which no short replicate holds), unless the model has a level
  profile, which the short replicates hold compressed whole;
  the spike statistic needs no rescaling: the short replicates' pooled per-sample exceedance
  rate, times ``N``, is the Poisson mean of the long record's exceedances
  (:class:`allanite.diagnosis.null.ExceedanceTail`);
* the reference of the Welch features (``log_psd``, ``log_line_psd``): the mean over the
  ``n_mc`` short replicates has an error that adds ``var_s / (n_mc var_N) ~ (N / N_short) /
  n_mc`` to the variance of a long record's log-PSD bin (40 % at 1e7 samples with
  ``n_mc = 200``, 4x at 1e8): as many more short replicates as bring that share down to
  :data:`REFERENCE_SHARE` are simulated for the reference alone (Welch features only, about
  ``N / (REFERENCE_SHARE N_short)`` in all, :func:`reference_replicates`);
* window-scale statistics of the time view (``level``, ``jump``, ``dyn``, ``kurt_lf`` over
  ``L/16`` and ``L/4`` samples): ``n_mc`` *decimated* replicates, the model simulated over the
  real duration at the rate ``fs / D`` (``N / D`` ~ 2^16 samples,
  :mod:`allanite.diagnosis.decimation`). Means over a
  time ``tau`` of white, flicker and random-walk noise, angle quantization, ramps and slow
  processes do not depend on the sampling rate once ``tau >> D / fs``; a term with a time
  scale shorter than ``5 D / fs`` (a line, a fast Markov or telegraph process, short bursts)
  lowers ``D`` until it is resolved, and spikes (whose block-mean contribution is ``D`` times
  larger at the coarse rate) keep ``D = 1``.

A term whose noise level follows a profile over the record (a ``variance_scale(t)``:
:class:`allanite.terms.WhiteDrift`) is simulated in the short replicates with its profile
compressed onto their time axis (every time parameter, all on the record's timeline, times
``N_short / N``; :func:`short_model`): window ``w`` of a short replicate then holds the level of
window ``w`` of the record, and the replicate's spectrum, kurtosis and spikes are those of the
whole record's level mixture. The decimated replicates span the real duration and need no
change.

A model with a warm-up (a transient at the start, which a short replicate would show over a
far larger share of its length) keeps the full-length replicate null.

The re-analysis after effects are added (:func:`allanite.diagnosis.engine.diagnose`) needs the
null of the model *with* the effects. An added effect is a process independent of the
sensor's, so a replicate of the augmented model is a replicate of the model plus one of the
effects: a :class:`ReplicateStore` keeps the null's replicate blocks (up to
:data:`SHARED_BYTES`) and the re-analysis adds the effects' own streams to them, simulating
only those (:meth:`ReplicateStore.adding`). A block not kept is simulated again from its seed,
so the result is the same whatever the budget and the number of threads.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.diagnosis.decimation import decimation
from allanite.diagnosis.frequency_view import frequency_features
from allanite.diagnosis.inputs import simulate_model
from allanite.diagnosis.null import (
    NullEnsemble,
    level_profiled,
    rescaled,
    rescaled_log_gamma,
)
from allanite.diagnosis.tau_view import gaussian_tau_null
from allanite.diagnosis.time_view import (
    SPIKE_POOLED,
    TimePlan,
    block_kurtosis,
    kurtosis_blocks,
    time_features,
    time_plan,
)

__all__ = [
    "FULL_REPLICATES_MAX",
    "REFERENCE_SHARE",
    "SHARED_BYTES",
    "SHORT_LENGTH",
    "ReplicateStore",
    "piecewise_block_kurtosis",
    "piecewise_kurtosis_model",
    "reference_replicates",
    "scaled_ensemble",
    "short_model",
    "uses_scaled_null",
]

#: records up to this length keep the full-length replicate null (it is cheap there)
FULL_REPLICATES_MAX = 2**18
#: length of the short replicates at the real rate (63 Welch segments of 4096 samples)
SHORT_LENGTH = 2**17
#: the reference of the Welch features adds at most this share to a log-PSD bin's variance
REFERENCE_SHARE = 0.2
#: effects tied to the start of the record: no short replicate can stand for them
START_TERMS = ("warmup",)
#: threads simulating replicate batches (the results do not depend on it)
WORKERS = min(4, os.cpu_count() or 1)

#: memory the null's replicate blocks may keep for the re-analysis (bytes)
SHARED_BYTES = 2**30
#: seed offset of the added effects' streams in a re-analysis
ADDED_SEED = 2_000_003

Features = dict[str, NDArray[np.float64]]
Progress = Callable[[str, int, int], None]
#: ``simulate(n, fs, seed, k)``: ``k`` replicates of ``n`` samples as an ``(n, k)`` array
Simulate = Callable[[int, float, int, int], NDArray[np.float64]]


class ReplicateStore:
    """The null's replicate blocks of ``model``, kept for a re-analysis that adds effects.

    ``ReplicateStore(model)`` is given to the null (:func:`scaled_ensemble`), which keeps the
    blocks it simulates while they fit in ``budget`` bytes. ``store.adding(added)`` is the
    source of the re-analysis: each block is the kept (or, beyond the budget, re-simulated)
    block of ``model`` with the same seed plus a block of ``added`` (a NoiseModel of the
    effects' independent processes, seeded ``ADDED_SEED`` further on), i.e. a replicate of
    the model with the effects.

    Parameters
    ----------
    model : NoiseModel
        The simulated sensor of the null.
    budget : int, optional
        Bytes of replicate blocks kept (default :data:`SHARED_BYTES`; 0 keeps none).
    """

    def __init__(self, model: Any, budget: int | None = None) -> None:
        budget = SHARED_BYTES if budget is None else budget
        if budget < 0:
            raise ValueError(f"budget must be >= 0 bytes, got {budget}")
        self.model = model
        self.added: Any = None
        self.budget = int(budget)
        self._blocks: dict[tuple[Any, ...], NDArray[np.float64]] = {}
        self._used = 0
        self._lock = threading.Lock()

    def adding(self, added: Any) -> ReplicateStore:
        """The same blocks with the independent streams of ``added`` on top (re-analysis)."""
        view = ReplicateStore.__new__(ReplicateStore)
        view.__dict__.update(self.__dict__)
        view.added = added
        return view

    def release(self) -> None:
        """Drop the kept blocks (the re-analysis is done, or there is none)."""
        with self._lock:
            self._blocks.clear()
            self._used = 0

    @property
    def kept_bytes(self) -> int:
        """Bytes of replicate blocks kept."""
        return self._used

    def _block(self, model: Any, n: int, fs: float, seed: int, k: int) -> NDArray[np.float64]:
        key = (repr(model.terms), n, float(fs), seed, k)
        with self._lock:
            hit = self._blocks.get(key)
        if hit is not None:
            return hit
        block = simulate_model(model, n, fs, seed, n_channels=k)
        if self.added is None:  # only the null's own blocks are kept
            with self._lock:
                if self._used + block.nbytes <= self.budget:
                    self._blocks[key] = block
                    self._used += block.nbytes
        return block

    def simulator(self, transform: Callable[[Any], Any]) -> Simulate:
        """Replicate blocks of ``transform(model)`` (plus ``transform(added)``, if any)."""
        base = transform(self.model)
        extra = transform(self.added) if self.added is not None else None

        def simulate(n: int, fs: float, seed: int, k: int) -> NDArray[np.float64]:
            block = self._block(base, n, fs, seed, k)
            if extra is None:
                return block
            more = simulate_model(extra, n, fs, seed + ADDED_SEED, n_channels=k)
            return np.asarray(block + more, dtype=np.float64)

        return simulate


def _simulator(
    model: Any, store: ReplicateStore | None, transform: Callable[[Any], Any]
) -> Simulate:
    """Replicate blocks of ``transform(model)``, through ``store`` when there is one."""
    if store is not None:
        return store.simulator(transform)
    target = transform(model)

    def simulate(n: int, fs: float, seed: int, k: int) -> NDArray[np.float64]:
        return simulate_model(target, n, fs, seed, n_channels=k)

    return simulate


def short_model(model: Any, n: int) -> Any:
    """``model`` for the short replicates of an ``n``-sample record (see the module docstring).

    Terms with a level profile over the record (non-stationary, with ``variance_scale``) get
    their time parameters times ``SHORT_LENGTH / n``; the model is returned unchanged when
    it has none.
    """
    factor = SHORT_LENGTH / n
    terms = []
    for t in model.terms:
        if level_profiled(t):
            times = {p.name: factor * float(getattr(t, p.name)) for p in t.params if p.time == 1}
            t = t.with_values(**times)
        terms.append(t)
    if all(a is b for a, b in zip(terms, model.terms, strict=True)):
        return model
    return replace(model, terms=tuple(terms))


def uses_scaled_null(model: Any, n: int) -> bool:
    """Whether a record of ``n`` samples against ``model`` gets the scaled null."""
    if model is None or n <= FULL_REPLICATES_MAX:
        return False
    return not any(getattr(t, "type", "") in START_TERMS for t in model.terms)


def _replicates(
    simulate: Simulate,
    n: int,
    fs: float,
    count: int,
    seed: int,
    features: Callable[[NDArray[np.float64]], Features],
    progress: Progress | None,
    stage: str,
    done0: int,
    total: int,
) -> Iterator[Features]:
    """Features of ``count`` replicates of ``n`` samples, simulated in batches of channels.

    Batch ``b`` starting at replicate ``i`` is seeded ``seed + i`` whatever the thread that
    runs it, and the results are collected in replicate order, so the ensemble is the same for
    any number of :data:`WORKERS` (the simulation and the features release the GIL in numpy
    and scipy, which is where the time goes). They are yielded as their batch completes, so a
    caller that sums them holds only the batches in flight.
    """
    batch = int(max(1, min(count, 2**22 // n)))
    step = max(1, total // 10)
    starts = list(range(0, count, batch))

    def run(start: int) -> list[Features]:
        k = min(batch, count - start)
        block = simulate(n, fs, seed + start, k)
        return [features(np.ascontiguousarray(block[:, j])) for j in range(k)]

    done_count = 0
    workers = min(WORKERS, len(starts))
    with ThreadPoolExecutor(max_workers=workers) as pool:
        # at most two batches per worker in flight: memory stays ~ 2 x workers batches
        pending = [pool.submit(run, s) for s in starts[: 2 * workers]]
        following = iter(starts[2 * workers :])
        while pending:
            done = pending.pop(0).result()
            nxt = next(following, None)
            if nxt is not None:
                pending.append(pool.submit(run, nxt))
            for feats in done:
                done_count += 1
                i = done0 + done_count
                if progress is not None and (i % step == 0 or i == total):
                    progress(stage, i, total)
                yield feats


def reference_replicates(n: int, nperseg: int, n_mc: int) -> int:
    """Short replicates (those of the null included) for the Welch reference of ``n`` samples.

    The reference's error adds ``var_s / (n_ref var_N) = k_N / (n_ref k_s)`` (``k`` the Welch
    segment counts) to the variance of a log-PSD bin of the record; ``n_ref`` is the smallest
    count that keeps this at or below :data:`REFERENCE_SHARE`, and never below ``n_mc``.
    """
    step = nperseg // 2
    k_s = (SHORT_LENGTH - nperseg) // step + 1
    k_n = (n - nperseg) // step + 1
    return int(max(n_mc, np.ceil(k_n / (REFERENCE_SHARE * k_s))))


def _welch_reference(
    simulate: Simulate,
    fs: float,
    nperseg: int,
    count: int,
    seed: int,
    progress: Progress | None,
    stage: str,
) -> Features:
    """Sum of the Welch features over ``count`` further short replicates (the reference only)."""
    sums: Features = {}

    def welch(x: NDArray[np.float64]) -> Features:
        return frequency_features(x, fs, nperseg)

    for feats in _replicates(
        simulate, SHORT_LENGTH, fs, count, seed, welch, progress, stage + " (spectrum reference)",
        0, count,
    ):  # fmt: skip
        for k, v in feats.items():  # in replicate order: the same sums for any thread count
            sums[k] = sums[k] + v if k in sums else v.copy()
    return sums


def scaled_ensemble(
    model: Any,
    n: int,
    fs: float,
    m: NDArray[np.int64],
    nperseg: int,
    plan: TimePlan,
    n_mc: int,
    seed: int,
    progress: Progress | None = None,
    stage: str = "null replicates",
    store: ReplicateStore | None = None,
) -> NullEnsemble:
    """The null of a record of ``n`` samples from short and decimated replicates of ``model``.

    Same feature names and meaning as the full-length replicate null (see the module
    docstring); ``exact_tau`` is set, the tau residuals being draws from a known law.
    ``store`` keeps the replicate blocks (the null of ``store.model == model``) or supplies
    them with the effects added (``store.adding(added)``: ``model`` is then the model with the
    effects, whose exact law gives the tau view's null and the decimation).
    """
    n_s = SHORT_LENGTH
    plan_s = time_plan(n_s)
    d = decimation(model, n, fs)
    n_d = n // d
    length_d = plan.length // d
    plan_d = TimePlan(n_windows=plan.n_windows, length=length_d, m=max(2, length_d // 16))
    blocks = kurtosis_blocks(plan)
    coarse_blocks = tuple(max(b // d, 2) for b in blocks[1:])

    def short(x: NDArray[np.float64]) -> Features:
        feats = frequency_features(x, fs, nperseg)
        feats.update(time_features(x, plan_s, kurt_blocks=blocks[:1]))
        return feats

    def coarse(x: NDArray[np.float64]) -> Features:
        return time_features(x, plan_d, kurt_blocks=coarse_blocks, sample_scale=False)

    total = 2 * n_mc
    sim_s = _simulator(model, store, lambda m: short_model(m, n))
    sim_d = _simulator(model, store, lambda m: m)
    ens_s = NullEnsemble.from_model(
        list(_replicates(sim_s, n_s, fs, n_mc, seed, short, progress, stage, 0, total))
    )
    ens_d = NullEnsemble.from_model(
        list(
            _replicates(
                sim_d, n_d, fs / d, n_mc, seed + 7_919, coarse, progress, stage, n_mc, total
            )
        )
    )
    ref: Features = {}
    null: dict[str, NDArray[np.float64]] = {}
    step = nperseg // 2
    segs = ((n_s - nperseg) // step + 1) / ((n - nperseg) // step + 1)
    n_ref = reference_replicates(n, nperseg, n_mc)
    more = (
        _welch_reference(sim_s, fs, nperseg, n_ref - n_mc, seed + 3_000_017, progress, stage)
        if n_ref > n_mc
        else {}
    )
    for name in ("log_psd", "log_line_psd"):
        if more:
            mean = (ens_s.ref[name] * n_mc + more[name]) / n_ref
            ref[name], null[name] = rescaled_log_gamma(
                ens_s, name, segs, reference=mean, n_reference=n_ref
            )
        else:
            ref[name], null[name] = rescaled_log_gamma(ens_s, name, segs)
    # the windows share one expected level, unless a term's level follows a profile: then
    # each window keeps its own reference (the short replicates hold the compressed profile)
    steady = not any(level_profiled(t) for t in model.terms)
    ref["hf"], null["hf"] = rescaled(
        ens_s, "hf", (plan_s.length - 1) / (plan.length - 1), log_mean=True, pool=steady
    )
    ref["kurt_hf"], null["kurt_hf"] = rescaled(
        ens_s, "kurt_hf", (n_s - 1) / (n - 1), log_mean=False
    )
    # the excess kurtosis of k Gaussian values has mean -6 / (k + 1)
    ref["kurt_hf"] = ref["kurt_hf"] + 6.0 / n_s - 6.0 / n
    # the tail's shape: shares of the samples (a mean over them), the same expected value
    ref["tail"], null["tail"] = rescaled(ens_s, "tail", n_s / n, log_mean=False)
    # the record's 8-sample block kurtosis is the mean over its pieces of a short replicate's
    # length (piecewise_kurtosis_model): slow terms shape each piece as they shape a replicate
    if piecewise_kurtosis_model(model):
        k8 = 1.0 / max(n // n_s, 1)
    else:  # a level profile is compressed whole into every short replicate
        k8 = (plan_s.length // blocks[0]) / (plan.length // blocks[0])
    ref_k8, null_k8 = rescaled(ens_s, "kurt_lf", k8, log_mean=False)
    ref["kurt_lf"] = np.concatenate([ref_k8, ens_d.ref["kurt_lf"]])
    null["kurt_lf"] = np.concatenate([null_k8, ens_d.null["kurt_lf"]], axis=1)
    for name in ("level", "jump", "dyn"):
        ref[name], null[name] = ens_d.ref[name], ens_d.null[name]
    log_ref, avar, tau_null = gaussian_tau_null(
        model, m, fs, n, n_draw=max(4000, 20 * n_mc), seed=seed + 104_729
    )
    ref["log_avar"], ref["avar_lin"], null["log_avar"] = log_ref, avar, tau_null
    # the spike law takes the short replicates' pooled exceedance counts as they are
    pooled = {name: ens_s.pooled[name] for name in SPIKE_POOLED}
    return NullEnsemble(
        ref=ref, null=null, real_scale=1.0, exact_tau=True, pooled=pooled,
        n_pooled=ens_s.n_pooled,
    )  # fmt: skip


def piecewise_kurtosis_model(model: Any) -> bool:
    """Whether the scaled null of ``model`` judges the 8-sample block kurtosis piece by piece.

    Yes unless a term's noise level follows a profile over the record: the short replicates
    hold that profile compressed whole (:func:`short_model`), so the record is judged whole.
    """
    return not any(level_profiled(t) for t in model.terms)


def piecewise_block_kurtosis(x: NDArray[np.float64], b: int) -> float:
    """Excess kurtosis of ``b``-sample block means, averaged over pieces of a short replicate.

    The pieces hold :data:`SHORT_LENGTH` samples each, laid out as a short replicate's windows.

    A long record's block means over its whole length carry the full span of its slow terms (a
    ramp's range, a random walk's wander), which a short replicate cannot hold: the whole-record
    kurtosis of a white + ramp record is the uniform law's -1.2 while a short replicate's is
    near 0. Piece by piece, a slow term shapes the long record as it shapes the short
    replicates, so their law is the null of the mean over the pieces (residuals scaled by one
    over the number of pieces, :func:`~allanite.diagnosis.null.rescaled`).
    """
    plan_s = time_plan(SHORT_LENGTH)
    used = plan_s.n_windows * plan_s.length
    pieces = max(x.size // SHORT_LENGTH, 1)
    values = [
        block_kurtosis(
            x[i * SHORT_LENGTH : i * SHORT_LENGTH + used].reshape(plan_s.n_windows, -1), b
        )
        for i in range(pieces)
    ]
    return float(np.mean(values))
