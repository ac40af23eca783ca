r"""Simulate records from a noise model: one-shot, chunked (bounded memory) or to a file.

A model is a sum of :class:`~allanite.terms.base.Term` objects (a
:class:`allanite.model.NoiseModel` or any sequence of terms). Each term gets its own child
seed (``SeedSequence(seed).spawn(n_terms)``) and streams its rate samples; the sum is
returned as rate, angle increments (:math:`\Delta\theta_k = \bar\omega_k \Delta t`) or angle
(:math:`\theta_k = \Delta t\sum_{i \le k}\bar\omega_i`, the angle at the end of sample
``k``, summed with Neumaier compensation in the C++ core so that day-long records keep full
precision). Every sample depends on the seed alone: :func:`simulate` and any chunking of
:func:`simulate_chunks` agree bit for bit.
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Iterator, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from allanite import _core
from allanite._deprecation import keyword_only_fs, renamed
from allanite.memory import check_allocation
from allanite.simulation.flicker import FLICKER_METHODS
from allanite.simulation.streams import SumStream, block_length, check_fs, seed_sequence
from allanite.terms.base import Term
from allanite.terms.flicker import Flicker

__all__ = [
    "DEFAULT_CHUNK",
    "OUTPUTS",
    "model_terms",
    "parse_duration",
    "record_length",
    "simulate",
    "simulate_chunks",
]

Output = Literal["rate", "angle", "increment"]
OUTPUTS: tuple[str, ...] = ("rate", "angle", "increment")
#: samples per chunk of :func:`simulate_chunks` (the memory bound of streaming)
DEFAULT_CHUNK = 1 << 20

_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "min": 60.0, "m": 60.0, "h": 3600.0, "d": 86400.0}


def parse_duration(text: str | float) -> float:
    """Seconds from ``"90"``, ``"90s"``, ``"30min"``, ``"1.5h"``, ``"2d"`` or a number.

    Raises
    ------
    ValueError
        For anything else, or a duration that is not positive and finite.
    """
    if isinstance(text, bool):
        raise TypeError(
            f"duration must be a number of seconds or a string like '24h', got {text!r}"
        )
    if isinstance(text, numbers.Real):
        seconds = float(text)
    else:
        match = re.fullmatch(
            r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-zA-Z]*)\s*", str(text)
        )
        unit = match.group(2).lower() if match else None
        if match is None or unit not in _UNITS:
            raise ValueError(
                f"cannot read the duration {text!r}; write a number with an optional unit s, min, "
                "h or d (e.g. 90s, 30min, 24h)"
            )
        seconds = float(match.group(1)) * _UNITS[unit]
    if not math.isfinite(seconds) or seconds <= 0:
        raise ValueError(f"the duration must be positive and finite, got {text!r}")
    return seconds


def record_length(n: int | None = None, duration: str | float | None = None, *, fs: float) -> int:
    """Return the number of samples from ``n`` or ``duration`` (one of them) at ``fs`` Hz."""
    rate = check_fs(fs)
    if (n is None) == (duration is None):
        raise ValueError("give the record length as n (samples) or duration (seconds), not both")
    if n is not None:
        if isinstance(n, bool) or not isinstance(n, numbers.Integral):
            raise TypeError(f"n must be a whole number of samples, got {n!r}")
        samples = int(n)
    else:
        samples = round(parse_duration(duration) * rate)  # type: ignore[arg-type]
    if samples < 1:
        raise ValueError(
            f"the record would have {samples} samples; give a positive length (n >= 1 or a "
            "duration of at least one sample period)"
        )
    return samples


def model_terms(model: Any) -> list[Term]:
    """Return the terms of a NoiseModel (``.terms``), a single Term or a sequence of Terms."""
    if isinstance(model, Term):
        return [model]
    terms = getattr(model, "terms", model)
    if isinstance(terms, (str, bytes)) or not isinstance(terms, Sequence):
        raise TypeError(
            f"expected a NoiseModel, a Term or a list of Terms, got {type(model).__name__}"
        )
    out = list(terms)
    for t in out:
        if not isinstance(t, Term):
            raise TypeError(f"a model holds Term objects, got {type(t).__name__}")
    if not out:
        raise ValueError("the model has no terms; add at least one noise term to simulate")
    return out


def _check_band(term: Term, fs: float, allow_aliasing: bool) -> None:
    """Refuse tones and cutoffs above Nyquist unless aliasing is explicitly wanted."""
    nyquist = 0.5 * fs
    for name in ("frequency", "f0"):
        value = getattr(term, name, None)
        if value is not None and float(value) > nyquist and not allow_aliasing:
            raise ValueError(
                f"{type(term).__name__}.{name} = {value} Hz is above the Nyquist frequency "
                f"{nyquist} Hz of fs = {fs} Hz; raise fs, lower {name}, or pass "
                "allow_aliasing=True (CLI: --allow-aliasing) to simulate the aliased samples"
            )


def _open(
    model: Any,
    fs: float,
    n: int,
    n_channels: int,
    seed: Any,
    allow_aliasing: bool,
    flicker_method: str = "auto",
) -> SumStream:
    terms = model_terms(model)
    if (
        isinstance(n_channels, bool)
        or not isinstance(n_channels, numbers.Integral)
        or n_channels < 1
    ):
        raise ValueError(f"n_channels must be a positive integer, got {n_channels!r}")
    if flicker_method not in FLICKER_METHODS:
        raise ValueError(
            f"unknown flicker_method {flicker_method!r}; use one of "
            f"{', '.join(map(repr, FLICKER_METHODS))}"
        )
    for term in terms:
        _check_band(term, fs, allow_aliasing)
    # each term's stream holds a float64 block of block_length x channels values (and as many
    # again in temporaries): refused before allocating, not a MemoryError halfway
    check_allocation(
        2 * 8 * len(terms) * block_length(int(n_channels)) * int(n_channels),
        f"simulating {len(terms):,} term(s) x {int(n_channels):,} channel(s)",
        "simulate fewer channels (or fewer terms) at a time",
    )
    # per-type stream options: only flicker has a choice of method
    options: dict[str, dict[str, Any]] = {Flicker.type: {"method": flicker_method}}
    children = seed_sequence(seed).spawn(len(terms))
    streams = [
        term.stream(fs, int(n_channels), child, n_samples=n, **options.get(term.type, {}))
        for term, child in zip(terms, children, strict=True)
    ]
    return SumStream(streams, fs, int(n_channels))


@keyword_only_fs
def simulate_chunks(
    model: Any,
    n: int | None = None,
    *,
    fs: float,
    duration: str | float | None = None,
    output: Output = "rate",
    n_channels: int = 1,
    seed: Any = None,
    chunk: int = DEFAULT_CHUNK,
    allow_aliasing: bool = False,
    flicker_method: str = "auto",
    channels: int | None = None,
) -> Iterator[NDArray[np.float64]]:
    """Yield the simulated record in ``(chunk, channels)`` pieces (the last may be shorter).

    Memory is bounded by the chunk and the terms' blocks, whatever the record length (the
    flicker term of a record longer than ``SPECTRAL_MAX_SAMPLES`` streams through its
    AR(1) bank + FIR generator). Parameters as in :func:`simulate`; ``chunk`` only sets the
    piece size, never the samples.
    """
    n_channels = renamed(n_channels, channels, new="n_channels", old="channels", default=1)
    rate = check_fs(fs)
    total = record_length(n, duration, fs=rate)
    if output not in OUTPUTS:
        raise ValueError(f"unknown output {output!r}; use 'rate', 'angle' or 'increment'")
    if isinstance(chunk, bool) or not isinstance(chunk, numbers.Integral) or chunk < 1:
        raise ValueError(f"chunk must be a positive number of samples, got {chunk!r}")
    stream = _open(model, rate, total, n_channels, seed, allow_aliasing, flicker_method)
    dt = 1.0 / rate
    # compensated running sum carried across chunks (C++): identical for any chunking
    angle_hi, angle_lo = np.zeros(stream.n_channels), np.zeros(stream.n_channels)
    done = 0
    while done < total:
        size = min(int(chunk), total - done)
        values = stream.next(size)
        if output == "increment":
            values = values * dt
        elif output == "angle":
            values = _core.running_sum(angle_hi, angle_lo, values) * dt
        done += size
        yield values


@keyword_only_fs
def simulate(
    model: Any,
    n: int | None = None,
    *,
    fs: float,
    duration: str | float | None = None,
    output: Output = "rate",
    n_channels: int = 1,
    seed: Any = None,
    allow_aliasing: bool = False,
    flicker_method: str = "auto",
    channels: int | None = None,
) -> NDArray[np.float64]:
    r"""Simulate a record of ``n`` samples (or ``duration``) at ``fs`` Hz from a noise model.

    Parameters
    ----------
    model : NoiseModel, Term or sequence of Term
        The effects to add up.
    n : int, optional
        Number of samples (or give ``duration``).
    fs : float
        Sampling frequency in Hz (keyword-only, as everywhere in allanite).
    duration : float or str, optional
        Record length in seconds or with a unit: ``"90s"``, ``"30min"``, ``"24h"``.
    output : {"rate", "angle", "increment"}
        Rate samples (means over each period, model units), angle increments
        :math:`\bar\omega_k\Delta t` or accumulated angle :math:`\Delta t\sum_{i\le k}
        \bar\omega_i`.
    n_channels : int
        Independent channels (axes or Monte Carlo runs) simulated at once.
    seed : None, int or numpy.random.SeedSequence
        Same seed, same samples (whatever the chunking).
    allow_aliasing : bool
        Allow tones (and flicker cutoffs) above the Nyquist frequency ``fs/2``.
    flicker_method : {"auto", "spectral", "kasdin", "bank"}
        How flicker terms are simulated (:func:`allanite.simulation.flicker.flicker_stream`):
        ``auto`` = exact spectral synthesis up to ``SPECTRAL_MAX_SAMPLES``, else the streaming
        AR(1) bank + FIR generator (the same law to about 1e-6); ``kasdin`` = Kasdin's
        fractional filter (law: :func:`allanite.terms.flicker_laws.kasdin_avar`).
    channels : int, optional
        Deprecated name of ``n_channels`` (``channels`` means channel names elsewhere, as in
        :class:`allanite.io.Record`); warns.

    Returns
    -------
    numpy.ndarray
        Shape ``(n,)`` for one channel, else ``(n, n_channels)``.

    Raises
    ------
    ValueError
        For ``fs <= 0``, a zero length, an unknown output or flicker method, a tone above
        Nyquist, or a flicker method that cannot serve the record.
    """
    n_channels = renamed(n_channels, channels, new="n_channels", old="channels", default=1)
    rate = check_fs(fs)
    total = record_length(n, duration, fs=rate)
    pieces = list(
        simulate_chunks(
            model,
            total,
            fs=rate,
            output=output,
            n_channels=n_channels,
            seed=seed,
            chunk=total,
            allow_aliasing=allow_aliasing,
            flicker_method=flicker_method,
        )
    )
    record = pieces[0]
    return record[:, 0] if record.shape[1] == 1 else record
