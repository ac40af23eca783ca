r"""The headline: is the gap closed in all three views, and if not, what remains and where.

A diagnosis is **closed** only when no gap is significant, or when, after the effects of the
joint attribution (:mod:`allanite.diagnosis.joint`) are added to the simulated sensor, every
view is consistent with chance:

* tau view: the remaining statistic ``T_after`` (all fitted parameters taken off the degrees
  of freedom) is consistent with chance at level ``alpha``;
* frequency and time views: for a model, the record is re-analysed against the model *with*
  the effects (its own Monte Carlo null), and every statistic of these views (line,
  broadband bands, level, jump, ``hf``, ``dyn``, spikes, the tail's shape, kurtosis) lies
  above ``alpha / 10`` (Bonferroni over the ten). For a simulated record there is no model to
  augment: the broadband test is re-run with the effects' PSD added
  (:meth:`FrequencyView.band_test`) and the significant evidence the effects do not explain
  remains; non-stationary effects have no PSD, and then the broadband evidence counts as
  explained when the tau view is consistent.

Whatever is left is reported as an :class:`Unexplained` item: its view, the evidence, *where*
(taus, frequency band or lines, time segments) and *how large* (the remaining gap, the rms
noise-level ratio in the flagged windows, the line amplitude, the excess kurtosis).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.diagnosis.attribution import LEVEL_NEGLIGIBLE, Attribution
from allanite.diagnosis.candidates import Candidate
from allanite.diagnosis.frequency_view import FrequencyView
from allanite.diagnosis.joint import Explanation
from allanite.diagnosis.null import runs
from allanite.diagnosis.tau_view import TauModel, TauView
from allanite.diagnosis.time_view import TimeView, largest_spikes
from allanite.units import coefficient_text as param_unit
from allanite.units import customary_value as shown_param

__all__ = [
    "Unexplained",
    "Verdict",
    "effect_psd",
    "explanation_lines",
    "format_params",
    "param_unit",
    "param_units",
    "percent",
    "shown_param",
    "terms_label",
    "verdict",
]

#: plain names of the term types (the headline's vocabulary)
#: spikes listed in an item's time segments (the largest; the count states them all)
LISTED_SPIKES = 50

TERM_NAMES = {
    "white": "white noise",
    "quantization": "quantization noise",
    "flicker": "bias instability (flicker)",
    "rrw": "rate random walk",
    "ramp": "rate ramp",
    "markov": "Gauss-Markov noise",
    "sine": "sinusoid",
    "warmup": "warm-up transient",
    "step": "bias steps",
    "spikes": "spikes",
    "telegraph": "random telegraph noise",
    "lowpass": "low-pass filter on the white noise",
    "bursts": "white noise in bursts (a time-varying noise level)",
    "resonance": "a resonance (white noise through a second-order band-pass)",
    "drifting_line": "a vibration line whose frequency drifts",
    "white_drift": "a white-noise level that changes over the record",
}

#: effects whose plain name is a plural ("spikes are missing")
PLURAL_EFFECTS = frozenset({"step", "spikes"})

#: what each piece of time/frequency evidence means, in words
EVIDENCE_TEXT = {
    "line": "a spectral line",
    "jump": "level jumps",
    "level": "a wandering or drifting level",
    "hf": "the short-term noise level changes over the record (bursts)",
    "dyn": "the mid-tau noise level changes over the record",
    "spike": "spikes",
    "tail": (
        "a heavier tail of moderate deviations than simulated, beyond a few large spikes (a "
        "scale mixture: a noise level that changes, bursts, or some samples summing two "
        "increments)"
    ),
    "kurt_hf": "heavy-tailed sample-to-sample changes (excess kurtosis)",
    "kurt_lf": "a two-level (platykurtic) amplitude distribution",
}


#: an excess-kurtosis difference below this is reported as negligible in size: it changes the
#: variance of a short-tau Allan variance estimate by the factor ``1 + kappa / 2`` (Gaussian
#: reference), i.e. by less than 10 %, so the Gaussian intervals stay within 5 %
KURTOSIS_NEGLIGIBLE = 0.2
#: an explanation whose effects shrink the tau gap by less than this and explain no evidence
#: of the other views is not named in the headline of a gap it leaves open
SHRINKAGE_NEGLIGIBLE = 0.01
_NEGLIGIBLE = ": significant on this long record, but negligible in size"


@dataclass(frozen=True)
class Unexplained:
    """One part of the gap that the effects (the joint explanation) leave unexplained.

    Attributes
    ----------
    view : str
        ``"tau"``, ``"frequency"`` or ``"time"``.
    evidence : str
        The statistic: ``tau`` (the Mahalanobis statistic), ``band`` (broadband PSD), ``line``,
        ``level``, ``jump``, ``hf``, ``dyn``, ``spike``, ``tail``, ``kurt_hf``, ``kurt_lf``; or
        the time base (:mod:`allanite.diagnosis.time_base`): ``time base`` (gaps, jitter, doubled
        increments), ``held``.
    where : dict
        ``tau_bands_s``, ``frequency_bands_hz``, ``frequency_lines_hz`` or ``time_segments_s``;
        a tau gap spread over the taus, none beyond the simultaneous threshold, adds
        ``largest_departure_tau_s`` (and ``size["largest_departure_z"]``, signed).
    size : dict
        How large: e.g. ``gap_after``; ``noise_level_ratio`` (rms ratio to the record's typical
        level in the flagged windows); ``amplitude``; ``excess_kurtosis`` (``kurt_hf``: of the
        first differences, and ``excess_kurtosis_samples`` of the samples minus their running
        mean; negligible when both depart by less than ``KURTOSIS_NEGLIGIBLE``).
    p_value : float
        p-value of the evidence (after the effect, where it can be re-tested).
    text : str
        One plain sentence.
    """

    view: str
    evidence: str
    where: dict[str, Any]
    size: dict[str, float]
    p_value: float
    text: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "view": self.view,
            "evidence": self.evidence,
            "where": self.where,
            "size": self.size,
            "p_value": self.p_value,
            "text": self.text,
        }


@dataclass(frozen=True)
class Verdict:
    """The headline of a diagnosis.

    Attributes
    ----------
    closed : bool
        True when no gap is significant, or when the effects of the joint explanation leave
        every view consistent with chance.
    unexplained : list of Unexplained
        What remains (empty when closed).
    headline : str
        The plain sentence that leads the CLI text and the report.
    """

    closed: bool
    unexplained: list[Unexplained]
    headline: str


def param_units(a: Attribution, units: str | None) -> dict[str, str]:
    """Unit of each of an attribution's parameters as the JSON holds them (the model's units).

    ``""`` for a dimensionless parameter (``scale``, ``ratio``, a damping ratio).
    """
    specs = _specs(a)
    out = {}
    for name in a.params:
        spec = specs.get(name)
        out[name] = param_unit(units, spec.rate, spec.time) if spec is not None else ""
    return out


def format_params(
    a: Attribution,
    units: str | None,
    *,
    skip: tuple[str, ...] = (),
    fs: float | None = None,
    sigma: bool = False,
) -> str:
    """``N = 0.84 deg/sqrt(h)``-style text of an attribution's parameters.

    Coefficients are shown in the customary units of ``allanite fit``
    (:func:`allanite.units.customary_value`),
    with ``sigma`` their one-sigma uncertainty (``± ...``). With the sampling frequency
    ``fs``, a frequency above the Nyquist frequency (a sensor filter's bandwidth can be: it
    acts before sampling) says so.
    """
    own = param_units(a, units)
    parts = []
    for name, value in a.params.items():
        if name in skip:
            continue
        if name == "scale":
            parts.append(f"x{value:.3g}")
            continue
        shown, unit = shown_param(name, value, own[name], units)
        text = f"{name} = {shown:.4g}"
        err = a.params_sigma.get(name) if sigma else None
        if err:
            text += f" ± {shown_param(name, err, own[name], units)[0]:.2g}"
        text += f" {unit}" if unit else ""
        if fs is not None and unit == "Hz" and value > fs / 2:
            text += (
                f" [above the Nyquist frequency {fs / 2:.4g} Hz: it acts before sampling and is "
                "seen only through the sampled noise]"
            )
        parts.append(text)
    return ", ".join(parts)


def percent(fraction: float) -> str:
    """``fraction`` as a percentage that never rounds a part to 0 % or 100 %.

    ``0.9992`` is ``99.9 %`` (not ``100 %``, which would read as the whole gap), ``0.0005``
    is ``0.05 %``; exactly 0 and 1 stay ``0 %`` and ``100 %``.
    """
    value = 100.0 * float(fraction)
    if not np.isfinite(value):
        return "n/a"
    digits = 0
    while digits < 4 and 0.0 < value < 100.0 and float(f"{value:.{digits}f}") in (0.0, 100.0):
        digits += 1
    return f"{value:.{digits}f} %"


def explanation_lines(
    e: Explanation, units: str | None, fs: float | None = None, *, model: bool = True
) -> list[str]:
    """The joint explanation in plain text: the set, its gap, shares, held-out check, terms.

    One line for the set (effects with their parameters in customary units, the gap before
    and after all of them and whether the rest is consistent with chance in the tau view),
    one for each effect's share of the gap, one for the held-out check of the whole set (when
    there is one) and the term list: with ``model`` (the simulated sensor is a noise model)
    the model's terms with the effects added, as the model JSON's ``terms`` (in the model's
    units, ready to paste); for a simulated record, the effects' own terms, to add to the
    simulator's model.
    """
    after = "consistent with chance" if e.consistent_after else "gap remains"
    lines = [
        "joint explanation: "
        + " + ".join(a.effect for a in e.effects)
        + f"  gap {e.gap_before:.4g} -> {e.gap_after:.4g} (tau view: {after}, "
        f"p = {e.p_after:.2g})"
    ]
    lines.extend(f"  {a.effect:<20} {format_params(a, units, fs=fs)}" for a in e.effects)
    lines.append(
        "  share of the gap: " + ", ".join(f"{k} {percent(v)}" for k, v in e.share.items())
    )
    hold = e.holdout
    if hold is not None and hold.get("note"):
        lines.append("  " + str(hold["note"]))
    elif hold is not None:
        if hold.get("gap_before", 0.0) <= 0:
            shrink = "n/a (no gap in the held-out data)"
        else:
            shrink = f"shrinkage {percent(hold['shrinkage'])}, " + (
                "consistent with chance" if hold.get("consistent_after") else "gap remains"
            )
        lines.append(
            f"  held-out check of the set ({hold.get('source', '')}, "
            f"{int(hold.get('n_samples', 0)):,} samples): {shrink}"
        )
    if e.terms:
        lines.append(f"  {terms_label(model)}: " + json.dumps(e.terms, allow_nan=False))
    return lines


def terms_label(model: bool) -> str:
    """What the explanation's term list is: a whole model's terms, or the effects' alone."""
    if model:
        return 'model JSON "terms" with the effects added (model units)'
    return 'the effects as model JSON "terms" (units of the record; add them to your simulator)'


