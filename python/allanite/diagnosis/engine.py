"""``diagnose``: the sim-to-real gap of a real record against a simulated sensor."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite._deprecation import keyword_only_fs, renamed
from allanite.diagnosis.analysis import Analysis, Progress, analyze
from allanite.diagnosis.attribution import LF_KURTOSIS_MAX_SAMPLES, TWO_LEVEL, Attribution, rank
from allanite.diagnosis.band_shape import band_shapes
from allanite.diagnosis.candidates import EVIDENCE, candidate_library, check_effects
from allanite.diagnosis.holdout import holdout_check, holdout_set, tau_model_for
from allanite.diagnosis.holdout_validation import (
    deciding_length,
    detectable,
    disagreement,
    validation_note,
)
from allanite.diagnosis.identification import identified
from allanite.diagnosis.inputs import (
    MIN_SAMPLES,
    SimSource,
    as_rate,
    check_units,
    make_source,
)
from allanite.diagnosis.joint import Explanation, combined_terms, explain
from allanite.diagnosis.level_shape import warmup_time_constant
from allanite.diagnosis.noise_level import burst_spans, drift_shape
from allanite.diagnosis.result import Diagnosis, Holdout
from allanite.diagnosis.scaled_null import ADDED_SEED, ReplicateStore, uses_scaled_null
from allanite.diagnosis.time_base import time_base_evidence, with_time_base
from allanite.diagnosis.two_level import two_level_context
from allanite.diagnosis.verdict import verdict
from allanite.io.record import Record
from allanite.terms import Resonance, term_from_dict
from allanite.variance.checks import check_fs as _check_fs
from allanite.variance.checks import resolve_source

__all__ = ["diagnose"]

#: effects tied to the start of a record: a held-out end of the record cannot show them
START_EFFECTS = ("warmup",)

#: seed offset of the sensor replicates of the telegraph's two-level test
TWO_LEVEL_SEED = 7_000_001


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


def _bursts(
    tv: Any, x: NDArray[np.float64], fs: float
) -> tuple[float, float, list[tuple[int, int]]] | None:
    """Duty, mean length (s) and sample spans of the bursts of raised short-term noise level.

    The time view flags the windows; :func:`~allanite.diagnosis.noise_level.burst_spans`
    measures each burst's ends on the record's first differences.
    """
    z = tv.z.get("hf")
    if z is None or z.size == 0:
        return None
    raised = z > tv.thresholds["hf"]
    if not raised.any() or raised.all():
        return None
    spans = burst_spans(x, fs, tv, raised)
    if not spans:
        return None
    covered = raised.size * round(tv.window_s * fs)  # the samples the windows cover
    duty = min(float(sum(e - s for s, e in spans)) / float(covered), 1.0 - 1e-9)
    length = float(np.mean([e - s for s, e in spans])) / fs
    return duty, length, spans


def _claiming_only_what_is_left_explained(
    explanation: Explanation | None, unexplained: list[Any]
) -> Explanation | None:
    """The explanation without the evidence its re-analysis still finds (``unexplained``)."""
    if explanation is None:
        return None
    left = {u.evidence for u in unexplained}
    return replace(explanation, explained=[e for e in explanation.explained if e not in left])


def _evidence(analysis: Analysis) -> dict[str, float]:
    fam = analysis.time.family_p
    out = {"line": analysis.frequency.line_p_value}
    out.update({k: fam[k] for k in EVIDENCE if k in fam})
    return out


@keyword_only_fs
def diagnose(
    real: ArrayLike | Record,
    sim: Any,
    *,
    fs: float | None = None,
    input: str | None = None,
    units: str | None = None,
    sim_units: str | None = None,
    sim_input: str = "rate",
    sim_fs: float | None = None,
    holdout: float | ArrayLike | None = None,
    effects: list[str] | None = None,
    n_mc: int = 200,
    significance: float = 0.05,
    seed: int = 0,
    progress: Progress | None = None,
    alpha: float | None = None,
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
    real : array_like or Record
        The real record, one channel. A :class:`~allanite.io.Record` brings its own ``fs``,
        ``input`` and unit (giving them as well is allowed only when they agree).
    sim : NoiseModel, str, dict, path or array_like
        The simulated sensor: a NoiseModel (or its JSON text, dict or file path) or a
        simulated record at least as long as ``real``.
    fs : float
        Sampling frequency in Hz of both records (keyword-only; required for a raw array,
        taken from a Record).
    input : {"rate", "increment", "angle"}, optional
        What the real samples are (default ``"rate"``, or the Record's).
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
    significance : float
        Significance level of every test (``alpha=`` is its deprecated name: ``alpha`` means
        the noise exponent in :func:`allanite.avar`).
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
    significance = renamed(
        significance,
        alpha,
        new="significance",
        old="alpha",
        default=0.05,
        why="alpha is the noise exponent in avar",
    )
    samples, rate, input_kind, units, _ = resolve_source(real, fs, input, units)
    if np.ndim(samples) != 1:
        raise ValueError(
            f"diagnose takes one channel, the record has {np.shape(samples)[1]}: pick one, "
            "e.g. record.select([0])"
        )
    effects = check_effects(effects)
    if not 0.0 < significance < 0.5:
        raise ValueError(f"significance must lie in (0, 0.5), got {significance}")
    if isinstance(n_mc, bool) or not isinstance(n_mc, (int, np.integer)) or n_mc < 20:
        raise ValueError(f"n_mc must be an integer >= 20, got {n_mc!r}")
    if sim_fs is not None and not np.isclose(_check_fs(sim_fs), rate, rtol=1e-9, atol=0.0):
        raise ValueError(
            f"sample-rate mismatch: the real record has fs = {rate} Hz but the simulated record "
            f"fs = {sim_fs} Hz; simulate at the real rate (or resample one of them)"
        )
    x = as_rate(samples, rate, input_kind, name="real")
    source = make_source(sim, rate, x.size, sim_units=sim_units, sim_input=sim_input)
    common_units = check_units(units, source.units)
    x_fit, x_hold, hold_kind = _split(x, holdout, rate, input_kind)
    # a fraction held out validates (:func:`_fraction_check`): the gap is tested and the effects
    # attributed on the whole record, the fit part's attribution is checked on the held-out part
    parts = (x_fit, x_hold) if hold_kind == "fraction" else None
    x_fit = x if parts is not None else x_fit
    # the long-record null keeps its replicate blocks for the re-analysis (shorter records and
    # simulated records have a full-length replicate null, simulated afresh each time)
    long_null = source.kind == "model" and uses_scaled_null(source.model, x_fit.size)
    store = ReplicateStore(source.model) if long_null else None
    run = _Run(x_fit, rate, source, int(n_mc), seed, significance, progress, store)
    analysis = analyze(
        x_fit, source, n_mc=run.n_mc, seed=seed, alpha=significance, progress=progress,
        store=store,
    )  # fmt: skip
    p = analysis.p_value
    significant = bool(p < significance)
    bands = band_shapes(x_fit, rate, analysis.frequency) if significant else []
    analysis = _lines_beyond_resonances(analysis, bands, rate)
    ev_p = _evidence(analysis)
    found = _attribute(run, analysis, ev_p, effects, bands) if significant else _Found()
    after = _reanalysis(run, found.explanation)
    if store is not None:
        store.release()  # the null's replicate blocks served the re-analysis (or nothing)
    head = verdict(
        significant=significant, p_value=p, alpha=significance, tau_model=analysis.tau_model,
        tau=analysis.tau, frequency=analysis.frequency, time=analysis.time, evidence_p=ev_p,
        evidence_significant=found.significant, explanation=found.explanation,
        units=common_units, after=after,
    )  # fmt: skip
    # the time base (time stamps of a Record, held samples): reported next to the three views
    base_items = time_base_evidence(
        real, samples, rate, significance / 10.0, input_kind=input_kind, samples_rate=x,
        view=analysis.time,
    )  # fmt: skip
    head = with_time_base(head, base_items)
    head, rival_names = identified(
        head, found.explanation, found.attribution, found.by_effect, model=source.model,
        fs=rate, n=x_fit.size, alpha=significance, units=common_units,
    )  # fmt: skip
    head, explanation, held = _validated(run, found, head, parts, (x_hold, hold_kind), effects)
    return Diagnosis(
        statistic=analysis.tau.gap,
        p_value=p,
        significant=significant,
        tau=analysis.tau,
        frequency=analysis.frequency,
        time=analysis.time,
        attribution=found.attribution,
        holdout=held,
        explanation=explanation,
        closed=head.closed,
        unexplained=head.unexplained,
        headline=head.headline,
        indistinguishable=tuple(rival_names),
        meta={
            "fs": rate,
            "n_samples": int(x.size),
            "n_fit": int(parts[0].size if parts is not None else x_fit.size),
            "units": common_units,
            "sim": source.kind,
            "n_mc": run.n_mc,
            "n_null": analysis.n_null,
            "significance": significance,
            "seed": seed,
            "evidence_p_values": ev_p,
            "unavailable_effects": found.unavailable,
        },
    )


@dataclass(frozen=True)
class _Run:
    """What every stage of one diagnosis shares: the fitted part, the sensor, the settings."""

    x_fit: NDArray[np.float64]
    fs: float
    source: Any
    n_mc: int
    seed: int
    significance: float
    progress: Progress | None
    store: ReplicateStore | None = None

    @property
    def duration(self) -> float:
        return self.x_fit.size / self.fs


@dataclass(frozen=True)
class _Found:
    """The candidates' outcome: ranked single effects, the joint explanation, the evidence."""

    attribution: list[Attribution] = field(default_factory=list)
    explanation: Explanation | None = None
    by_effect: dict[str, Any] = field(default_factory=dict)
    significant: dict[str, bool] = field(default_factory=dict)
    unavailable: list[str] = field(default_factory=list)


