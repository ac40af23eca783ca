"""Fold a diagnosis into a simulator config: the corrected model the simulator should use.

The best attribution of a :class:`~allanite.diagnosis.result.Diagnosis` that the target
format can represent is applied to the simulated sensor's model: ``rescale:<type>`` replaces
that term by its rescaled copy, ``lowpass`` replaces the white noise by low-passed white
noise, any other effect is added. An effect the format can neither hold nor project (a sensor
low-pass filter in a simulator without one, a sinusoid, ...) is skipped in favour of the next
one, and said. The format's writer then holds what it can and lists the rest
(:mod:`.projection`).
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


def corrected_model(
    model: NoiseModel, diagnosis: Any, holds: frozenset[str] | None = None
) -> tuple[NoiseModel, str]:
    """Return ``(model with the diagnosed effect folded in, one-line description)``.

    ``holds`` are the term types of the target format (None: all); the best attribution the
    format can represent is used. The model is unchanged when the gap is not significant or
    no representable effect was attributed.
    """
    if not diagnosis.significant or not diagnosis.attribution:
        return model, "no significant gap: the config is written unchanged"
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
    term = term_from_dict(dict(best.term))
    if best.effect.startswith("rescale:"):
        out = _replace_first(model, best.effect.split(":", 1)[1], term)
    elif best.effect == "lowpass":
        out = _replace_first(model, "white", term)
    else:
        out = model.plus(term)
    params = ", ".join(f"{k}={v:.4g}" for k, v in best.params.items())
    return out, (
        f"folded in {best.effect} ({params}); gap {best.gap_before:.4g} -> {best.gap_after:.4g}"
        f" (shrinkage {100 * best.shrinkage:.0f} %){note}"
    )