def _specs(a: Attribution) -> dict[str, Any]:
    """The parameter specifications of an attribution's term type, by name."""
    cls = _term_class(a)
    return {p.name: p for p in cls.params + cls.optional} if cls is not None else {}


def _term_class(a: Attribution) -> Any:
    from allanite.terms import TERM_TYPES

    return TERM_TYPES.get(str(a.term.get("type", "")))


#: a Gauss-Markov term whose correlation time exceeds the record this many times is, on that
#: record, the rate random walk ``K = sigma sqrt(2 / tau_c)`` (how its user meant it)
WALK_TAU_FACTOR = 10.0


def as_random_walk(a: Attribution, duration: float | None) -> Attribution | None:
    """A Gauss-Markov effect far slower than the record, stated as the random walk it is.

    None unless ``a`` is a (rescaled or added) Gauss-Markov term with ``tau_c`` beyond
    :data:`WALK_TAU_FACTOR` times ``duration``; otherwise the attribution as a ``rrw`` term
    with ``K = sigma sqrt(2 / tau_c)`` (the walk's rate in the Gauss-Markov's time units).
    """
    term = a.term
    if duration is None or term.get("type") != "markov":
        return None
    tau_c, sigma = float(term.get("tau_c", 0.0)), float(term.get("sigma", 0.0))
    if not tau_c > WALK_TAU_FACTOR * duration:
        return None
    k = sigma * float(np.sqrt(2.0 / tau_c))
    return replace(a, effect="rrw", term={"type": "rrw", "K": k}, params={"K": k})


