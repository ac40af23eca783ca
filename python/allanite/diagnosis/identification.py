"""'Closed' only when identified: rival effects that close the gap as well.

A single effect that closes the gap is only *identified* when no other candidate of a
different law does the same on this record: closes the tau view at level ``alpha``
(``consistent_after``) and leaves no evidence unexplained that the effect explains. Effects of
one law are not rivals (adding or rescaling white noise; a random walk and a Gauss-Markov term
far slower than the record, :func:`~allanite.diagnosis.verdict.as_random_walk`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from scipy import stats

from allanite.diagnosis.attribution import Attribution
from allanite.diagnosis.holdout_validation import deciding_length, duration_text
from allanite.diagnosis.joint import Explanation
from allanite.diagnosis.verdict import Verdict, as_random_walk, describe_effect

__all__ = ["identified", "rivals"]


def _law(a: Attribution, duration: float) -> str:
    """The noise law of an effect: rescaling a term is adding more of the same."""
    if as_random_walk(a, duration) is not None:
        return "rrw"
    return a.effect.split(":", 1)[1] if a.effect.startswith("rescale:") else a.effect


def rivals(
    explanation: Explanation | None,
    attribution: list[Attribution],
    duration: float,
    alpha: float = 0.05,
) -> list[Attribution]:
    """Other effects that close the gap as well as a one-effect explanation (best first).

    A rival closes the tau view, leaves no evidence unexplained that the best explains, and
    its score (the penalised ``-2 ln p`` sum of the ranking) exceeds the best's by less than
    the ``chi2_1`` quantile ``1 - alpha / n`` (``n`` the ranked effects: the family-wise
    level of the one-parameter likelihood-ratio margin that lists ``alternatives``).
    """
    if explanation is None or len(explanation.effects) != 1:
        return []
    best = explanation.effects[0]
    left = set(best.evidence.get("unexplained", []))
    law = _law(best, duration)
    margin = float(stats.chi2.isf(alpha / max(len(attribution), 1), 1))
    return [
        b
        for b in attribution
        if b.consistent_after
        and _law(b, duration) != law
        and set(b.evidence.get("unexplained", [])) <= left
        and b.score - best.score < margin
    ]


def identified(
    head: Verdict,
    explanation: Explanation | None,
    attribution: list[Attribution],
    by_effect: dict[str, Any],
    *,
    model: Any,
    fs: float,
    n: int,
    alpha: float,
    units: str | None,
) -> tuple[Verdict, list[str]]:
    """The verdict, no longer closed when rival effects close the gap alike; their names.

    The headline then names the effect and its rivals as indistinguishable on this record and
    the record length that would tell the best from its first rival
    (:func:`~allanite.diagnosis.holdout_validation.deciding_length`).
    """
    duration = n / fs
    found = rivals(explanation, attribution, duration, alpha) if head.closed else []
    if not found or explanation is None:
        return head, []
    names = [describe_effect(a, units, fs, duration) for a in (explanation.effects[0], *found)]
    other = replace(explanation, effects=[found[0]], candidates=[by_effect[found[0].effect]])
    length = deciding_length(explanation, other, model, fs, n, alpha)
    if length is None:
        tail = (
            f"no record up to 64 times this one tells {explanation.effects[0].effect} from "
            f"{found[0].effect} in the tau view (the same Allan variance law)"
        )
    elif length > duration:
        tail = (
            f"a record of about {duration_text(length)} (same rate) would tell "
            f"{explanation.effects[0].effect} from {found[0].effect}"
        )
    else:
        tail = "a record this long tells them apart on average but this one does not: repeat it"
    text = (
        "the gap closes alike with any of these (each closes the tau view and "
        "explains the same evidence), indistinguishable on this record: "
        + "; or ".join(names)
        + f"; {tail}"
    )
    return replace(head, closed=False, headline=text), [explanation.effects[0].effect] + [
        a.effect for a in found
    ]