def _lines_beyond_resonances(analysis: Analysis, bands: list[Any], fs: float) -> Analysis:
    """The analysis whose lines stand out once the resonances found are expected.

    A narrow resonance's own peak can pass the line detector on a short record (see
    :meth:`FrequencyView.lines_beyond`): such a "line" is the resonance, not a sinusoid.
    """
    psd: Any = 0.0
    for band in bands:
        if band.kind == "resonance":
            with np.errstate(all="ignore"):
                one = Resonance(**band.params).psd_sampled(analysis.frequency.f, 1.0 / fs)
            psd = psd + np.where(np.isfinite(one), one, 0.0)
    if np.ndim(psd) == 0:
        return analysis
    return replace(analysis, frequency=analysis.frequency.lines_beyond(psd))


def _attribute(
    run: _Run,
    analysis: Analysis,
    ev_p: dict[str, float],
    effects: list[str] | None,
    bands: list[Any],
) -> _Found:
    """Fit every candidate effect on top of the sensor, rank them and select the joint set.

    ``bands``: the band-pass shaped excesses of the frequency view (:func:`band_shapes`).
    """
    sig = {k: v < run.significance / len(ev_p) for k, v in ev_p.items()}
    spikes = None
    if analysis.time.spike_times_s:
        height = float(np.sqrt(np.mean(np.square(analysis.time.spike_amplitudes))))
        spikes = (len(analysis.time.spike_times_s) / run.duration, height)
    if run.progress is not None:
        run.progress("fitting candidate effects", 0, 1)
    bursts = _bursts(analysis.time, run.x_fit, run.fs)
    # the set's tau view is judged on a null that holds the bursts where the record has them
    tm = analysis.tau_model.with_bursts(run.source.model, bursts[2] if bursts else ())
    cands, unavailable = candidate_library(
        sig,
        duration=run.duration,
        n_changes=len(analysis.time.change_points_s),
        warmup_tau=warmup_time_constant(analysis.time, run.duration),
        model=run.source.model,
        lines=[(ln.frequency_hz, ln.amplitude) for ln in analysis.frequency.lines],
        spikes=spikes,
        effects=effects,
        bursts=bursts[:2] if bursts else None,
        band=bands,
        drift=drift_shape(run.x_fit, run.fs, analysis.time, run.source.model),
        tail_spread=analysis.time.tail.get("spread"),
    )
    # the same calibrated test ranks single effects and selects the joint set
    test: dict[str, Any] = {
        "alpha": run.significance,
        "evidence_p": ev_p,
        "significant": sig,
        "time_view": _with_two_level(run, analysis.time, cands),
        "duration": run.duration,
    }
    attribution = rank(cands, tm, **test)
    explanation = None
    if attribution:
        explanation = explain(attribution[0], cands, tm, frequency=analysis.frequency, **test)
    return _Found(attribution, explanation, {c.effect: c for c in cands}, sig, unavailable)