def describe_effect(
    a: Attribution, units: str | None, fs: float | None = None, duration: float | None = None
) -> str:
    """The effect in words, with its parameters and units (``fs``: see :func:`format_params`).

    ``duration`` (s, the record's): a Gauss-Markov term far slower than the record (e.g. a
    simulator's dynamic bias with ``tau_c = 1e5 s``) is described as the random walk it is
    there (:func:`as_random_walk`), its stationary sigma in brackets.
    """
    walk = as_random_walk(a, duration)
    if walk is not None:
        what = (
            f"is {a.params['scale']:.2f}x the simulated one"
            if "scale" in a.params
            else "is missing"
        )
        return (
            f"the real sensor's rate random walk {what} ({format_params(walk, units, fs=fs)}; "
            f"the simulated Gauss-Markov term with tau_c = {float(a.term['tau_c']):.3g} s, far "
            f"beyond the {duration:.4g} s record, is that random walk: "
            f"{format_params(a, units, skip=('scale', 'tau_c'), fs=fs)} as its stationary sigma)"
        )
    if a.effect.startswith("rescale:"):
        kind = a.effect.split(":", 1)[1]
        name = TERM_NAMES.get(kind, f"{kind} term")
        return (
            f"the real sensor's {name} is {a.params.get('scale', float('nan')):.2f}x the "
            f"simulated one ({format_params(a, units, skip=('scale',), fs=fs)})"
        )
    if a.effect == "white_drift":
        return _describe_drift(a, units)
    name = TERM_NAMES.get(a.effect, a.effect)
    verb = "are missing" if a.effect in PLURAL_EFFECTS else "is missing"
    verb += " in the simulation" if a.effect == "lowpass" else ""
    return f"{name} {verb} ({format_params(a, units, fs=fs)})"


