"""Fold a diagnosis into a simulator config: the corrected model the simulator should use.

The best attribution of a :class:`~allanite.diagnosis.result.Diagnosis` is applied to the
simulated sensor's model: ``rescale:<type>`` replaces that term by its rescaled copy,
``lowpass`` replaces the white noise by low-passed white noise, any other effect is added.
The format's writer then holds what it can and lists the rest (:mod:`.projection`).
"""

from __future__ import annotations

from typing import Any

from allanite.model import NoiseModel
from allanite.terms import Term, term_from_dict

__all__ = ["corrected_model"]


def _replace_first(model: NoiseModel, kind: str, new: Term) -> NoiseModel:
    terms = list(model.terms)
    for i, term in enumerate(terms):
        if term.type == kind:
            terms[i] = new
            return NoiseModel(tuple(terms), model.units)
    return model.plus(new)


def corrected_model(model: NoiseModel, diagnosis: Any) -> tuple[NoiseModel, str]:
    """Return ``(model with the diagnosed effect folded in, one-line description)``.

    The model is unchanged when the gap is not significant or no effect was attributed.
    """
    best = diagnosis.best
    if not diagnosis.significant or best is None:
        return model, "no significant gap: the config is written unchanged"
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
        f" (shrinkage {100 * best.shrinkage:.0f} %)"
    )
