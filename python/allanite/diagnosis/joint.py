r"""Joint attribution: a set of effects that together explain the gap.

Forward selection with the same calibrated, penalised test as the single-effect ranking
(:func:`allanite.diagnosis.attribution.rank`): starting from the best single effect, every
remaining candidate is fitted on top of the simulated sensor *plus the effects chosen so far*
(their Allan variances add: the reference becomes ``log(S + E_chosen + E_new)``), only
against the evidence the chosen effects leave unexplained; the best kept candidate (likelihood
ratio test ``Delta T > chi2_{1-alpha}(k)`` or significant evidence explained, without raising
``T`` by more than ``chi2_{1-alpha}(1)``) joins the set.
Selection stops when the tau view is consistent with chance and no significant evidence is
left, when no candidate passes the test, or after :data:`MAX_EFFECTS` effects.

Backfitting: an effect of the set was fitted before the later ones existed and may have
taken part of their Allan variance (a resonance fitted alone takes some of the extra white
noise next to it and overshoots the shortest taus, which a Gauss-Markov look-alike of
``tau_c`` ~ one sample then fits better than the white noise). So every single candidate on
top of the set is judged on the set refitted with it: each effect of the set refitted from
its own values on top of the others and the candidate, then the candidate on top of them
(one sweep, :func:`_backfit`, kept only when it lowers ``T``); the winner's refitted set is
adopted.

Exchange: each chosen effect is then refitted, with every candidate, on top of the others
(the same ranking against the evidence the others leave); when another candidate ranks
first it replaces the effect (greedy forward selection can start from an effect that only
mimics two true ones, e.g. a rate random walk for a ramp plus Gauss-Markov noise). Two passes
at most.

In both steps the time view's window-mean spreads include the slow noise of the stationary
effects already in the set (:func:`with_level_background`): a ramp or a warm-up on top of
Gauss-Markov noise is judged against that noise, not against the bare simulation.

The opening also tries a warm-up or a ramp measured on the window means with each stationary
partner fitted on top of it (:func:`_shape_and_noise`): the tau view reads a warm-up or ramp
under slow noise as a random walk, and the shape fitted alone there takes the noise's Allan
variance too, so greedy selection never reaches the pair.

Spectral shape: in both steps the candidates on top of the set are ordered by their penalised
score *plus* the misfit of the spectrum's shape with the set and the candidate added
(:meth:`~allanite.diagnosis.frequency_view.FrequencyView.shape_misfit`, ``F = sum_b z_b^2``
over the broadband bands, ``chi2`` with one degree of freedom per band when the set is right;
each effect contributes its exact sampled PSD, a ramp or warm-up the Welch spectrum of its own
samples: every Welch segment loses its mean but keeps its slope, whose leakage is a ``1/f^2``
excess in the lowest bins that a slow-noise look-alike would otherwise explain). The tau
view's penalised likelihood alone cannot tell look-alikes
apart whose Allan variances nearly coincide over the flagged taus (a Gauss-Markov process next
to more white noise and more flicker; a random walk and flicker at long taus); their spectra
differ (a Lorentzian knee against a ``1/f`` line, ``1/f^2`` against ``1/f``), so the pair
whose combined spectrum fits wins; candidates whose combined score stays within the penalty of
one parameter are reported as the chosen effect's ``alternatives`` (a tie the views leave).

Backward check: an effect is dropped again when removing it (the others kept) raises ``T`` by
less than the ``chi2_{1-alpha}(k)`` quantile and it is the only one to explain none of the
evidence, i.e. it no longer earns its parameters in the presence of the later effects.

``share`` splits the gap: effect ``i`` (in selection order) gets ``(G_{i-1} - G_i) / G_0``
with ``G_i`` the gap after the first ``i`` effects; what remains is ``G_final / G_0``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from allanite.diagnosis.attribution import EVIDENCE_CAP, Attribution, fit_candidate, rank
from allanite.diagnosis.candidates import DISTINCT_FACTOR, Candidate
from allanite.diagnosis.frequency_view import FrequencyView
from allanite.diagnosis.level_shape import level_misfit, ramp_shape, warmup_shape
from allanite.diagnosis.tau_view import TauModel
from allanite.diagnosis.time_view import TimeView, added_level_variance
from allanite.diagnosis.two_level import with_set

__all__ = [
    "LEVEL_SHAPES",
    "MAX_EFFECTS",
    "Explanation",
    "combined_terms",
    "explain",
    "with_background",
    "with_level_background",
]

#: at most this many effects in one explanation
MAX_EFFECTS = 4


@dataclass(frozen=True)
class Explanation:
    """A set of effects that together explain the gap.

    Attributes
    ----------
    effects : list of Attribution
        The effects in selection order, each fitted on top of the previous ones; an effect's
        ``alternatives`` are the candidates whose score plus spectral shape misfit on top of
        the others lies within the penalty of one parameter of its own (the record does not
        tell them apart in its slot).
    candidates : list of Candidate
        Their candidate definitions (same order).
    gap_before, gap_after : float
        ``G`` without and with all the effects.
    consistent_after : bool
        Tau view consistent with chance after all the effects (``k`` = all their parameters).
    p_after : float
        p-value of the remaining tau-view statistic.
    share : dict
        Fraction of the gap per effect and ``"remainder"``.
    explained : list of str
        Evidence of the frequency/time views the set explains (:func:`allanite.diagnose`
        drops what its re-analysis with the effects still finds, which is ``unexplained``).
    extra_avar : numpy.ndarray
        Combined Allan variance the effects add on the tau grid.
    terms : list of dict
        Combined model term list (model JSON ``terms``), when the simulated sensor is a model.
    holdout : dict or None
        Held-out check of the whole set.
    """

    effects: list[Attribution]
    candidates: list[Candidate]
    gap_before: float
    gap_after: float
    consistent_after: bool
    p_after: float
    share: dict[str, float]
    explained: list[str]
    extra_avar: NDArray[np.float64]
    terms: list[dict[str, Any]] = field(default_factory=list)
    holdout: dict[str, Any] | None = None

    @property
    def n_params(self) -> int:
        """Free parameters of the set."""
        return sum(len(c.free) for c in self.candidates)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "effects": [
                {
                    "effect": a.effect,
                    "params": dict(a.params),
                    "term": dict(a.term),
                    "alternatives": list(a.alternatives),
                }
                for a in self.effects
            ],
            "gap_before": self.gap_before,
            "gap_after": self.gap_after,
            "consistent_after": self.consistent_after,
            "p_after": self.p_after,
            "share": dict(self.share),
            "explained": list(self.explained),
            "terms": list(self.terms),
            "holdout": self.holdout,
        }


def with_background(tm: TauModel, extra: NDArray[np.float64]) -> TauModel:
    """The tau model of the simulated sensor plus an Allan variance ``extra`` (additive)."""
    ratio = np.maximum(1.0 + extra / tm.sim_avar, 1e-12)
    return replace(tm, ref=tm.ref + np.log(ratio), sim_avar=tm.sim_avar * ratio)


#: effects whose window means are a deterministic shape, not noise (see level_shape)
LEVEL_SHAPES = ("ramp", "step", "warmup")


def with_level_background(
    tv: TimeView | None,
    chosen: list[Attribution],
    chosen_c: list[Candidate],
    tm: TauModel,
    duration: float,
    cache: dict[str, NDArray[np.float64]],
) -> TimeView | None:
    """The time view with the chosen stationary effects' slow noise added to its null spreads.

    A Gauss-Markov or flicker effect already in the set scatters the window means: the level
    spreads become ``sqrt(s_w^2 + v_w)`` (``v_w`` the effect's own level variance per window,
    :func:`~allanite.diagnosis.time_view.added_level_variance`) and the jump spreads
    ``sqrt(s^2 + 2 A(window))``, so a level shape (ramp, warm-up, step) fitted on top of them
    is judged against the noise the set already has, not against the bare simulation.
    """
    if tv is None or "level" not in tv.spread or "jump" not in tv.spread:
        return tv
    fs, n_fit = 1.0 / tm.dt, round(duration / tm.dt)
    w = tv.level.size
    if n_fit < 2 * w:
        return tv
    v = np.zeros(w)
    a_w = 0.0
    for a, c in zip(chosen, chosen_c, strict=True):
        if c.effect in LEVEL_SHAPES:
            continue
        added = c.added_term({k: a.params[k] for k in c.free})
        if added is None:
            continue
        key = repr(added)
        if key not in cache:
            cache[key] = added_level_variance(added, fs, n_fit, w)
        v = v + cache[key]
        with np.errstate(all="ignore"):
            aw = float(np.asarray(added.avar(np.array([tv.window_s]), tm.dt))[0])
        a_w += aw if np.isfinite(aw) else 0.0
    if not np.any(v > 0) and a_w <= 0:
        return tv
    spread = dict(tv.spread)
    spread["level"] = np.sqrt(spread["level"] ** 2 + v)
    spread["jump"] = np.sqrt(spread["jump"] ** 2 + 2.0 * a_w)
    steps = tv.steps.with_extra(2.0 * a_w) if tv.steps is not None else None
    return replace(tv, level_sd=np.sqrt(tv.level_sd**2 + v), spread=spread, steps=steps)


def _own_extra(a: Attribution, c: Candidate, tm: TauModel) -> NDArray[np.float64]:
    """Return the Allan variance the fitted effect ``a`` adds on the tau grid.

    The candidate's own law at its fitted parameters, whatever ``a`` was fitted on top of.
    """
    with np.errstate(all="ignore"):
        extra = c.extra_avar({k: a.params[k] for k in c.free}, tm.tau, tm.dt)
    return np.asarray(extra, dtype=np.float64)


def _added(on: list[Attribution], on_c: list[Candidate]) -> list[Any]:
    """The processes the fitted effects ``on`` add to the sensor (None: none of its own)."""
    return [c.added_term({k: a.params[k] for k in c.free}) for a, c in zip(on, on_c, strict=True)]


def _on_set(tv: TimeView | None, on: list[Attribution], on_c: list[Candidate]) -> TimeView | None:
    """The time view whose two-level test holds the processes of ``on`` in its null."""
    out: TimeView | None = with_set(tv, [t for t in _added(on, on_c) if t is not None])
    return out


def _pair_starts(
    c: Candidate, single: Attribution | None, tm_bg: TauModel
) -> list[tuple[Candidate, Candidate]]:
    """Start pairs (first, second) for two processes of the repeatable kind ``c``.

    A kind whose locating parameter is fitted (a Gauss-Markov ``tau_c``): the first started
    :data:`DISTINCT_FACTOR` squared below and above the single fit's value (the tau grid's
    middle without one), the second from the candidate's own start. A kind whose locating
    parameter the other views fix (a resonance's frequency): the candidate and each further
    process those views located (:meth:`~allanite.diagnosis.candidates.Candidate.repeats`).
    """
    key = c.repeat_key
    if key is None:
        return []
    if key not in c.free:
        return [(c, r) for r in c.repeats()]
    ref = single.params[key] if single is not None else float(np.sqrt(tm_bg.tau[0] * tm_bg.tau[-1]))
    return [
        (replace(c, start={**c.start, key: t0}), c)
        for t0 in (ref / DISTINCT_FACTOR**2, ref * DISTINCT_FACTOR**2)
    ]


def _two_processes(
    c: Candidate,
    tm_bg: TauModel,
    fit_kw: dict[str, Any],
    single: Attribution | None,
    worse: float,
) -> tuple[float, list[Attribution]] | None:
    """Two processes of the repeatable kind ``c`` fitted together on top of the set.

    A single process of the kind fits a compromise between two distinct ones (e.g. the
    0.015-s wander of a MEMS gyro and a 2-s Gauss-Markov process read as one of 0.5 s, or as
    flicker; a gyro's own 20-Hz resonance next to an injected 35-Hz one read as quantization),
    so the pair is fitted as a unit from the starts of :func:`_pair_starts`: the first
    process, the second on top of it, the first refitted on top of the second. The pair is
    kept under the same rule as one effect (likelihood ratio ``Delta T > chi2_{1-alpha}(k)``
    with ``k`` both processes' parameters, or evidence explained; not worse than
    ``chi2_{1-alpha}(1)``) and scored by the same penalised criterion, ``T_after + k
    chi2_{1-alpha}(1) + `` the evidence both leave unexplained.

    Returns
    -------
    (score, [first, second]) or None
        None when no distinct pair passes.
    """
    key = c.repeat_key
    alpha = float(fit_kw["alpha"])
    evidence_p: dict[str, float] = fit_kw["evidence_p"]
    left: dict[str, bool] = fit_kw["significant"]
    per_param = float(stats.chi2.isf(alpha, 1))
    best: tuple[float, list[Attribution]] | None = None
    t_before = tm_bg.statistic()
    for c1, c2 in _pair_starts(c, single, tm_bg):
        first = fit_candidate(c1, tm_bg, **fit_kw)
        if first is None:
            continue
        e1 = _own_extra(first, c1, tm_bg)
        second = fit_candidate(c2, with_background(tm_bg, e1), **fit_kw)
        if second is None or not _distinct(second, c2, [first], [c1]):
            continue
        e2 = _own_extra(second, c2, tm_bg)
        refit = (key,) if key in c1.free else c1.free
        again = fit_candidate(
            replace(c1, start={**c1.start, **{k: first.params[k] for k in refit}}),
            with_background(tm_bg, e2),
            **fit_kw,
        )
        if again is not None and _distinct(again, c1, [second], [c2]):
            e_again = _own_extra(again, c1, tm_bg)
            if tm_bg.statistic(e_again + e2) < tm_bg.statistic(e1 + e2):
                first, e1 = again, e_again
        t_after = tm_bg.statistic(e1 + e2)
        k = len(c1.free) + len(c2.free)
        explained = set(first.evidence.get("explained", [])) | set(
            second.evidence.get("explained", [])
        )
        lr_p = float(stats.chi2.sf(max(t_before - t_after, 0.0), k))
        if (lr_p >= alpha and not explained) or t_before - t_after <= -worse:
            continue
        unexplained = [e for e, sig in left.items() if sig and e not in explained]
        penalty = sum(
            min(-2.0 * np.log(max(evidence_p[e], 1e-300)), EVIDENCE_CAP) for e in unexplained
        )
        score = float(t_after + k * per_param + penalty)
        if best is None or score < best[0]:
            best = (score, [first, second])
    return best


#: a warm-up measured on the window means settles within the record: its time constant is at
#: most the record over this factor (the transient decays to e^-4 = 2 % by the end); a slower
#: one is a drift over the whole record, which a ramp or a random walk describes (a bias step
#: under a random walk was read as a warm-up with T_w the record's length)
WARMUP_SETTLES = 4.0


def _measured_level_shape(
    effect: str, view: TimeView, duration: float, per_param: float
) -> dict[str, float] | None:
    """Parameters of a warm-up or ramp measured on the window means; None for other effects.

    A ramp only where the window means follow a line at least as well as bias steps (with
    their penalty, :func:`~allanite.diagnosis.level_shape.level_misfit`): a step under white
    noise also has a slope on the window means, and was read as a ramp plus noise.
    """
    if effect == "warmup":
        tau_w, amp, _ = warmup_shape(view, duration)
        if amp == 0.0 or tau_w * WARMUP_SETTLES > duration:
            return None
        return {"tau_w": tau_w, "amplitude": amp}
    if effect == "ramp":
        slope, _ = ramp_shape(view, duration)
        steps = level_misfit("step", view, duration, per_param)
        if slope == 0.0 or level_misfit("ramp", view, duration, per_param) > steps:
            return None
        return {"R": abs(slope)}
    return None


def _shape_gain(effect: str, view: TimeView, duration: float) -> float:
    """Drop of the window means' ``chi^2`` the measured warm-up or ramp brings."""
    return warmup_shape(view, duration)[2] if effect == "warmup" else ramp_shape(view, duration)[1]


def _shape_and_noise(
    shape_c: Candidate,
    partners: list[Candidate],
    tm: TauModel,
    fit_kw: dict[str, Any],
    duration: float,
    cache: dict[str, NDArray[np.float64]],
) -> list[tuple[float, list[Attribution]]]:
    """A warm-up or ramp measured on the window means, with each stationary partner on top.

    The tau view alone cannot split a warm-up from slow noise next to it (a Gauss-Markov
    process or a random walk: their Allan variances imitate each other), and a warm-up fitted
    alone there takes the noise's Allan variance as well, while its window-mean shape misfit
    counts the noise's wander against it; a random walk then explains the level alone. A
    warm-up is deterministic and sits in the first windows: the window means measure it
    (:func:`~allanite.diagnosis.level_shape.warmup_shape`, amplitude and time constant fixed
    there; it must settle within the record, ``T_w <= T /`` :data:`WARMUP_SETTLES`), and each
    partner is fitted on top of it in the tau view, against the evidence the warm-up leaves.
    A pair is kept when the partner passes its own test on top of the warm-up and the warm-up
    still lowers the window means' ``chi^2`` by more than ``chi2_{1-alpha}(2)`` with the
    partner's slow noise in their spreads (:func:`with_level_background`); it is scored like
    one effect, ``T_after + k chi2_{1-alpha}(1)`` (``k`` the partner's free parameters and the
    warm-up's amplitude) plus the evidence both leave and the warm-up's shape misfit against
    those spreads. A ramp under slow noise is the same case (the tau view reads a ramp next to
    a Gauss-Markov process as a random walk): its slope is measured on the window means
    (:func:`~allanite.diagnosis.level_shape.ramp_shape`, one parameter, gain against
    ``chi2_{1-alpha}(1)``).
    """
    view: TimeView | None = fit_kw["time_view"]
    alpha = float(fit_kw["alpha"])
    evidence_p: dict[str, float] = fit_kw["evidence_p"]
    left: dict[str, bool] = fit_kw["significant"]
    if view is None or "level" not in view.spread:
        return []
    per_param = float(stats.chi2.isf(alpha, 1))
    measured_params = _measured_level_shape(shape_c.effect, view, duration, per_param)
    if measured_params is None:
        return []
    fixed = {**shape_c.fixed, **measured_params}
    measured = replace(shape_c, fixed=fixed, free=tuple(n for n in shape_c.free if n not in fixed))
    shape = fit_candidate(measured, tm, **fit_kw)
    if shape is None:
        return []
    e_shape = np.asarray(measured.extra_avar({}, tm.tau, tm.dt), dtype=np.float64)
    told = set(shape.evidence.get("explained", []))
    rest = {e: s and e not in told for e, s in left.items()}
    tm_shape = with_background(tm, e_shape)
    gain = float(stats.chi2.isf(alpha, len(measured_params)))
    out = []
    view_shape = _on_set(view, [shape], [measured])  # the shape in the two-level null
    for c in partners:
        a = fit_candidate(c, tm_shape, **{**fit_kw, "significant": rest, "time_view": view_shape})
        if a is None:
            continue
        view_bg = with_level_background(view, [a], [c], tm, duration, cache)
        if view_bg is None or _shape_gain(shape_c.effect, view_bg, duration) <= gain:
            continue
        explained = told | set(a.evidence.get("explained", []))
        unexplained = [e for e, sig in left.items() if sig and e not in explained]
        penalty = sum(
            min(-2.0 * np.log(max(evidence_p[e], 1e-300)), EVIDENCE_CAP) for e in unexplained
        )
        k = len(shape_c.free) + len(c.free)
        t_after = tm.statistic(e_shape + _own_extra(a, c, tm))
        misfit = level_misfit(shape_c.effect, view_bg, duration, per_param)
        out.append((float(t_after + k * per_param + penalty + misfit), [shape, a]))
    return out


#: deterministic level shapes whose Welch spectrum is their own samples' (see effect_psd)
WELCH_SHAPES = ("ramp", "warmup")


def shape_welch_psd(term: Any, n: int, dt: float, nperseg: int) -> NDArray[np.float64]:
    """Welch PSD (the frequency view's estimate, bins above DC) of a deterministic shape.

    Each Welch segment loses its mean, not its slope: a ramp leaves a linear trend of the
    same size in every segment, whose leakage is a ``1/f^2`` excess at the lowest bins; a
    warm-up leaves its decay in the first segments. The shape is independent of the noise, so
    it adds its own Welch spectrum (cross terms average out).
    """
    from allanite.diagnosis.frequency_view import frequency_features
    from allanite.model import NoiseModel

    x = NoiseModel((term,)).simulate(n, fs=1.0 / dt, seed=0)
    x = np.asarray(x, dtype=np.float64).ravel()
    return np.exp(frequency_features(x, 1.0 / dt, nperseg)["log_psd"])


def effect_psd(
    a: Attribution, c: Candidate, f: NDArray[np.float64], dt: float, n: int | None = None
) -> NDArray[np.float64]:
    """One-sided PSD (on ``f``) the fitted effect ``a`` adds to the simulated sensor.

    The candidate's :meth:`~allanite.diagnosis.candidates.Candidate.extra_psd`. A ramp or a
    warm-up adds the Welch spectrum of its own samples over the ``n`` fitted samples
    (:func:`shape_welch_psd`, ``f`` the frequency view's bins); without ``n``, and for any
    other term without a PSD, none.
    """
    values = {k: a.params[k] for k in c.free}
    if c.effect in WELCH_SHAPES and n is not None and f.size > 1:
        nperseg = round(1.0 / (dt * float(f[1] - f[0])))
        if nperseg // 2 == f.size and n >= nperseg:
            return shape_welch_psd(c.term(values), n, dt, nperseg)
    try:
        with np.errstate(all="ignore"):
            out = c.extra_psd(values, f, dt)
    except NotImplementedError:
        return np.zeros_like(f)
    out = np.asarray(out, dtype=np.float64)
    return np.where(np.isfinite(out), out, 0.0)


def _same_slot(c: Candidate, chosen: list[Candidate]) -> bool:
    """Whether ``c`` changes a model term already changed or adds a type already chosen.

    Adding white noise after rescaling it (or rescaling it twice) is the same effect. A
    process of a :data:`~allanite.diagnosis.candidates.REPEATABLE` kind (a Gauss-Markov
    process, a resonance) may be added once more next to one already in the set (added or
    rescaled): two distinct such processes are two effects; :func:`_distinct` then checks
    the fitted one.
    """
    for d in chosen:
        repeat = c.repeat_key is not None and d.term_cls is c.term_cls
        if repeat and sum(e.effect == c.effect for e in chosen) < 2:
            continue
        if c.effect == d.effect or c.term_cls is d.term_cls:  # white and rescale:white alike
            return True
        for t in (c.base, c.replaces):
            if t is not None and t in (d.base, d.replaces):
                return True
    return False


def _distinct(a: Attribution, c: Candidate, on: list[Attribution], on_c: list[Candidate]) -> bool:
    """Whether a fitted repeatable effect ``a`` is a process distinct from those of the set.

    It must be distinct (:meth:`~allanite.diagnosis.candidates.Candidate.distinct`: correlation
    times more than :data:`DISTINCT_FACTOR` apart, resonance bands that do not overlap) from
    every process of its kind already in the set (an added one, or the model's term a rescale
    scales); otherwise it is that process with another size, which the set describes by
    refitting it (exchange pass), not by a second one.
    """
    if c.repeat_key is None:
        return True
    for b, d in zip(on, on_c, strict=True):
        if d.term_cls is not c.term_cls:
            continue
        other = b.params if d.base is None else d.base.values()
        if not c.distinct(a.params, other):
            return False
    return True


def _moved(refit: Attribution, old: Attribution, c: Candidate) -> bool:
    """Whether a refit moves a free parameter of ``c`` by more than its standard error.

    The standard error is the old fit's Fisher one (``params_sigma``); a parameter without a
    finite one does not count as moved.
    """
    for k in c.free:
        sigma = old.params_sigma.get(k, float("nan"))
        if np.isfinite(sigma) and abs(refit.params[k] - old.params[k]) > sigma:
            return True
    return False


def _backfit(
    a: Attribution,
    c: Candidate,
    on: list[Attribution],
    on_c: list[Candidate],
    tm: TauModel,
    fit_kw: dict[str, Any],
    significant: dict[str, bool],
) -> tuple[Attribution | None, list[Attribution]] | None:
    """One backfitting sweep of the set ``on`` with the new effect ``a`` (fitted on top of it).

    Each effect of the set was fitted before ``a`` existed and may have taken part of ``a``'s
    Allan variance (a resonance fitted alone takes some of the extra white noise next to it,
    which then overshoots the shortest taus; a low-pass look-alike fits that overshoot better
    than the white noise itself). So each effect of the set is refitted, from its own values,
    on top of the others and ``a``, and then ``a`` on top of the refitted set. An effect of
    the set keeps its old fit when its refit is not kept, explains less of the evidence, moves
    no parameter by more than that parameter's own standard error (:func:`_moved`: within it
    the refit is the same fit at the record's resolution, and adopting it would let the fit's
    rounding decide a tie between look-alikes), or is a level shape (measured on the window
    means, not on the tau view). Returns None when no effect of the set changes or the sweep
    does not lower ``T`` of the whole set; otherwise
    the refitted ``a`` (None: it no longer passes its test on top of the refitted set) and the
    refitted set.
    """
    extras = [_own_extra(b, d, tm) for b, d in zip(on, on_c, strict=True)]
    e_a = _own_extra(a, c, tm)
    view = fit_kw["time_view"]
    t_old = tm.statistic(np.sum(extras, axis=0) + e_a)
    new = list(on)
    changed = False
    for j, (b, d) in enumerate(zip(on, on_c, strict=True)):
        if d.effect in LEVEL_SHAPES or (d.base is None and not d.free):
            continue
        others = [e for i, e in enumerate(extras) if i != j]
        told = set(a.evidence.get("explained", [])).union(
            *(set(x.evidence.get("explained", [])) for i, x in enumerate(new) if i != j)
        )
        left = {e: s and e not in told for e, s in significant.items()}
        start = {k: b.params[k] for k in d.free} if d.base is None else {}
        rest = [x for i, x in enumerate(new) if i != j] + [a]
        rest_c = [x for i, x in enumerate(on_c) if i != j] + [c]
        refit = fit_candidate(
            replace(d, start={**d.start, **start}),
            with_background(tm, np.sum(others, axis=0) + e_a),
            **{**fit_kw, "significant": left, "time_view": _on_set(view, rest, rest_c)},
        )
        if (
            refit is None
            or not set(b.evidence.get("explained", [])) <= set(refit.evidence.get("explained", []))
            or not _distinct(refit, d, rest, rest_c)
        ):
            continue
        if not _moved(refit, b, d):
            continue
        new[j], extras[j] = refit, _own_extra(refit, d, tm)
        changed = True
    if not changed:
        return None
    start = {k: a.params[k] for k in c.free} if c.base is None else {}
    again = fit_candidate(
        replace(c, start={**c.start, **start}),
        with_background(tm, np.sum(extras, axis=0)),
        **{**fit_kw, "time_view": _on_set(view, new, on_c)},
    )
    if again is not None and not _distinct(again, c, new, on_c):
        again = None
    e_again = _own_extra(again, c, tm) if again is not None else np.zeros_like(e_a)
    if tm.statistic(np.sum(extras, axis=0) + e_again) >= t_old:
        return None
    return again, new


def _candidate_of(a: Attribution, by_effect: dict[str, Candidate]) -> Candidate:
    """The candidate ``a`` was fitted from: its effect's, or the further process it is.

    A second resonance is its effect's candidate with another band's shape fixed
    (:meth:`~allanite.diagnosis.candidates.Candidate.repeats`).
    """
    c = by_effect[a.effect]
    for r in c.repeats():
        if all(a.params.get(k) == v for k, v in r.fixed.items()) and r.fixed != c.fixed:
            return r
    return c


def explain(
    best: Attribution,
    candidates: list[Candidate],
    tm: TauModel,
    *,
    alpha: float,
    evidence_p: dict[str, float],
    significant: dict[str, bool],
    time_view: TimeView | None,
    duration: float,
    frequency: FrequencyView | None = None,
) -> Explanation:
    """Forward selection from ``best``, then the backward check (see the module docstring).

    With ``frequency`` (the frequency view of the same record), candidates on top of the set
    are ordered by score plus the spectral shape misfit of the set with them.
    """
    by_effect = {c.effect: c for c in candidates}
    cache: dict[str, NDArray[np.float64]] = {}
    worse = float(stats.chi2.isf(alpha, 1))
    n_fit = round(duration / tm.dt)

    def on_top(
        on: list[Attribution],
        on_c: list[Candidate],
        tm_bg: TauModel,
        left: dict[str, bool],
        room: int = 1,
        singles: list[Attribution] | None = None,
    ) -> list[tuple[list[Attribution], list[Attribution]]]:
        """The candidates of another slot, ranked on top of the effects ``on``.

        Each entry is a group of effects to add: one effect, or (with ``room`` for two) two
        processes of a repeatable kind fitted together (:func:`_two_processes`), which
        forward selection of one effect at a time never reaches when a single process of that
        kind fits a compromise between them. An effect that explains time/frequency evidence
        but makes the tau view significantly worse is not an explanation of this record.
        ``singles`` (the opening step): the single effects already ranked, not refitted.
        Each entry comes with the set it is judged on: ``on``, or ``on`` refitted with a
        single effect on top when that fits better (:func:`_backfit`); the caller adopts it.
        """
        fit_kw: dict[str, Any] = {
            "alpha": alpha,
            "evidence_p": evidence_p,
            "significant": left,
            "time_view": _on_set(
                with_level_background(time_view, on, on_c, tm, duration, cache), on, on_c
            ),
            "duration": duration,
        }
        if singles is not None:
            kept = singles
        else:
            # next to one process of a repeatable kind: the further processes the views located
            pool = [c for c in candidates if not _same_slot(c, on_c)]
            pool += [
                r for c in pool if any(d.effect == c.effect for d in on_c) for r in c.repeats()
            ]
            kept = [
                a
                for a in rank(pool, tm_bg, **fit_kw)
                if a.evidence["tau"]["delta_T"] > -worse
                and _distinct(a, _candidate_of(a, by_effect), on, on_c)
            ]
        # each single effect judged on the set refitted with it (one backfitting sweep)
        sets: dict[int, list[Attribution]] = {}
        if on and singles is None:
            refitted = []
            for a in kept:
                c_a = _candidate_of(a, by_effect)
                got = _backfit(a, c_a, on, on_c, tm, fit_kw, significant)
                if got is None:
                    refitted.append(a)
                elif got[0] is not None:
                    refitted.append(got[0])
                    sets[id(got[0])] = got[1]
            kept = refitted
        groups: list[tuple[float, list[Attribution]]] = [(a.score, [a]) for a in kept]
        if singles is not None and room >= 2:
            # the opening: a warm-up or ramp the window means measure, slow noise next to it
            partners = [c for c in candidates if c.effect not in LEVEL_SHAPES]
            for c in candidates:
                groups += _shape_and_noise(c, partners, tm_bg, fit_kw, duration, cache)
        if room >= 2:
            for c in candidates:
                if c.repeat_key is None or any(d.term_cls is c.term_cls for d in on_c):
                    continue
                single = next((a for a in kept if a.effect == c.effect), None)
                pair = _two_processes(c, tm_bg, fit_kw, single, worse)
                if pair is not None:
                    groups.append(pair)

        def base(g: list[Attribution]) -> list[Attribution]:
            return sets.get(id(g[0]), on)

        if frequency is None or len(groups) < 2:
            return [(g, base(g)) for _, g in sorted(groups, key=lambda g: g[0])]
        f = frequency.f

        def joint_score(group: tuple[float, list[Attribution]]) -> float:
            extra = sum(
                effect_psd(a, _candidate_of(a, by_effect), f, tm.dt, n_fit)
                for a in [*base(group[1]), *group[1]]
            )
            return group[0] + frequency.shape_misfit(np.asarray(extra, dtype=np.float64))

        scored = sorted(((joint_score(g), g[1]) for g in groups), key=lambda s: s[0])
        # the alternatives of a single effect are re-judged on the joint score: a tie in the
        # tau view that the spectrum breaks is no tie, and one the spectrum leaves is
        # reported, not resolved blindly in favour of the simpler effect
        ones = [(s, g[0]) for s, g in scored if len(g) == 1]
        margin = float(stats.chi2.isf(alpha, 1))
        return [
            (
                [
                    replace(
                        g[0],
                        alternatives=tuple(
                            b.effect for t, b in ones if b is not g[0] and abs(t - s) < margin
                        ),
                    )
                ]
                if len(g) == 1
                else g,
                base(g),
            )
            for s, g in scored
        ]

    # the opening: the best single effect, or two processes of a repeatable kind fitted as a
    # unit when they fit better (a single resonance at one of two bands leaves the other's
    # excess in the tau view, and a look-alike wins the single ranking)
    opening = on_top(
        [], [], tm, {e: bool(s) for e, s in significant.items()}, MAX_EFFECTS, singles=[best]
    )[0][0]
    chosen = [best] if len(opening) == 1 else list(opening)  # best keeps its alternatives
    chosen_c = [_candidate_of(a, by_effect) for a in chosen]
    extras = [_own_extra(a, c, tm) for a, c in zip(chosen, chosen_c, strict=True)]
    explained = set().union(*(set(a.evidence.get("explained", [])) for a in chosen))
    gaps = [tm.gap()] + [tm.gap(np.sum(extras[: j + 1], axis=0)) for j in range(len(extras))]
    while len(chosen) < MAX_EFFECTS:
        total = np.sum(extras, axis=0)
        k_total = sum(len(c.free) for c in chosen_c)
        left = {e: bool(s) and e not in explained for e, s in significant.items()}
        held = tm.holding(_added(chosen, chosen_c))
        if held.p_value(total, n_params=k_total) > alpha and not any(left.values()):
            break
        tm_bg = with_background(tm, total)
        groups = on_top(chosen, chosen_c, tm_bg, left, room=MAX_EFFECTS - len(chosen))
        if not groups:
            break
        group, refitted = groups[0]
        if refitted is not chosen:  # the set refitted with the new effect on top
            chosen = list(refitted)
            extras = [_own_extra(a, c, tm) for a, c in zip(chosen, chosen_c, strict=True)]
        for nxt in group:
            chosen.append(nxt)
            chosen_c.append(_candidate_of(nxt, by_effect))
            extras.append(_own_extra(nxt, _candidate_of(nxt, by_effect), tm))
            explained |= set(nxt.evidence.get("explained", []))
            gaps.append(tm.gap(np.sum(extras, axis=0)))
    # exchange: each effect refitted against every candidate on top of the others
    for _ in range(2):
        swapped = False
        for i in range(len(chosen)):
            others_c = [c for j, c in enumerate(chosen_c) if j != i]
            others = [e for j, e in enumerate(extras) if j != i]
            bg = np.sum(others, axis=0) if others else np.zeros_like(tm.sim_avar)
            tm_bg = with_background(tm, bg)
            told = set().union(
                *(set(a.evidence.get("explained", [])) for j, a in enumerate(chosen) if j != i)
            )
            left = {e: bool(s) and e not in told for e, s in significant.items()}
            others_a = [a for j, a in enumerate(chosen) if j != i]
            kept = [(g[0], s) for g, s in on_top(others_a, others_c, tm_bg, left) if len(g) == 1]
            # the same term added or rescaled (white, rescale:white) is the same effect: only
            # the spectral misfit's rounding could tell them apart, so the incumbent stays
            if not kept or _candidate_of(kept[0][0], by_effect).term_cls is chosen_c[i].term_cls:
                continue
            top, refitted = kept[0]
            for j, a in zip([j for j in range(len(chosen)) if j != i], refitted, strict=True):
                chosen[j], extras[j] = a, _own_extra(a, chosen_c[j], tm)
            chosen[i], chosen_c[i] = top, _candidate_of(top, by_effect)
            extras[i] = _own_extra(top, chosen_c[i], tm)
            swapped = True
        if not swapped:
            break
    gaps = [gaps[0]] + [tm.gap(np.sum(extras[: j + 1], axis=0)) for j in range(len(extras))]
    # backward check
    i = 0
    while len(chosen) > 1 and i < len(chosen):
        others = [e for j, e in enumerate(extras) if j != i]
        t_without = tm.statistic(np.sum(others, axis=0))
        t_with = tm.statistic(np.sum(extras, axis=0))
        k = len(chosen_c[i].free)
        own = set(chosen[i].evidence.get("explained", []))
        rest = set().union(
            *(set(a.evidence.get("explained", [])) for a in chosen if a is not chosen[i])
        )
        if stats.chi2.sf(max(t_without - t_with, 0.0), max(k, 1)) >= alpha and own <= rest:
            del chosen[i], chosen_c[i], extras[i]
            gaps = [gaps[0]] + [tm.gap(np.sum(extras[: j + 1], axis=0)) for j in range(len(extras))]
            continue
        i += 1
    total = np.asarray(np.sum(extras, axis=0), dtype=np.float64)
    k_total = sum(len(c.free) for c in chosen_c)
    # judged against a null that holds the set (bursts change the covariance, not only the mean)
    p_after = tm.holding(_added(chosen, chosen_c)).p_value(total, n_params=k_total)
    g0 = gaps[0]
    share: dict[str, float] = {}
    for j, a in enumerate(chosen):
        share[share_key(a.effect, share)] = float((gaps[j] - gaps[j + 1]) / g0) if g0 > 0 else 0.0
    share["remainder"] = float(gaps[-1] / g0) if g0 > 0 else 0.0
    explained = set().union(*(set(a.evidence.get("explained", [])) for a in chosen))
    return Explanation(
        effects=chosen,
        candidates=chosen_c,
        gap_before=g0,
        gap_after=gaps[-1],
        consistent_after=bool(p_after > alpha),
        p_after=p_after,
        share=share,
        explained=sorted(explained),
        extra_avar=total,
    )


def share_key(effect: str, share: dict[str, float]) -> str:
    """The key of ``effect`` in ``share``: its name, ``<name>_2`` for a second process of it."""
    if effect not in share:
        return effect
    n = 2
    while f"{effect}_{n}" in share:
        n += 1
    return f"{effect}_{n}"


def combined_terms(explanation: Explanation, model: Any) -> list[dict[str, Any]]:
    """Model JSON ``terms`` of the simulated sensor with the effects added (or rescaled)."""
    terms = list(model.terms) if model is not None else []
    out: list[Any] = list(terms)
    for a, c in zip(explanation.effects, explanation.candidates, strict=True):
        target = c.base if c.base is not None else c.replaces
        if target is not None and target in out:
            out[out.index(target)] = a.term
        else:
            out.append(a.term)
    return [t if isinstance(t, dict) else t.to_dict() for t in out]