def _describe_drift(a: Attribution, units: str | None) -> str:
    """``white_drift`` in words: how the level changes, when, and the rms level."""
    p = a.params
    ratio, t0, t1 = p.get("ratio", 1.0), p.get("t_start", 0.0), p.get("t_end", 0.0)
    how = f"steps at {t0:.4g} s" if t1 <= t0 else f"drifts from {t0:.4g} s to {t1:.4g} s"
    return (
        f"the real sensor's white-noise level changes over the record: it {how}, to "
        f"x{ratio:.3g} of its initial level "
        f"({format_params(a, units, skip=('ratio', 't_start', 't_end', 'duration'))} rms)"
    )


def effect_psd(cand: Candidate, values: dict[str, float], f: Any, dt: float) -> Any:
    """One-sided PSD the effect adds to the simulated sensor, or None (non-stationary)."""
    try:
        psd = cand.extra_psd(values, f, dt)
    except (NotImplementedError, ValueError, ZeroDivisionError, OverflowError):
        return None
    psd = np.asarray(psd, dtype=np.float64)
    return psd if np.all(np.isfinite(psd)) else None


def _segments(tv: TimeView, mask: NDArray[np.bool_]) -> list[list[float]]:
    return [[a * tv.window_s, (b + 1) * tv.window_s] for a, b in runs(mask)]


def _segments_text(segs: list[list[float]], limit: int = 4) -> str:
    text = ", ".join(f"{a:.4g}-{b:.4g} s" for a, b in segs[:limit])
    return text + (f" (+{len(segs) - limit} more)" if len(segs) > limit else "")


