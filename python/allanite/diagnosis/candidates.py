"""The library of candidate effects: which Term each effect is, and what evidence it explains.

Every candidate is an existing :class:`allanite.terms.Term` class (looked up by its JSON
``type`` in :data:`allanite.terms.TERM_TYPES`), fitted on top of the simulated sensor; there is
no second copy of any term's Allan variance here. ``rescale:<type>`` multiplies the principal
coefficient of a term already in the model by a factor ``s`` (adds ``(s^2 - 1)`` times its
Allan variance), the most common real-world gap (e.g. the sim's N is 2x too small).

Besides the tau view, an effect may explain significant evidence of the other views:

=============  ==============================================  ==========================
effect         explains                                        requires (signature)
=============  ==============================================  ==========================
sine           spectral line                                   a spectral line
ramp           level, level jump, kurtosis of block means      --
step           level jump, level, kurtosis of block means      a level jump
warmup         level, level jump, kurtosis of block means      level or jump
spikes         spike statistic, kurtosis of differences, hf    the spike statistic
telegraph      dyn; kurtosis of block means, jump and level    -- (named only when two
               when its own process reproduces them (the      levels are shown: the
               re-tests of the slow candidates)                kurtosis re-test or the
                                                               two-level test)
bursts         hf, kurtosis of differences, spike statistic,   hf (noise-level changes)
               the tail's shape
resonance      --                                              a band-pass shaped excess
                                                               whose peak stays put
drifting_line  kurtosis of differences and of block means      a band-pass shaped excess
               (a sinusoid is platykurtic)                     whose peak moves linearly
white_drift    hf, kurtosis of differences, spike statistic,   hf, and a drift/step shape
               the tail's shape (the model's white noise,      of the windows' noise level
               its level drifting or stepping over the         (replaces the white term)
               record)
=============  ==============================================  ==========================

The last two come from :func:`allanite.diagnosis.band_shape.band_shapes` (frequency view and
spectrogram); their shape parameters are fixed there and only the level is fitted.

**Repeatable kinds** (:data:`REPEATABLE`): a set may hold two processes of a Gauss-Markov or
resonance kind when they are distinct (:meth:`Candidate.distinct`): correlation times more
than :data:`DISTINCT_FACTOR` apart, or resonances whose half-power bands do not overlap
(``|f_1 - f_2| > zeta_1 f_1 + zeta_2 f_2``). A resonance's shape is fixed by its band excess,
so a second one exists only where the frequency view shows a second band-pass excess
(:attr:`Candidate.others`, :meth:`Candidate.repeats`).

An effect whose signature is absent is not proposed. A telegraph is always fitted, but named
only when its two levels are shown, by the block-mean kurtosis its own process reproduces or by
the likelihood ratio of two levels against its Gaussian twin
(:mod:`allanite.diagnosis.two_level`): without them it is a Gauss-Markov process, and the
simpler term is the answer.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from allanite.diagnosis.time_view import TAIL_BAND, TAIL_MEAN
from allanite.terms import TERM_TYPES, Term

__all__ = [
    "DISTINCT_FACTOR",
    "EFFECTS",
    "EVIDENCE",
    "EXPLAINS",
    "REPEATABLE",
    "SIGNATURE",
    "Candidate",
    "candidate_library",
    "check_effects",
]

#: effect name -> Term ``type``
EFFECTS: dict[str, str] = {
    "white": "white",
    "quantization": "quantization",
    "flicker": "flicker",
    "rrw": "rrw",
    "ramp": "ramp",
    "markov": "markov",
    "sine": "sine",
    "warmup": "warmup",
    "step": "bias_steps",
    "spikes": "spikes",
    "telegraph": "telegraph",
    "lowpass": "lowpass_white",
    "bursts": "white_bursts",
    "resonance": "resonance",
    "drifting_line": "drifting_line",
    "white_drift": "white_drift",
}

#: evidence (non-tau statistics) each effect can explain
EXPLAINS: dict[str, frozenset[str]] = {
    "sine": frozenset({"line"}),
    # a level that moves once (step), drifts (ramp) or settles (warm-up) has a platykurtic,
    # bimodal or uniform, distribution of block means too
    "ramp": frozenset({"level", "jump", "kurt_lf"}),
    "step": frozenset({"jump", "level", "kurt_lf"}),
    "warmup": frozenset({"level", "jump", "kurt_lf"}),
    "spikes": frozenset({"spike", "kurt_hf", "hf"}),
    # block means, jumps and level: only as far as its own process reproduces them (the
    # re-tests of fit_candidate; a small two-level process does not explain a random walk's
    # platykurtic path or a ramp's level)
    "telegraph": frozenset({"dyn"}),
    # a noise level that changes in time is a scale mixture: moderate deviations (the tail's
    # shape) as well as large ones; spikes (single large outliers above the tail statistic's
    # cap) and a rescale (the same shape at another scale) do not explain the tail's shape
    "bursts": frozenset({"hf", "kurt_hf", "spike", "tail"}),
    # a sinusoid's amplitude follows the arcsine law: platykurtic samples, differences and
    # short block means
    "drifting_line": frozenset({"kurt_hf", "kurt_lf"}),
    # a white-noise level that changes over the record: like bursts, a scale mixture
    "white_drift": frozenset({"hf", "kurt_hf", "spike", "tail"}),
}

#: statistics of the frequency and time views that count as evidence for an effect (each is
#: judged at ``alpha / len(EVIDENCE)``)
EVIDENCE = ("line", "jump", "level", "spike", "tail", "kurt_hf", "kurt_lf", "hf", "dyn")

#: evidence an effect needs before it is proposed (any of)
SIGNATURE: dict[str, frozenset[str]] = {
    "sine": frozenset({"line"}),
    "step": frozenset({"jump"}),
    "warmup": frozenset({"level", "jump"}),
    "spikes": frozenset({"spike"}),
    "bursts": frozenset({"hf"}),
    "white_drift": frozenset({"hf"}),
}


#: kinds of which a set may hold a second process, and the parameter that locates one
REPEATABLE: dict[str, str] = {"markov": "tau_c", "resonance": "frequency"}

#: a second Gauss-Markov process must have a correlation time more than this factor away from
#: every process of that kind in the set (model or effects): closer, the two are one process
#: of larger variance (the existing one rescaled)
DISTINCT_FACTOR = 4.0


@dataclass(frozen=True)
class Candidate:
    """One candidate effect to fit on top of the simulated sensor.

    Attributes
    ----------
    effect : str
        Effect name (``white`` ... ``lowpass`` or ``rescale:<type>``).
    term_cls : type of Term
        The Term class of the effect (of the rescaled term for ``rescale:``).
    free : tuple of str
        Parameters fitted on the tau view (all positive, fitted in log space).
    fixed : dict
        Parameters fixed from the other views (e.g. the frequency of a detected line).
    start : dict
        Starting values of some free parameters from the other views.
    base : Term or None
        The model's term that ``rescale:`` scales.
    replaces : Term or None
        A model term the effect replaces (``lowpass``: the model's white noise becomes
        low-passed white noise of the same N); its Allan variance is subtracted.
    measured : tuple of str
        Free parameters whose ``start`` is another view's measurement of the effect's size
        (a detected line's amplitude, a band excess's level), not a mere starting guess: the
        size rule :func:`allanite.diagnosis.attribution.negligible` accepts them near it.
    others : tuple of dict
        Parameters (fixed and starting values) of further processes of this kind that the
        other views located (a second band-pass excess: a second resonance), see
        :meth:`repeats`.
    view_size : float or None
        The effect's size as another view measured it, relative to the sensor's own level
        (``white_drift``: ``|ratio - 1|``, the time view's level ratio), for an effect that
        leaves the tau view unchanged; the size rule judges it on this number instead of
        its tau size. None: the tau view sizes it.
    explains_also : frozenset of str
        Evidence this candidate explains beyond its kind's :data:`EXPLAINS`, by its fixed
        size (spikes low enough to fall in the tail-shape band explain ``tail``).
    """

    effect: str
    term_cls: type[Term]
    free: tuple[str, ...]
    fixed: dict[str, float] = field(default_factory=dict)
    start: dict[str, float] = field(default_factory=dict)
    base: Term | None = None
    replaces: Term | None = None
    measured: tuple[str, ...] = ()
    view_size: float | None = None
    others: tuple[dict[str, float], ...] = ()
    explains_also: frozenset[str] = frozenset()

    @property
    def repeat_key(self) -> str | None:
        """The parameter that locates a process of a :data:`REPEATABLE` kind (None: not one).

        A rescale of a model term is that term, never a second process.
        """
        return REPEATABLE.get(self.effect) if self.base is None else None

    def repeats(self) -> list[Candidate]:
        """The candidate of each further process of this kind located by the other views."""
        return [
            replace(
                self,
                fixed={k: v for k, v in p.items() if k not in self.free},
                start={k: v for k, v in p.items() if k in self.free},
                others=(),
            )
            for p in self.others
        ]

    def distinct(self, p: dict[str, float], q: dict[str, float]) -> bool:
        """Whether processes of this kind with parameters ``p`` and ``q`` are two processes.

        Gauss-Markov: correlation times more than :data:`DISTINCT_FACTOR` apart. Resonance:
        half-power bands that do not overlap, ``|f_p - f_q| > zeta_p f_p + zeta_q f_q``.
        Closer, they are one process of another size (the set refits it instead).

        Raises
        ------
        ValueError
            When the kind is not :data:`REPEATABLE` (any two processes of it are one slot).
        """
        key = REPEATABLE.get(self.effect)
        if key is None:
            raise ValueError(f"{self.effect!r} is not a repeatable kind; use one of {REPEATABLE}")
        a, b = p.get(key), q.get(key)
        if a is None or b is None or not (a > 0 and b > 0):
            return False
        if self.effect == "resonance":
            half = p.get("damping", 0.0) * a + q.get("damping", 0.0) * b
            return bool(abs(a - b) > half)
        return not 1.0 / DISTINCT_FACTOR <= a / b <= DISTINCT_FACTOR

    @property
    def explains(self) -> frozenset[str]:
        """Evidence this candidate explains."""
        return EXPLAINS.get(self.effect, frozenset()) | self.explains_also

    def term(self, values: dict[str, float]) -> Term:
        """Build the fitted Term from free-parameter ``values`` (``rescale:``: key ``scale``)."""
        if self.base is not None:
            coef = self.term_cls.params[0].name
            return self.base.with_values(**{coef: values["scale"] * self.base.values()[coef]})
        return self.term_cls(**{**self.fixed, **values})

    def added_term(self, values: dict[str, float]) -> Term | None:
        """The independent process this candidate adds to the simulated sensor, if any.

        ``rescale:`` by ``s > 1`` adds the same term with its coefficient times
        ``sqrt(s^2 - 1)``; a rescale down and ``lowpass`` (which filters the model's own white
        noise) add no process of their own (None).
        """
        if self.base is not None:
            s2 = values["scale"] ** 2
            if s2 <= 1.0:
                return None
            coef = self.term_cls.params[0].name
            return self.base.with_values(**{coef: np.sqrt(s2 - 1.0) * self.base.values()[coef]})
        if self.replaces is not None:
            return None
        return self.term(values)

    def extra_avar(self, values: dict[str, float], tau: Any, dt: float) -> Any:
        """Allan variance this candidate adds to the simulated sensor."""
        if self.base is not None:
            return (values["scale"] ** 2 - 1.0) * self.base.avar(tau, dt)
        extra = self.term(values).avar(tau, dt)
        if self.replaces is not None:
            extra = extra - self.replaces.avar(tau, dt)
        return extra

    def extra_psd(self, values: dict[str, float], f: Any, dt: float) -> Any:
        """One-sided PSD (sampled at ``dt``) this candidate adds to the simulated sensor.

        A rescale adds ``(s^2 - 1)`` times its term's PSD, a replacement (``lowpass``) the
        difference of the two terms' PSDs, any other effect its own
        (:meth:`allanite.terms.Term.psd_sampled`, which raises ``NotImplementedError`` for a
        term without a stationary PSD).
        """
        if self.base is not None:
            return (values["scale"] ** 2 - 1.0) * self.base.psd_sampled(f, dt)
        psd = self.term(values).psd_sampled(f, dt)
        if self.replaces is not None:
            psd = psd - self.replaces.psd_sampled(f, dt)
        return psd


def _model_terms(model: Any) -> list[Term]:
    terms = getattr(model, "terms", None)
    return list(terms) if terms is not None else []


def _drift_fixed(drift: Any, duration: float) -> dict[str, float] | None:
    """Fixed parameters of ``white_drift`` from a :class:`DriftShape` (None: not proposed)."""
    if drift is None:
        return None
    return {
        "ratio": float(drift.ratio),
        "t_start": float(drift.t_start),
        "t_end": float(drift.t_end),
        "duration": float(duration),
    }


def check_effects(effects: Any) -> list[str] | None:
    """Validate a list of effect names (None: all); unknown names are refused with the list.

    Known names are those of :data:`EFFECTS`, ``rescale`` (every rescale) and
    ``rescale:<term type>`` (e.g. ``rescale:white``).
    """
    if effects is None:
        return None
    if isinstance(effects, str):
        effects = [e.strip() for e in effects.split(",") if e.strip()]
    names = list(effects)
    bad = [
        e
        for e in names
        if not isinstance(e, str)
        or not (
            e in EFFECTS
            or e == "rescale"
            or (e.startswith("rescale:") and e.split(":", 1)[1] in TERM_TYPES)
        )
    ]
    if bad or not names:
        what = f"unknown effect(s) {', '.join(map(repr, bad))}" if bad else "no effect given"
        raise ValueError(
            f"{what}; known effects: {', '.join(EFFECTS)}, rescale (every term of the model) "
            f"or rescale:<term type> ({', '.join(sorted(TERM_TYPES))})"
        )
    return names


def candidate_library(
    evidence: dict[str, bool],
    *,
    duration: float,
    model: Any = None,
    lines: list[tuple[float, float]] | None = None,
    spikes: tuple[float, float] | None = None,
    n_changes: int = 0,
    warmup_tau: float | None = None,
    effects: list[str] | None = None,
    bursts: tuple[float, float] | None = None,
    band: Any = None,
    drift: Any = None,
    tail_spread: float | None = None,
) -> tuple[list[Candidate], list[str]]:
    """Candidates to fit, and the effects that cannot be tried (no Term class, no model term).

    Parameters
    ----------
    evidence : dict
        Which non-tau statistics are significant (``line``, ``jump``, ``level``, ``spike``,
        ``kurt_hf``, ``kurt_lf``, ``hf``, ``dyn``).
    duration : float
        Length of the analysed record in seconds (a warm-up's Allan variance depends on it; one
        bias step per record is ``interval = duration``).
    model : NoiseModel, optional
        The simulated sensor's model (enables ``rescale:<type>`` and ``lowpass``).
    lines : list of (frequency, amplitude), optional
        Detected spectral lines, strongest first (the sine takes the strongest's frequency).
    spikes : (rate per second, rms height), optional
        Detected spikes (both parameters are then fixed from the time view).
    tail_spread : float, optional
        The spread of the record's deviations from its running mean, the unit of the time
        view's tail-shape statistic (:func:`allanite.diagnosis.time_view.tail_test`): spikes
        whose height falls in its band, within one spread of its cap, explain ``tail`` too
        (higher ones lie above the band and leave it to a scale mixture).
    bursts : (duty, mean burst length in s), optional
        Windows of raised short-term noise level found by the time view (``bursts`` is only
        proposed with them; both parameters are then fixed, the level ``N`` is fitted).
    n_changes : int
        Number of detected level jumps (bias steps: ``interval = duration / n_changes``).
    warmup_tau : float, optional
        Warm-up time constant measured on the window means (then only the amplitude is
        fitted, like the single free parameter of a bias step).
    effects : list of str, optional
        Restrict the library to these effects (``rescale`` selects every rescale).
    band : BandShape or list of BandShape, optional
        Band-pass shaped excesses of the frequency view, strongest first
        (:func:`allanite.diagnosis.band_shape.band_shapes`): ``resonance`` or
        ``drifting_line`` is proposed with the first's shape fixed and its level free; further
        resonances become the candidate's :attr:`~Candidate.others`.
    drift : DriftShape, optional
        A drift or step of the white-noise level found on the time view's windows
        (:func:`allanite.diagnosis.noise_level.drift_shape`): ``white_drift`` replaces the
        model's white noise with its ``ratio``, ``t_start`` and ``t_end`` fixed and the rms
        level ``N`` free.
    """
    wanted = effects if effects is not None else list(EFFECTS)
    bands = [] if band is None else list(band) if isinstance(band, (list, tuple)) else [band]
    terms = _model_terms(model)
    whites = [t for t in terms if t.type == "white"]
    out: list[Candidate] = []
    unavailable: list[str] = []
    for effect, term_type in EFFECTS.items():
        if effect not in wanted:
            continue
        cls = TERM_TYPES.get(term_type)
        if cls is None or (effect in ("lowpass", "white_drift") and not whites):
            unavailable.append(effect)
            continue
        signature = SIGNATURE.get(effect)
        if signature is not None and not any(evidence.get(s, False) for s in signature):
            continue
        fixed: dict[str, float] = {}
        start: dict[str, float] = {}
        measured: tuple[str, ...] = ()
        view_size: float | None = None
        replaces: Term | None = None
        others: tuple[dict[str, float], ...] = ()
        also: frozenset[str] = frozenset()
        if effect == "sine" and lines:
            freq, amp = lines[0]
            fixed["frequency"] = freq
            start["amplitude"] = max(amp, 1e-300)
            measured = ("amplitude",)
        elif effect == "spikes" and spikes is not None and spikes[1] > 0:
            # the time view counts and measures them: nothing left to fit
            fixed["amplitude"] = spikes[1]
            fixed["rate"] = spikes[0]
            if tail_spread and spikes[1] * (1.0 - 1.0 / TAIL_MEAN) / tail_spread < TAIL_BAND[1] + 1:
                also = frozenset({"tail"})
        elif effect == "step":
            fixed["interval"] = duration / max(n_changes, 1)
        elif effect == "warmup":
            fixed["duration"] = duration
            if warmup_tau is not None:
                fixed["tau_w"] = warmup_tau
        elif effect == "bursts":
            if bursts is None:
                continue
            # the time view locates the bursts: their share of the time and mean length
            fixed["duty"], fixed["burst_s"] = bursts
        elif effect in ("resonance", "drifting_line"):
            if not bands or bands[0].kind != effect:
                continue
            level = "N" if effect == "resonance" else "amplitude"
            fixed.update({k: v for k, v in bands[0].params.items() if k != level})
            start[level] = bands[0].params[level]
            measured = (level,)
            if effect == "resonance":
                others = tuple(dict(b.params) for b in bands[1:] if b.kind == effect)
            if effect == "drifting_line":
                fixed["duration"] = duration
        elif effect == "lowpass":
            replaces = whites[0]
            fixed["N"] = float(replaces.values()["N"])
        elif effect == "white_drift":
            fixed_drift = _drift_fixed(drift, duration)
            if fixed_drift is None:
                continue
            replaces = whites[0]
            fixed.update(fixed_drift)
            start["N"] = float(replaces.values()["N"])
            # it keeps the mean level (no tau size): its size is the measured level ratio
            view_size = abs(fixed_drift["ratio"] - 1.0)
        names = tuple(p.name for p in cls.params)
        free = tuple(n for n in names if n not in fixed)
        out.append(
            Candidate(
                effect=effect,
                term_cls=cls,
                free=free,
                fixed=fixed,
                start=start,
                replaces=replaces,
                measured=measured,
                others=others,
                view_size=view_size,
                explains_also=also,
            )
        )
    for term in terms:
        effect = f"rescale:{term.type}"
        if effects is not None and effect not in effects and "rescale" not in effects:
            continue
        if term.type == "turn_on_bias":
            continue  # a constant has no Allan variance: nothing to rescale in the tau view
        out.append(Candidate(effect=effect, term_cls=type(term), free=("scale",), base=term))
    return out, unavailable