def _with_two_level(run: _Run, view: Any, cands: list[Any]) -> Any:
    """The time view with the context of the telegraph's two-level test (:mod:`two_level`).

    Only when a telegraph is a candidate, the sensor is a model and the fitted part is at most
    :data:`~allanite.diagnosis.attribution.LF_KURTOSIS_MAX_SAMPLES` samples.
    """
    if (
        run.source.model is None
        or run.x_fit.size > LF_KURTOSIS_MAX_SAMPLES
        or not any(c.effect in TWO_LEVEL for c in cands)
    ):
        return view
    ctx = two_level_context(run.x_fit, run.source.model, run.fs, seed=run.seed + TWO_LEVEL_SEED)
    return replace(view, lf_kurtosis={**view.lf_kurtosis, "two_level": ctx})


def _reanalysis(run: _Run, explanation: Explanation | None) -> Analysis | None:
    """The three views again, against the sensor WITH the explanation's effects.

    The frequency and time views' statistics (bursts, kurtosis, band levels) depend on the
    whole noise, so only a null of the augmented model says whether they are consistent
    after the effects. When every effect adds a process of its own (not a rescale down, not a
    replacement of the model's white noise), the null's replicates are reused with the
    effects' streams added (:class:`~allanite.diagnosis.scaled_null.ReplicateStore`);
    otherwise the augmented model is simulated afresh.
    """
    if explanation is None or run.source.model is None:
        return None
    model = run.source.model
    combined = replace(
        model, terms=tuple(term_from_dict(t) for t in combined_terms(explanation, model))
    )
    added = [
        c.added_term(a.params)
        for a, c in zip(explanation.effects, explanation.candidates, strict=True)
    ]
    store = None
    if run.store is not None and all(t is not None for t in added):
        store = run.store.adding(replace(model, terms=tuple(added)))
    return analyze(
        run.x_fit,
        SimSource(fs=run.fs, model=combined, units=run.source.units),
        n_mc=run.n_mc,
        seed=run.seed if store is not None else run.seed + ADDED_SEED,
        alpha=run.significance,
        progress=run.progress,
        stage="re-analysis with the effects",
        store=store,
    )