def _time_item(name: str, tv: TimeView, p: float) -> Unexplained:
    what = EVIDENCE_TEXT.get(name, name)
    size: dict[str, float] = {}
    where: dict[str, Any] = {"time_segments_s": []}
    if name in ("hf", "dyn", "level") and name in tv.z:
        flagged = np.abs(tv.z[name]) > tv.thresholds[name]
        where["time_segments_s"] = _segments(tv, flagged)
        if name in ("hf", "dyn") and name in tv.residual and flagged.any():
            ratio = np.exp(0.5 * tv.residual[name][flagged])
            size["noise_level_ratio_max"] = float(ratio.max())
            size["noise_level_ratio_min"] = float(ratio.min())
    elif name == "jump":
        where["change_points_s"] = list(tv.change_points_s)
        where["time_segments_s"] = [
            [t - tv.window_s / 4, t + tv.window_s / 4] for t in tv.change_points_s
        ]
    elif name == "spike":
        listed = largest_spikes(tv.spike_amplitudes, LISTED_SPIKES)
        where["time_segments_s"] = [[tv.spike_times_s[i]] * 2 for i in listed]
        size["count"] = float(len(tv.spike_times_s))
        size["listed"] = float(len(listed))
        if tv.spike_amplitudes:
            size["rms_height"] = float(np.sqrt(np.mean(np.square(tv.spike_amplitudes))))
    elif name == "tail" and tv.tail:
        t = tv.tail
        # a record-wide statistic: the moderate deviations lie all over the record
        where["time_segments_s"] = [[0.0, float(tv.t_s.size * tv.window_s)]]
        size["score_ratio"] = t["score"] / t["expected"] if t["expected"] > 0 else float("inf")
        for x, c, m in zip(t["levels"], t["count"], t["expected_count"], strict=True):
            size[f"count_{x:g}"] = float(c)
            size[f"expected_{x:g}"] = float(m)
    elif name in ("kurt_hf", "kurt_lf"):
        key = name.split("_")[1]
        size["excess_kurtosis_real"] = tv.kurtosis.get(f"{key}_real", float("nan"))
        size["excess_kurtosis_sim"] = tv.kurtosis.get(f"{key}_sim", float("nan"))
        if name == "kurt_hf" and "hf_samples_real" in tv.kurtosis:
            size["excess_kurtosis_samples_real"] = tv.kurtosis["hf_samples_real"]
            size["excess_kurtosis_samples_sim"] = tv.kurtosis["hf_samples_sim"]
    segs = where["time_segments_s"]
    text = f"time view: {what}"
    if "noise_level_ratio_max" in size:
        hi, lo = size["noise_level_ratio_max"] - 1.0, size["noise_level_ratio_min"] - 1.0
        spread = f"rms {100 * hi:+.2g} % / {100 * lo:+.2g} % of the typical level"
        if max(abs(hi), abs(lo)) < LEVEL_NEGLIGIBLE:
            text = f"time view: the {'short' if name == 'hf' else 'mid'}-tau noise level varies "
            text += f"slightly over the record ({spread}{_NEGLIGIBLE})"
        else:
            text += f" ({spread}" + (f" at {_segments_text(segs)})" if segs else ")")
    elif name == "tail" and tv.tail:
        cap = tv.tail["band"][1]
        counts = ", ".join(
            f"at {x:g}-{cap:g} robust sigmas from the running mean: {c:.0f} ({m:.0f} simulated)"
            for x, c, m in zip(
                tv.tail["levels"], tv.tail["count"], tv.tail["expected_count"], strict=True
            )
        )
        detail = f"samples {counts}; score x{size['score_ratio']:.3g}"
        # its size is that of the heavy tail: the sample-level excess kurtosis, as kurt_hf's
        k = tv.kurtosis
        departs = max(
            abs(k.get("hf_real", 0.0) - k.get("hf_sim", 0.0)),
            abs(k.get("hf_samples_real", 0.0) - k.get("hf_samples_sim", 0.0)),
        )
        if departs < KURTOSIS_NEGLIGIBLE:
            text = "time view: slightly more moderate deviations than simulated over the whole "
            text += f"record ({detail}; excess kurtosis departs by {departs:.2g}{_NEGLIGIBLE})"
        else:
            text += f" over the whole record ({detail})"
    elif segs and name != "spike":
        text += f" at {_segments_text(segs)}"
    elif name == "spike":
        count, shown = int(size["count"]), int(size["listed"])
        text += f" ({count:,} found" + (
            f"; the {shown} largest of {count:,} listed)" if shown < count else ")"
        )
    elif name.startswith("kurt"):
        real, sim = size["excess_kurtosis_real"], size["excess_kurtosis_sim"]
        departs = abs(real - sim)
        if "excess_kurtosis_samples_real" in size:
            departs = max(
                departs,
                abs(size["excess_kurtosis_samples_real"] - size["excess_kurtosis_samples_sim"]),
            )
        if departs < KURTOSIS_NEGLIGIBLE:
            shape = "heavier" if real > sim else "lighter"
            text = f"time view: the sample-to-sample changes are slightly {shape}-tailed than "
            text += f"simulated (excess kurtosis {real:.3g}, simulated {sim:.3g}{_NEGLIGIBLE})"
        else:
            text += f" (real {real:.3g} vs simulated {sim:.3g})"
        if "excess_kurtosis_samples_real" in size:
            real, sim = size["excess_kurtosis_samples_real"], size["excess_kurtosis_samples_sim"]
            text += f"; of the samples: real {real:.3g} vs simulated {sim:.3g}"
    return Unexplained("time", name, where, size, float(p), text + f", p = {p:.2g}")


