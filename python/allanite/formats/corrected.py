"""Fold a diagnosis into a simulator config: the corrected model the simulator should use.

The effects of a :class:`~allanite.diagnosis.result.Diagnosis` are applied to the simulated
sensor's model: the joint explanation's effects when the gap needs several (as far as the
target format represents them), else the best attribution the format can represent.
``rescale:<type>`` replaces that term by its rescaled copy, ``lowpass`` replaces the white
noise by low-passed white noise, any other effect is added. An effect the format can neither
hold nor project (a sensor low-pass filter in a simulator without one, a sinusoid, ...) is
skipped in favour of the next one, and said. The format's writer then holds what it can and
lists the rest (:mod:`.projection`).
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np

from allanite.model import NoiseModel
from allanite.terms import Term, term_from_dict

__all__ = ["corrected_model", "representable"]


def _replace_first(model: NoiseModel, kind: str, new: Term) -> NoiseModel:
    terms = list(model.terms)
    for i, term in enumerate(terms):
        if term.type == kind:
            terms[i] = new
            return NoiseModel(tuple(terms), model.units)
    return model.plus(new)


def representable(effect: str, term_type: str, holds: frozenset[str] | None) -> bool:
    """Whether a format holding ``holds`` can represent an effect (held, or projected)."""
    if holds is None:
        return True
    from allanite.formats.projection import SLOW_TYPES

    slow = bool(holds & {"markov", "rrw"})
    if effect.startswith("rescale:"):
        kind = effect.split(":", 1)[1]
        return kind in holds or (slow and kind in SLOW_TYPES)
    return term_type in holds or (slow and term_type in SLOW_TYPES)


def _fold(model: NoiseModel, effect: str, term_dict: dict[str, Any]) -> NoiseModel:
    """``model`` with one attributed effect folded in (rescale, low-pass or an added term)."""
    term = term_from_dict(dict(term_dict))
    if effect.startswith("rescale:"):
        return _replace_first(model, effect.split(":", 1)[1], term)
    if effect == "lowpass":
        return _replace_first(model, "white", term)
    return model.plus(term)


def _params(a: Any, model: NoiseModel) -> str:
    """The effect's parameters as ``allanite diagnose`` shows them (customary units)."""
    from allanite.diagnosis.verdict import format_params

    return format_params(a, model.units.get("rate"))


def _joint(
    model: NoiseModel, diagnosis: Any, holds: frozenset[str] | None
) -> tuple[NoiseModel, str, list[Any]] | None:
    """The joint explanation's effects folded in, as far as the format represents them.

    Each effect of the set was fitted on top of the previous ones, so the longest prefix the
    format can represent is folded in; None when the set has fewer than two effects or its
    first cannot be represented (then the best single effect the format holds is used).
    """
    explanation: Any = getattr(diagnosis, "explanation", None)
    effects = list(getattr(explanation, "effects", None) or [])
    if len(effects) < 2:
        return None
    prefix = []
    for a in effects:
        if not representable(a.effect, str(a.term.get("type", "")), holds):
            break
        prefix.append(a)
    if not prefix:
        return None
    out = model
    for a in prefix:
        out = _fold(out, a.effect, a.term)
    folded = "; ".join(f"{a.effect} ({_params(a, model)}{_written(a, out, model)})" for a in prefix)
    if len(prefix) == len(effects):
        gap = (
            f"gap {explanation.gap_before:.4g} -> {explanation.gap_after:.4g} "
            f"(shrinkage {100 * (1 - explanation.gap_after / explanation.gap_before):.0f} %)"
            if explanation.gap_before > 0
            else ""
        )
        return out, f"folded in the joint explanation: {folded}; {gap}".rstrip("; "), prefix
    left = ", ".join(a.effect for a in effects[len(prefix) :])
    return (
        out,
        f"folded in {folded}; left out {left} of the joint explanation (the format cannot "
        "represent it, and what follows was fitted on top of it)",
        prefix,
    )


