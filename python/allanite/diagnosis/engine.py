"""``diagnose``: the sim-to-real gap of a real record against a simulated sensor."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.diagnosis.analysis import Analysis, Progress, analyze
from allanite.diagnosis.attribution import rank
from allanite.diagnosis.band_shape import band_shape
from allanite.diagnosis.candidates import candidate_library, check_effects
from allanite.diagnosis.holdout import holdout_check, holdout_set, tau_model_for
from allanite.diagnosis.inputs import (
    MIN_SAMPLES,
    SimSource,
    as_rate,
    check_units,
    make_source,
)
from allanite.diagnosis.joint import Explanation, combined_terms, explain
from allanite.diagnosis.level_shape import warmup_time_constant
from allanite.diagnosis.null import runs
from allanite.diagnosis.result import Diagnosis, Holdout
from allanite.diagnosis.verdict import verdict
from allanite.terms import term_from_dict
from allanite.variance.checks import check_fs as _check_fs

__all__ = ["diagnose"]

#: effects tied to the start of a record: a held-out end of the record cannot show them
START_EFFECTS = ("warmup",)

#: statistics of the frequency and time views that count as evidence for an effect
EVIDENCE = ("line", "jump", "level", "spike", "kurt_hf", "kurt_lf", "hf", "dyn")


def _split(
    x: NDArray[np.float64], holdout: Any, fs: float, input: str
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, str]:
    if holdout is None:
        return x, None, ""
    if isinstance(holdout, (float, int)) and not isinstance(holdout, bool):
        h = float(holdout)
        if not 0.0 < h < 1.0:
            raise ValueError(f"holdout must be a fraction in (0, 1) or a second record, got {h}")
        n_fit = round(x.size * (1.0 - h))
        if min(n_fit, x.size - n_fit) < MIN_SAMPLES:
            raise ValueError(
                f"holdout={h} splits the {x.size}-sample record into {n_fit} and "
                f"{x.size - n_fit} samples; each part needs at least {MIN_SAMPLES}: use a longer "
                "record or a fraction nearer 0.5"
            )
        return x[:n_fit], x[n_fit:], "fraction"
    return x, as_rate(holdout, fs, input, name="held-out"), "record"


def _bursts(tv: Any) -> tuple[float, float] | None:
    """Duty and mean length (s) of the windows whose short-term noise level is raised."""
    z = tv.z.get("hf")
    if z is None or z.size == 0:
        return None
    raised = z > tv.thresholds["hf"]
    spans = runs(raised)
    if not spans or raised.all():
        return None
    duty = float(raised.mean())
    length = float(np.mean([b - a + 1 for a, b in spans])) * tv.window_s
    return duty, length


def _evidence(analysis: Analysis) -> dict[str, float]:
    fam = analysis.time.family_p
    out = {"line": analysis.frequency.line_p_value}
    out.update({k: fam[k] for k in EVIDENCE if k in fam})
    return out


def diagnose(
    real: ArrayLike,
    sim: Any,
    fs: float,
    *,
    input: str = "rate",
    units: str | None = None,
    sim_units: str | None = None,
    sim_input: str = "rate",
    sim_fs: float | None = None,
    holdout: float | ArrayLike | None = None,
    effects: list[str] | None = None,
    n_mc: int = 200,
    alpha: float = 0.05,
    seed: int = 0,
    progress: Progress | None = None,
) -> Diagnosis:
    r"""Where and why a simulated sensor differs from a real record.

    The real record is compared with Monte Carlo replicates of the simulated sensor in three
    views: averaging time (log Allan variance per octave, Mahalanobis statistic ``T`` with the
    covariance between taus), frequency (Welch PSD ratio with bands and a spectral-line
    detector) and time (sliding-window scan for level jumps, warm-up, bursts, spikes and
    non-Gaussian amplitudes). When the combined test is significant, every candidate effect
    (a :class:`~allanite.terms.Term` type, or ``rescale:<type>`` of a model term) is fitted on
    top of the simulated sensor and ranked; see docs/diagnosis.md. A record longer than 2^18
    samples against a model needs no full-length replicate: the tau view's null comes from the
    model's exact AVAR covariance, the other views from short and decimated replicates
    (:mod:`allanite.diagnosis.scaled_null`), so the cost hardly grows with the record.

    The gap statistic is :math:`G = \max(0, T - T_0)` (``T0`` the null mean of ``T``) and the
    shrinkage of an effect ``1 - G_after / G_before``.

    Parameters
    ----------
    real : array_like
        The real record, one channel.
    sim : NoiseModel, str, dict, path or array_like
        The simulated sensor: a NoiseModel (or its JSON text, dict or file path) or a
        simulated record at least as long as ``real``.
    fs : float
        Sampling frequency in Hz of both records.
    input : {"rate", "increment", "angle"}
        What the real samples are.
    units : str, optional
        Rate unit of the real record; must agree with the model's or ``sim_units``.
    sim_units : str, optional
        Rate unit of a simulated record.
    sim_input : {"rate", "increment", "angle"}
        What the samples of a simulated record are.
    sim_fs : float, optional
        Sampling frequency of a simulated record, if known; it must equal ``fs`` (resample
        the simulation otherwise).
    holdout : float or array_like, optional
        Fraction of the real record (its end) held out from the fit, or a second real record:
        the best effect's shrinkage is measured there (not for a warm-up, which lives at the
        start of a record; then ``Diagnosis.holdout`` is None).
    effects : list of str, optional
        Restrict the candidate effects (default: all, see
        :data:`allanite.diagnosis.candidates.EFFECTS`).
    n_mc : int
        Monte Carlo replicates of the null (at least 20; 200 gives p-values to ~0.005).
    alpha : float
        Significance level of every test.
    seed : int
        Seed of the Monte Carlo replicates (results are reproducible).
    progress : callable, optional
        Called as ``progress(stage, done, total)`` while replicates are simulated (about ten
        times per stage: the null, the re-analysis with the effects, the fits) -- the CLI
        prints it on long records.

    Returns
    -------
    Diagnosis
        Gap statistic and p-value, the three views, ranked attributions and the held-out check.

    References
    ----------
    D. W. Allan (1966); C. A. Greenhall, W. J. Riley (2003); P. D. Welch (1967); L. Galleani,
    P. Tavella, "The dynamic Allan variance" (2009).
    """
    rate = _check_fs(fs)
    effects = check_effects(effects)
    if not 0.0 < alpha < 0.5:
        raise ValueError(f"alpha must lie in (0, 0.5), got {alpha}")
    if isinstance(n_mc, bool) or not isinstance(n_mc, (int, np.integer)) or n_mc < 20:
        raise ValueError(f"n_mc must be an integer >= 20, got {n_mc!r}")
    if sim_fs is not None and not np.isclose(_check_fs(sim_fs), rate, rtol=1e-9, atol=0.0):
        raise ValueError(
            f"sample-rate mismatch: the real record has fs = {rate} Hz but the simulated record "
            f"fs = {sim_fs} Hz; simulate at the real rate (or resample one of them)"
        )
    x = as_rate(real, rate, input, name="real")
    source = make_source(sim, rate, x.size, sim_units=sim_units, sim_input=sim_input)
    common_units = check_units(units, source.units)
    x_fit, x_hold, hold_kind = _split(x, holdout, rate, input)
    analysis = analyze(x_fit, source, n_mc=int(n_mc), seed=seed, alpha=alpha, progress=progress)
    p = analysis.p_value
    significant = bool(p < alpha)
    attribution = []
    unavailable: list[str] = []
    by_effect: dict[str, Any] = {}
    explanation: Explanation | None = None
    ev_p = _evidence(analysis)
    sig: dict[str, bool] = {}
    if significant:
        sig = {k: v < alpha / len(ev_p) for k, v in ev_p.items()}
        spikes = None
        if analysis.time.spike_times_s:
            duration = x_fit.size / rate
            height = float(np.sqrt(np.mean(np.square(analysis.time.spike_amplitudes))))
            spikes = (len(analysis.time.spike_times_s) / duration, height)
        if progress is not None:
            progress("fitting candidate effects", 0, 1)
        cands, unavailable = candidate_library(
            sig,
            duration=x_fit.size / rate,
            n_changes=len(analysis.time.change_points_s),
            warmup_tau=warmup_time_constant(analysis.time, x_fit.size / rate),
            model=source.model,
            lines=[(ln.frequency_hz, ln.amplitude) for ln in analysis.frequency.lines],
            spikes=spikes,
            effects=effects,
            bursts=_bursts(analysis.time),
            band=band_shape(x_fit, rate, analysis.frequency),
        )
        # the same calibrated test ranks single effects and selects the joint set
        test: dict[str, Any] = {
            "alpha": alpha,
            "evidence_p": ev_p,
            "significant": sig,
            "time_view": analysis.time,
            "duration": x_fit.size / rate,
        }
        attribution = rank(cands, analysis.tau_model, **test)
        by_effect = {c.effect: c for c in cands}
        if attribution:
            explanation = explain(attribution[0], cands, analysis.tau_model, **test)
    after: Analysis | None = None
    if explanation is not None and source.model is not None:
        # the frequency and time views re-run against the simulated sensor WITH the effects:
        # their statistics (bursts, kurtosis, band levels) depend on the whole noise, so only
        # a null of the augmented model says whether they are consistent after the effects
        combined = replace(
            source.model,
            terms=tuple(term_from_dict(t) for t in combined_terms(explanation, source.model)),
        )
        after = analyze(
            x_fit,
            SimSource(fs=rate, model=combined, units=source.units),
            n_mc=int(n_mc),
            seed=seed + 2_000_003,
            alpha=alpha,
            progress=progress,
            stage="re-analysis with the effects",
        )
    head = verdict(
        significant=significant,
        p_value=p,
        alpha=alpha,
        tau_model=analysis.tau_model,
        tau=analysis.tau,
        frequency=analysis.frequency,
        time=analysis.time,
        evidence_p=ev_p,
        evidence_significant=sig,
        explanation=explanation,
        units=common_units,
        after=after,
    )
    held: Holdout | None = None
    if explanation is not None:
        explanation = replace(explanation, terms=combined_terms(explanation, source.model))
    starts_only = explanation is not None and any(
        a.effect in START_EFFECTS for a in explanation.effects
    )
    if x_hold is not None and attribution and not starts_only:
        if progress is not None:
            progress("held-out null", 0, 1)
        tm_hold = tau_model_for(x_hold, source, n_mc=int(n_mc), seed=seed + 1_000_003)
        best = attribution[0]
        if best.effect not in START_EFFECTS:
            held = holdout_check(
                best,
                by_effect[best.effect],
                x_hold,
                source,
                n_mc=int(n_mc),
                seed=seed + 1_000_003,
                alpha=alpha,
                kind=hold_kind,
                tm=tm_hold,
            )
        if explanation is not None:
            pairs = list(zip(explanation.effects, explanation.candidates, strict=True))
            explanation = replace(
                explanation, holdout=holdout_set(pairs, tm_hold, alpha=alpha, kind=hold_kind)
            )
    return Diagnosis(
        statistic=analysis.tau.gap,
        p_value=p,
        significant=significant,
        tau=analysis.tau,
        frequency=analysis.frequency,
        time=analysis.time,
        attribution=attribution,
        holdout=held,
        explanation=explanation,
        closed=head.closed,
        unexplained=head.unexplained,
        headline=head.headline,
        meta={
            "fs": rate,
            "n_samples": int(x.size),
            "n_fit": int(x_fit.size),
            "units": common_units,
            "sim": source.kind,
            "n_mc": int(n_mc),
            "n_null": analysis.n_null,
            "alpha": alpha,
            "seed": seed,
            "evidence_p_values": ev_p,
            "unavailable_effects": unavailable,
        },
    )