def _line_item(fv: FrequencyView, p: float) -> Unexplained:
    lines = [ln.frequency_hz for ln in fv.lines]
    amps = [ln.amplitude for ln in fv.lines]
    text = "frequency view: " + (
        "spectral line(s) at " + ", ".join(f"{f:.5g} Hz" for f in lines[:4])
        if lines
        else "a line-like peak"
    )
    size = {"amplitude_max": float(max(amps))} if amps else {}
    return Unexplained(
        "frequency", "line", {"frequency_lines_hz": lines}, size, float(p), text + f", p = {p:.2g}"
    )


def _band_item(bands: list[tuple[float, float]], z: NDArray[np.float64], p: float) -> Unexplained:
    text = "frequency view: broadband PSD departs from the simulation"
    if bands:
        text += " at " + ", ".join(f"{a:.3g}-{b:.3g} Hz" for a, b in bands[:4])
    size = {"max_abs_band_z": float(np.abs(z).max())} if z.size else {}
    return Unexplained(
        "frequency",
        "band",
        {"frequency_bands_hz": [list(b) for b in bands]},
        size,
        float(p),
        text + f", p = {p:.2g}",
    )


def _tau_item(
    tm: TauModel, tv: TauView, extra: NDArray[np.float64] | None, p: float
) -> Unexplained:
    r = tm.residual(extra)
    sd = tm.null_sd if tm.null_sd is not None else np.ones_like(r)
    z = r / sd
    bands = [
        [float(tm.tau[i] / np.sqrt(2.0)), float(tm.tau[j] * np.sqrt(2.0))]
        for i, j in runs(np.abs(z) > tv.z_threshold)
    ]
    gap = tm.gap(extra)
    ratio = float(np.exp(np.max(np.abs(r))))
    text = f"tau view: a gap G = {gap:.4g} remains (chance level T0 = {tm.t0:.3g})"
    where: dict[str, Any] = {"tau_bands_s": bands}
    size = {"gap_after": gap, "max_avar_ratio": ratio}
    if bands:
        text += " at tau " + ", ".join(f"{x:.3g}-{y:.3g} s" for x, y in bands[:4])
    elif z.size:
        # spread over the taus (no single one beyond the simultaneous threshold): say where
        # it departs most, and in which direction
        k = int(np.argmax(np.abs(z)))
        where["largest_departure_tau_s"] = float(tm.tau[k])
        size["largest_departure_z"] = float(z[k])
        text += (
            f", spread over the taus (none beyond the simultaneous threshold |z| = "
            f"{tv.z_threshold:.3g}); largest departure at tau = {tm.tau[k]:.3g} s, z = "
            f"{z[k]:+.2g} (real {'above' if z[k] > 0 else 'below'} simulated)"
        )
    return Unexplained(
        "tau",
        "tau",
        where,
        size,
        float(p),
        text + f", p = {p:.2g}",
    )


#: an effect's share of the gap below which it is not named in the headline (unless it
#: explains evidence of the frequency or time view)
SHARE_NEGLIGIBLE = 0.005


def headline_effects(explanation: Explanation) -> list[Attribution]:
    """The set's effects worth naming: a share of the gap, or evidence they explain."""
    shown = [
        a
        for a in explanation.effects
        if explanation.share.get(a.effect, 1.0) >= SHARE_NEGLIGIBLE or a.evidence.get("explained")
    ]
    return shown or list(explanation.effects)