def _held_out(
    run: _Run, found: _Found, x_hold: NDArray[np.float64] | None, hold_kind: str
) -> tuple[Explanation | None, Holdout | None]:
    """The explanation with its pasteable terms, and the check of the effects on held-out data."""
    explanation = found.explanation
    if explanation is not None:
        explanation = replace(explanation, terms=combined_terms(explanation, run.source.model))
    starts_only = explanation is not None and any(
        a.effect in START_EFFECTS for a in explanation.effects
    )
    if x_hold is None or not found.attribution or starts_only:
        return explanation, None
    if run.progress is not None:
        run.progress("held-out null", 0, 1)
    seed = run.seed + 1_000_003
    tm_hold = tau_model_for(x_hold, run.source, n_mc=run.n_mc, seed=seed)
    best = found.attribution[0]
    held = None
    if best.effect not in START_EFFECTS:
        held = holdout_check(
            best,
            found.by_effect[best.effect],
            x_hold,
            run.source,
            n_mc=run.n_mc,
            seed=seed,
            alpha=run.significance,
            kind=hold_kind,
            tm=tm_hold,
        )
    if explanation is not None:
        pairs = list(zip(explanation.effects, explanation.candidates, strict=True))
        explanation = replace(
            explanation,
            holdout=holdout_set(pairs, tm_hold, alpha=run.significance, kind=hold_kind),
        )
    return explanation, held


def _validated(
    run: _Run,
    found: _Found,
    head: Any,
    parts: tuple[NDArray[np.float64], NDArray[np.float64] | None] | None,
    held_out: tuple[NDArray[np.float64] | None, str],
    effects: list[str] | None,
) -> tuple[Any, Explanation | None, Holdout | None]:
    """The held-out check: of a fraction (``parts``, :func:`_fraction_check`) or a record.

    A fraction's validation note joins the headline when it flags something: a disagreement
    with the whole record, an effect not checkable there, or no gap in the fit part. Without
    an attribution on the whole record (no gap) there is nothing to validate.
    """
    if parts is not None and not found.attribution:
        # nothing attributed on the whole record (no gap): nothing to validate
        explanation, held = _held_out(run, found, None, "fraction")
    elif parts is not None:
        explanation, held = _fraction_check(run, found, parts, effects)
        if held is not None and (held.disagrees or not held.checkable or not held.effect):
            head = replace(head, headline=head.headline + "; " + held.note)
    else:
        explanation, held = _held_out(run, found, *held_out)
    return head, _claiming_only_what_is_left_explained(explanation, head.unexplained), held