def corrected_model(
    model: NoiseModel, diagnosis: Any, holds: frozenset[str] | None = None
) -> tuple[NoiseModel, str]:
    """Return ``(model with the diagnosed effects folded in, one-line description)``.

    When the diagnosis explains the gap by several effects (its joint explanation), all of
    them are folded in, as far as the format represents them (see :func:`_joint`); otherwise
    the best single attribution the format can represent. ``holds`` are the term types of
    the target format (None: all). The model is unchanged when the gap is not significant
    or no representable effect was attributed.
    """
    if not diagnosis.significant or not diagnosis.attribution:
        return model, "no significant gap: the config is written unchanged"
    joint = _joint(model, diagnosis, holds)
    if joint is not None:
        return _bounded(joint[0], joint[1], joint[2], model, diagnosis)
    usable = [
        a
        for a in diagnosis.attribution
        if representable(a.effect, str(a.term.get("type", "")), holds)
    ]
    skipped = (
        [a.effect for a in diagnosis.attribution[: diagnosis.attribution.index(usable[0])]]
        if usable
        else [a.effect for a in diagnosis.attribution]
    )
    note = f"; skipped {', '.join(skipped)} (the format cannot represent it)" if skipped else ""
    if not usable:
        return model, "no attributed effect can be represented in the format" + note
    best = usable[0]
    out = _fold(model, best.effect, best.term)
    what = (
        f"folded in {best.effect} ({_params(best, model)}{_written(best, out, model)}); gap "
        f"{best.gap_before:.4g} -> {best.gap_after:.4g} (shrinkage {100 * best.shrinkage:.0f} %)"
        f"{note}"
    )
    return _bounded(out, what, [best], model, diagnosis)


#: term types whose repeated terms the formats merge into one (their variances add)
_ADDING = ("white", "rrw", "quantization", "turn_on_bias")


def _stated(a: Any, params: dict[str, float]) -> Any:
    """``a`` as :func:`_params` reads it, with other parameter values and no uncertainty."""
    return SimpleNamespace(effect=a.effect, term=a.term, params=params, params_sigma={})


def _written(a: Any, out: NoiseModel, model: NoiseModel) -> str:
    """What is written for an added term of a type the config already has (they merge).

    White noise added to the configured white noise is written as one white noise whose
    variance is the sum: the file holds that coefficient, not the added one, so both are said.
    """
    kind = str(a.term.get("type", ""))
    if a.effect.startswith("rescale:") or kind not in _ADDING or not model.terms_of_type(kind):
        return ""
    terms = out.terms_of_type(kind)
    coef = terms[0].params[0].name
    total = math.sqrt(sum(float(t.values()[coef]) ** 2 for t in terms))
    shown = _stated(a, {coef: total})
    return f" added to the configured {kind}: written {_params(shown, model)}"


def _upper_scale(term: Term, rest: NoiseModel, diagnosis: Any) -> float | None:
    """The largest factor on ``term`` that the record's Allan variance allows, or None.

    The record's estimate at each tau is consistent with a model Allan variance ``m`` while it
    lies above the lower edge of the chance band around ``m``; with the band's relative width
    (``sim_low / sim_avar`` of the tau view) that is ``m <= real_avar sim_avar / sim_low``. The
    factor ``s`` keeps ``rest + s^2 term`` under that limit at every tau where ``rest`` does.
    """
    view = diagnosis.tau
    tau = np.asarray(view.tau, dtype=float)
    dt = 1.0 / float(diagnosis.meta["fs"])
    with np.errstate(divide="ignore", invalid="ignore"):
        upper = np.asarray(view.real_avar) * np.asarray(view.sim_avar) / np.asarray(view.sim_low)
    own = np.asarray(term.avar(tau, dt), dtype=float)
    room = upper - np.asarray(rest.avar(tau, dt), dtype=float)
    keep = np.isfinite(room) & (room > 0) & (own > 0)
    if not np.any(keep):
        return None
    return float(np.sqrt(np.min(room[keep] / own[keep])))


