r"""Decimation of the window-scale replicates of a long record's null.

Means over a time ``tau`` of white, flicker and random-walk noise, angle quantization, ramps
and slow processes do not depend on the sampling rate once ``tau >> D / fs``: the time view's
window statistics of a long record can be simulated at ``fs / D``. A term with a time scale
shorter than ``5 D / fs`` lowers ``D`` until it is resolved; a term not listed in
:data:`RATE_FREE` keeps ``D = 1``. Used by :mod:`allanite.diagnosis.scaled_null` and
:func:`allanite.diagnosis.time_view.added_level_variance`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["COARSE_LENGTH", "RATE_FREE", "decimation"]

#: target length of the decimated replicates (32 windows of 2048 samples)
COARSE_LENGTH = 2**16
#: term types whose window-scale statistics do not depend on the sampling rate, with the
#: parameter giving their shortest time scale in seconds (None: no time scale)
RATE_FREE: dict[str, Callable[[Any], float | None]] = {
    "white": lambda t: None,
    "flicker": lambda t: None,
    "rrw": lambda t: None,
    "quantization": lambda t: None,
    "ramp": lambda t: None,
    "turn_on_bias": lambda t: None,
    "bias_steps": lambda t: float(t.interval),
    "markov": lambda t: float(t.tau_c),
    "telegraph": lambda t: float(t.tau_c),
    "white_bursts": lambda t: float(t.burst_s),
    "white_drift": lambda t: None,
    "warmup": lambda t: float(t.tau_w),
    "sine": lambda t: 1.0 / float(t.frequency),
    "lowpass_white": lambda t: 1.0 / float(t.bandwidth),
}


def decimation(model: Any, n: int, fs: float) -> int:
    """Decimation factor ``D`` (a power of 2) of the window-scale replicates.

    The largest ``D`` with ``N / D >= COARSE_LENGTH`` and ``D / fs`` at most a fifth of every
    term's time scale; 1 for a term outside :data:`RATE_FREE`.
    """
    d = 1
    while n // (2 * d) >= COARSE_LENGTH:
        d *= 2
    for term in model.terms:
        scale_of = RATE_FREE.get(getattr(term, "type", ""))
        if scale_of is None:
            return 1
        scale = scale_of(term)
        if scale is not None:
            while d > 1 and d / fs > scale / 5.0:
                d //= 2
    return d
