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

from typing import Any

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
) -> tuple[NoiseModel, str] | None:
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
    folded = "; ".join(f"{a.effect} ({_params(a, model)})" for a in prefix)
    if len(prefix) == len(effects):
        gap = (
            f"gap {explanation.gap_before:.4g} -> {explanation.gap_after:.4g} "
            f"(shrinkage {100 * (1 - explanation.gap_after / explanation.gap_before):.0f} %)"
            if explanation.gap_before > 0
            else ""
        )
        return out, f"folded in the joint explanation: {folded}; {gap}".rstrip("; ")
    left = ", ".join(a.effect for a in effects[len(prefix) :])
    return out, (
        f"folded in {folded}; left out {left} of the joint explanation (the format cannot "
        "represent it, and what follows was fitted on top of it)"
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
        return joint
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
    return out, (
        f"folded in {best.effect} ({_params(best, model)}); gap {best.gap_before:.4g} -> "
        f"{best.gap_after:.4g} (shrinkage {100 * best.shrinkage:.0f} %){note}"
    )
