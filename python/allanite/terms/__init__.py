"""Noise terms: one class per effect (see :mod:`allanite.terms.base`)."""

from __future__ import annotations

from allanite.terms.base import TERM_TYPES, ParamSpec, Term, term_from_dict
from allanite.terms.bursts import WhiteBursts
from allanite.terms.drifting_line import DriftingLine
from allanite.terms.flicker import Flicker
from allanite.terms.markov import GaussMarkov
from allanite.terms.quantization import Quantization
from allanite.terms.ramp import RateRamp
from allanite.terms.resonance import Resonance
from allanite.terms.rrw import RateRandomWalk
from allanite.terms.sine import Sine
from allanite.terms.transients import (
    BiasSteps,
    LowPassWhite,
    Spikes,
    Telegraph,
    TurnOnBias,
    WarmUp,
)
from allanite.terms.white import White
from allanite.terms.white_drift import WhiteDrift

#: the stationary IEEE power-law terms in order of increasing tau slope
POWER_LAW_TERMS: tuple[type[Term], ...] = (Quantization, White, Flicker, RateRandomWalk, RateRamp)

__all__ = [
    "POWER_LAW_TERMS",
    "TERM_TYPES",
    "BiasSteps",
    "DriftingLine",
    "Flicker",
    "GaussMarkov",
    "LowPassWhite",
    "ParamSpec",
    "Quantization",
    "RateRamp",
    "RateRandomWalk",
    "Resonance",
    "Sine",
    "Spikes",
    "Telegraph",
    "Term",
    "TurnOnBias",
    "WarmUp",
    "White",
    "WhiteBursts",
    "WhiteDrift",
    "term_from_dict",
]