def _fit_part_explanation(run: _Run, effects: list[str] | None) -> tuple[Analysis, _Found]:
    """The fit part's own analysis and attribution (``run.x_fit`` is the fit part)."""
    analysis = analyze(
        run.x_fit, run.source, n_mc=run.n_mc, seed=run.seed, alpha=run.significance,
        progress=run.progress, stage="fit part (holdout)", store=run.store,
    )  # fmt: skip
    if not analysis.p_value < run.significance:
        return analysis, _Found()
    bands = band_shapes(run.x_fit, run.fs, analysis.frequency)
    analysis = _lines_beyond_resonances(analysis, bands, run.fs)
    return analysis, _attribute(run, analysis, _evidence(analysis), effects, bands)


def _fraction_check(
    run: _Run,
    whole: _Found,
    parts: tuple[NDArray[np.float64], NDArray[np.float64] | None],
    effects: list[str] | None,
) -> tuple[Explanation | None, Holdout | None]:
    """Validation of ``holdout=`` a fraction (:mod:`~allanite.diagnosis.holdout_validation`).

    ``run`` and ``whole`` are the whole record's; the effects are attributed again on the fit
    part and carried to the held-out part, where the tau view judges them at the same level.
    """
    explanation, _ = _held_out(run, whole, None, "fraction")
    x_fit, x_hold = parts
    assert x_hold is not None
    store = ReplicateStore(run.source.model) if _long(run, x_fit.size) else None
    fit_run = replace(run, x_fit=x_fit, store=store)
    fit_analysis, fit = _fit_part_explanation(fit_run, effects)
    if store is not None:
        store.release()
    seed = run.seed + 1_000_003
    tm_hold = tau_model_for(x_hold, run.source, n_mc=run.n_mc, seed=seed)
    held_p = float(tm_hold.p_value())
    fit_e = fit.explanation
    pairs = list(zip(fit_e.effects, fit_e.candidates, strict=True)) if fit_e else []
    check: dict[str, Any] = {"effects": [a.effect for a, _ in pairs], "shrinkage": 0.0}
    check.update(
        gap_before=tm_hold.gap(),
        gap_after=tm_hold.gap(),
        consistent_after=held_p > run.significance,
    )
    if pairs:
        check.update(holdout_set(pairs, tm_hold, alpha=run.significance, kind="fraction"))
    check.update(
        source="fraction",
        n_samples=int(x_hold.size),
        fit_duration_s=x_fit.size / run.fs,
        held_duration_s=x_hold.size / run.fs,
        fit_p_value=float(fit_analysis.p_value),
        held_p_value=held_p,
        fit_significant=bool(fit_analysis.p_value < run.significance),
        held_gap_before=tm_hold.gap(),
        not_checkable=[a.effect for a, c in pairs if not _detectable_on(tm_hold, a, c, run)],
        disagrees=bool(
            fit_analysis.p_value < run.significance and disagreement(whole.explanation, fit_e)
        ),
        deciding_length_s=None,
    )
    if check["disagrees"] and whole.explanation is not None and fit_e is not None:
        check["deciding_length_s"] = deciding_length(
            whole.explanation, fit_e, run.source.model, run.fs, run.x_fit.size, run.significance
        )
    note = validation_note(check, whole.explanation)
    check["note"] = note
    if explanation is not None:
        explanation = replace(explanation, holdout=check)
    best = fit.attribution[0] if fit.attribution else None
    held = Holdout(
        effect=best.effect if best is not None else "",
        shrinkage=float(check["shrinkage"]),
        gap_before=float(check["gap_before"]),
        gap_after=float(check["gap_after"]),
        consistent_after=bool(check["consistent_after"]),
        n_samples=int(x_hold.size),
        source="fraction",
        checkable=not check["not_checkable"],
        disagrees=bool(check["disagrees"]),
        fit_effects=tuple(check["effects"]),
        deciding_length_s=check["deciding_length_s"],
        note=note,
    )
    return explanation, held


def _long(run: _Run, n: int) -> bool:
    return bool(run.source.kind == "model" and uses_scaled_null(run.source.model, n))


def _detectable_on(tm: Any, a: Attribution, c: Any, run: _Run) -> bool:
    values = {n: a.params[n] for n in c.free}
    extra = np.asarray(c.extra_avar(values, tm.tau, tm.dt), dtype=np.float64)
    return detectable(tm, extra, run.significance)