def verdict(
    *,
    significant: bool,
    p_value: float,
    alpha: float,
    tau_model: TauModel,
    tau: TauView,
    frequency: FrequencyView,
    time: TimeView,
    evidence_p: dict[str, float],
    evidence_significant: dict[str, bool],
    explanation: Explanation | None,
    units: str | None,
    after: Any = None,
) -> Verdict:
    """Decide whether the gap is closed in all three views and list what remains.

    ``explanation`` is the set of effects (the joint attribution, or the best single effect
    alone); ``evidence_significant`` marks the significant evidence statistics (the
    attribution's Bonferroni level). ``after`` is the analysis of the record against the
    simulated sensor with the effects added (a model): then the frequency and time views are
    judged on it; otherwise the broadband test is re-run with the effects' PSD and the evidence
    the effects do not explain remains.
    """
    if not significant:
        return Verdict(
            True,
            [],
            f"the real record agrees with the simulated sensor in all three views "
            f"(p = {p_value:.2g}): no gap",
        )
    level = alpha / max(len(evidence_p) + 1, 1)  # the evidence statistics and the broadband test
    items: list[Unexplained] = []
    explained = set(explanation.explained) if explanation is not None else set()
    if explanation is not None:
        if not explanation.consistent_after:
            items.append(_tau_item(tau_model, tau, explanation.extra_avar, explanation.p_after))
    elif tau.p_value < alpha / 3.0:
        items.append(_tau_item(tau_model, tau, None, tau.p_value))
    pending = [e for e, s in evidence_significant.items() if s and e not in explained]
    # broadband frequency view, re-tested with the effects' PSD
    band_p, bands, band_z = frequency.band_p_value, frequency.bands_hz, frequency.band_z
    if after is not None:
        # re-analysis against the simulated sensor with the effects (a model): every
        # frequency/time statistic has the null of the augmented model
        frequency, time = after.frequency, after.time
        band_p, bands, band_z = frequency.band_p_value, frequency.bands_hz, frequency.band_z
        ev_after = {"line": frequency.line_p_value}
        ev_after.update({k: time.family_p[k] for k in evidence_p if k in time.family_p})
        evidence_p = ev_after
        pending = [e for e, p in ev_after.items() if p < level]
    elif explanation is not None and frequency.band_sd.size:
        total: Any = np.zeros_like(frequency.f)
        for a, c in zip(explanation.effects, explanation.candidates, strict=True):
            values = {k: a.params[k] for k in c.free}
            psd = effect_psd(c, values, frequency.f, tau_model.dt)
            if psd is None:
                total = None
                break
            total = total + psd
        if total is not None:
            band_p, bands, band_z = frequency.band_test(total)
        elif explanation.consistent_after:
            band_p = 1.0
    if band_p < level:
        items.append(_band_item(bands, band_z, band_p))
    for e in pending:
        if e == "line":
            items.append(_line_item(frequency, evidence_p[e]))
        else:
            items.append(_time_item(e, time, evidence_p[e]))
    closed = explanation is not None and not items
    if (
        explanation is not None
        and not closed
        and all(a.shrinkage < SHRINKAGE_NEGLIGIBLE for a in explanation.effects)
        and not explanation.explained
    ):
        # effects that shrink nothing and explain no evidence are not named as "missing" (a
        # level change at an unchanged rms level shrinks no tau gap, but explains the time
        # view's)
        explanation = None
    if explanation is not None:
        fs = 1.0 / tau_model.dt
        effect = "; and ".join(
            describe_effect(a, units, fs, tau_model.duration) for a in headline_effects(explanation)
        )
        it = "them" if len(explanation.effects) > 1 else "it"
        if closed:
            headline = f"{effect}; after adding {it}, the records agree in all three views"
        else:
            closed_tau = (
                f"the tau view is closed by {it}, but " if explanation.consistent_after else ""
            )
            headline = f"{effect}; {closed_tau}not everything is explained: " + "; ".join(
                i.text for i in items
            )
    elif items and all(_NEGLIGIBLE in i.text for i in items):
        headline = "a small gap, significant but negligible in size, that no candidate effect "
        headline += "explains: " + "; ".join(i.text for i in items)
    else:
        headline = "there is a significant gap that no candidate effect explains: " + "; ".join(
            i.text for i in items
        )
    return Verdict(closed, items, headline)
