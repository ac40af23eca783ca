"""The :class:`Diagnosis` result: the gap, where it lies, which effect explains it."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

from allanite.diagnosis.attribution import Attribution
from allanite.diagnosis.frequency_view import FrequencyView
from allanite.diagnosis.joint import Explanation
from allanite.diagnosis.tau_view import TauView
from allanite.diagnosis.time_view import TimeView
from allanite.diagnosis.verdict import Unexplained, param_units
from allanite.notebook import diagnosis_html

__all__ = ["Diagnosis", "Holdout"]

#: a warm-up ``A exp(-t / tau_w)`` has settled to 0.7 % of its amplitude after ``5 tau_w``
WARMUP_SETTLED = 5.0


def _clean(value: Any) -> Any:
    """Replace non-finite floats by None so the JSON is strict."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value


@dataclass(frozen=True)
class Holdout:
    """Shrinkage of the best effect on data it was not fitted on.

    Attributes
    ----------
    effect : str
        The effect (the best attribution) whose fitted parameters were carried over.
    shrinkage : float
        ``1 - G_after / G_before`` on the held-out data (0 when the held-out data shows no
        tau-view gap to shrink, the in-sample convention; ``gap_before`` then is 0).
    gap_before, gap_after : float
        ``G`` on the held-out data without and with the effect.
    consistent_after : bool
        Whether the held-out remaining gap is consistent with chance.
    n_samples : int
        Length of the held-out record.
    source : str
        ``"fraction"`` (the end of the record) or ``"record"`` (a second real record).
    checkable : bool
        False when the effect's signature lies beyond the held-out part's taus (adding it
        would not change a record of that length significantly); ``shrinkage`` is then nan.
    disagrees : bool
        ``holdout=`` a fraction: the fit part alone names other effects than the whole record.
    fit_effects : tuple of str
        The effects attributed on the fit part (a fraction held out).
    deciding_length_s : float or None
        Record length that would tell the fit part's and the whole record's effects apart.
    note : str
        The validation in one sentence (also appended to the headline for a fraction).
    """

    effect: str
    shrinkage: float
    gap_before: float
    gap_after: float
    consistent_after: bool
    n_samples: int
    source: str
    checkable: bool = True
    disagrees: bool = False
    fit_effects: tuple[str, ...] = ()
    deciding_length_s: float | None = None
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "shrinkage": self.shrinkage if self.checkable else None,
            "effect": self.effect,
            "gap_before": self.gap_before,
            "gap_after": self.gap_after,
            "consistent_after": self.consistent_after,
            "n_samples": self.n_samples,
            "source": self.source,
            "checkable": self.checkable,
            "disagrees": self.disagrees,
            "fit_effects": list(self.fit_effects),
            "deciding_length_s": self.deciding_length_s,
            "note": self.note,
        }