def _deciding(term: Term, rest: NoiseModel, diagnosis: Any) -> tuple[float, float]:
    """``(tau, record length)`` at which ``term`` would rise clearly above ``rest``, in seconds.

    The tau where the term's Allan deviation first reaches twice the rest of the model's (the
    slope of the term emerging above the curve), beyond the longest tau measured; the record that
    measures that tau as this one measures its longest is longer by the same factor, and at
    least :data:`SEVERAL` times this one (the longest tau has few degrees of freedom).
    """
    longest = float(diagnosis.tau.tau[-1])
    dt = 1.0 / float(diagnosis.meta["fs"])
    record = _length(diagnosis)
    tau = np.geomspace(longest, longest * 1e6, 241)
    above = np.asarray(term.avar(tau, dt)) >= 4.0 * np.asarray(rest.avar(tau, dt))
    at = float(tau[int(np.argmax(above))]) if np.any(above) else float(tau[-1])
    # at the longest tau of this record the estimate has a few degrees of freedom: a
    # term that stands out there needs a record several times longer to be measured
    return at, max(record * at / longest, SEVERAL * record)


#: how many times longer than this one a record must be to measure a term at its longest tau
SEVERAL = 4.0


def _length(diagnosis: Any) -> float:
    """Duration of the diagnosed record in seconds."""
    return float(diagnosis.meta["n_samples"]) / float(diagnosis.meta["fs"])


def _bounded(
    out: NoiseModel, what: str, folded: list[Any], model: NoiseModel, diagnosis: Any
) -> tuple[NoiseModel, str]:
    """``out`` without coefficients the record does not determine, and what was done instead.

    A rescale fitted at its floor (:data:`~allanite.diagnosis.attribution.RESCALE_FLOOR`)
    says the term is not seen in the record: an upper limit, not a value. The configured
    coefficient is kept when the record allows it, else the largest value it allows
    (:func:`_upper_scale`) is written; the text says so, with the record length that would
    measure the coefficient (:func:`_deciding`).
    """
    from allanite.diagnosis.attribution import RESCALE_FLOOR

    notes = []
    for a in folded:
        if not a.effect.startswith("rescale:") or a.params.get("scale", 1.0) > 1.01 * RESCALE_FLOOR:
            continue
        kind = a.effect.split(":", 1)[1]
        base = model.terms_of_type(kind)[0]
        rest = NoiseModel(tuple(t for t in out.terms if t.type != kind), out.units)
        scale = _upper_scale(base, rest, diagnosis)
        kept = scale is None or scale >= 1.0
        coef = base.params[0].name
        new = (
            base
            if scale is None or kept
            else base.with_values(**{coef: scale * base.values()[coef]})
        )
        out = _replace_first(out, kind, new)
        what = what.replace(f"{a.effect} ({_params(a, model)}", f"{a.effect} (not determined")
        bound = _stated(a, dict(new.values()))
        tau, record = _deciding(new, rest, diagnosis)
        length = _length(diagnosis)
        notes.append(
            f"{kind} not determined by this {length:.4g} s record (its rescale sits at the "
            f"search floor x{RESCALE_FLOOR:g}: no {kind} is seen, which bounds it from above); "
            + (
                f"the configured {_params(bound, model)} is kept (the record allows it)"
                if kept
                else f"written at its upper limit {_params(bound, model)}, the largest the record "
                "allows, instead of the floor value"
            )
            + f"; at that size its slope would stand out of the measured curve (twice its "
            f"Allan deviation) at tau ~ {tau:.3g} s: a record of at least {record:.3g} s "
            f"({record / length:.2g}x this one) would measure it (a smaller one needs longer)"
        )
    if not notes:
        return out, what
    return out, what + "; " + "; ".join(notes)