@dataclass(frozen=True, repr=False)
class Diagnosis:
    """Where and why a simulated sensor differs from a real record.

    Attributes
    ----------
    statistic : float
        The gap ``G = max(0, T - T0)`` of the tau view (see docs/diagnosis.md).
    p_value : float
        Calibrated p-value of the combined test over the three views.
    significant : bool
        ``p_value < alpha``.
    tau, frequency, time : TauView, FrequencyView, TimeView
        The three views with their plotting-ready arrays.
    attribution : list of Attribution
        Effects that explain the gap, best first (empty when not significant).
    holdout : Holdout or None
        The held-out check, when requested and an effect was attributed.
    meta : dict
        fs, sample counts, units, kind of simulated input, Monte Carlo size, seed, alpha,
        unavailable effects.
    explanation : Explanation or None
        The joint attribution: the set of effects (forward selection from the best single
        effect, backward check), its remaining gap, shares, combined model terms and held-out
        check.
    closed : bool
        True only when the tau, frequency and time views are all consistent with chance after
        the effects of the joint explanation are added (or no gap is significant).
    unexplained : list of Unexplained
        What the joint explanation's effects leave unexplained: view, evidence, where and how
        large.
    headline : str
        One plain sentence: the effect with its parameters and units, and whether the records
        then agree in all three views or what remains.
    indistinguishable : tuple of str
        When the gap closes alike with several effects of different laws (not identified, so
        ``closed`` is False): the effect and its rivals (:mod:`allanite.diagnosis.identification`).
    """

    statistic: float
    p_value: float
    significant: bool
    tau: TauView
    frequency: FrequencyView
    time: TimeView
    attribution: list[Attribution]
    holdout: Holdout | None
    meta: dict[str, Any] = field(default_factory=dict)
    explanation: Explanation | None = None
    closed: bool = False
    unexplained: list[Unexplained] = field(default_factory=list)
    headline: str = ""
    indistinguishable: tuple[str, ...] = ()

    _repr_html_ = diagnosis_html  # Jupyter: a compact table and the plot (allanite.notebook)

    def __repr__(self) -> str:
        """Compact: the gap's p-value, the headline and the effects (the arrays are attributes).

        Each attributed effect (best first, at most three named) with its parameters in
        customary units and whether the records agree after it (``consistent after``), then
        the joint explanation's effects and whether the gap closes with them.
        """
        from allanite.diagnosis.verdict import format_params

        units = self.meta.get("units")
        effects = [
            f"{a.effect} ({format_params(a, units)}; "
            + ("consistent after" if a.consistent_after else "gap remains")
            + ")"
            for a in self.attribution[:3]
        ]
        if len(self.attribution) > 3:
            effects.append(f"+{len(self.attribution) - 3} more")
        joint = ""
        if self.explanation is not None:
            names = " + ".join(a.effect for a in self.explanation.effects) or "none"
            after = "consistent after" if self.explanation.consistent_after else "gap remains"
            joint = f", joint={names} ({after})"
        return (
            f"Diagnosis(p_value={self.p_value:.3g}, significant={self.significant}, "
            f"closed={self.closed}, headline={self.headline!r}, "
            f"effects=[{'; '.join(effects)}]{joint})"
        )

    @property
    def where(self) -> dict[str, Any]:
        """Tau bands, frequency lines and time segments of the gap.

        Empty when the gap is not significant (each view keeps its own flagged locations in
        ``tau.bands_s``, ``frequency.lines``, ``time.segments_s`` as hints).
        """
        if not self.significant:
            return {
                "tau_bands_s": [],
                "frequency_lines_hz": [],
                "time_segments_s": [],
                "frequency_bands_hz": [],
            }
        return {
            "tau_bands_s": [list(b) for b in self.tau.bands_s],
            "frequency_lines_hz": [line.frequency_hz for line in self.frequency.lines],
            "time_segments_s": [list(s) for s in self.time.segments_s]
            if self._time_view_significant()
            else [],
            "frequency_bands_hz": [list(b) for b in self.frequency.bands_hz],
        }

    def _time_view_significant(self) -> bool:
        """Whether any time-view statistic is significant (Bonferroni over the family).

        Time segments are findings only then: on a record whose time view agrees with the
        sensor they are the scan's chance excursions, not events.
        """
        fam = self.time.family_p
        level = float(self.meta.get("significance", 0.05)) / max(len(fam), 1)
        return bool(fam) and min(fam.values()) < level

    @property
    def level_steps(self) -> list[Any]:
        """The located level steps that are findings (``changepoint.Step``).

        None without a significant gap, and none inside the settling (``5 tau_w``) of a
        warm-up the explanation names: a settling transient reads as a staircase of steps at
        the record's start, and listing them next to "warm-up transient is missing" would
        tell the user two stories.
        """
        scan = self.time.steps
        if not self.significant or scan is None:
            return []
        effects = self.explanation.effects if self.explanation is not None else []
        settled = max(
            (WARMUP_SETTLED * a.params["tau_w"] for a in effects if a.effect == "warmup"),
            default=0.0,
        )
        return [s for s in scan.steps if s.t_s > settled]

    @property
    def best(self) -> Attribution | None:
        """The best attribution, if any."""
        return self.attribution[0] if self.attribution else None

    def to_dict(self, *, views: bool = True) -> dict[str, Any]:
        """JSON-ready dictionary; ``views=False`` leaves out the plotting arrays."""
        out: dict[str, Any] = {
            "headline": self.headline,
            "closed": self.closed,
            "indistinguishable": list(self.indistinguishable),
            "unexplained": [u.to_dict() for u in self.unexplained],
            "gap": {
                "statistic": self.statistic,
                "p_value": self.p_value,
                "significant": self.significant,
                "T": self.tau.statistic,
                "T0": self.tau.t0,
                "view_p_values": {
                    "tau": self.tau.p_value,
                    "frequency": self.frequency.p_value,
                    "time": self.time.p_value,
                },
            },
            "where": self.where,
            "steps": self.time.steps.to_dict() if self.time.steps is not None else None,
            "level_steps": [st.t_s for st in self.level_steps],
            "attribution": [a.to_dict() for a in self.attribution],
            "explanation": self.explanation.to_dict() if self.explanation is not None else None,
            "holdout": self.holdout.to_dict() if self.holdout is not None else None,
            "meta": dict(self.meta),
        }
        _state_units(out, self.attribution, self.explanation, self.meta.get("units"))
        if views:
            out["views"] = {
                "tau": self.tau.to_dict(),
                "frequency": self.frequency.to_dict(),
                "time": self.time.to_dict(),
            }
        cleaned: dict[str, Any] = _clean(out)
        return cleaned

    def to_json(self, *, views: bool = True, **kwargs: Any) -> str:
        """Strict JSON text of :meth:`to_dict`."""
        return json.dumps(self.to_dict(views=views), allow_nan=False, **kwargs)


def _state_units(
    out: dict[str, Any],
    attribution: list[Attribution],
    explanation: Explanation | None,
    units: str | None,
) -> None:
    """``params_units`` next to each ``params``: the unit of each value (the model's units)."""
    for item, a in zip(out["attribution"], attribution, strict=True):
        item["params_units"] = param_units(a, units)
    if explanation is not None:
        for item, a in zip(out["explanation"]["effects"], explanation.effects, strict=True):
            item["params_units"] = param_units(a, units)
