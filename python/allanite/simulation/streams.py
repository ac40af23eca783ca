"""Streaming generators of rate samples: the :class:`TermStream` interface.

A stream produces the rate samples of one effect (or of a sum of effects) for ``C``
independent channels, any number at a time: ``stream.next(n)`` returns the next ``n`` samples
as a ``(n, C)`` float64 array. Long records are generated chunk by chunk in bounded memory.

Reproducibility whatever the chunk size
---------------------------------------
Every stream generates its samples internally in blocks of a fixed size
(:func:`block_length`, set by the channel count alone), drawing its random numbers for one
whole block at a time, in a fixed order, from its own generator; ``next(n)`` only cuts the
concatenated blocks. The samples therefore depend on the seed alone, never on how the caller
slices the record: one-shot and chunked generation agree bit for bit. A model gives each
term its own child :class:`numpy.random.SeedSequence` (``SeedSequence(seed).spawn(n_terms)``),
so adding a term does not change the samples of the others.

What a rate sample is
---------------------
A rate sample is the value the term's exact sampled Allan variance (``Term.avar(tau, dt)``)
describes: the mean of the continuous rate over the sample period where the term is defined
that way (flicker, warm-up, steps, telegraph, low-pass), the discrete process itself where the
term is defined as a sampled process (Gauss-Markov AR(1), rate random walk, sinusoid).
"""

from __future__ import annotations

import math
import numbers
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.errors import check_fs_range

__all__ = [
    "BLOCK",
    "SumStream",
    "TermStream",
    "block_length",
    "check_fs",
    "make_generator",
    "seed_sequence",
]

#: values (samples x channels) per internal block; the block length in samples,
#: :func:`block_length`, depends only on the channel count, never on the caller's chunks
BLOCK_VALUES = 1 << 16
#: block length of a single-channel stream
BLOCK = BLOCK_VALUES


def block_length(n_channels: int) -> int:
    """Return the internal block length in samples for ``n_channels`` channels (>= 1024)."""
    return max(1024, BLOCK_VALUES // max(1, n_channels))


def seed_sequence(seed: Any) -> np.random.SeedSequence:
    """Make a :class:`numpy.random.SeedSequence` from None, an int >= 0 or a SeedSequence.

    Raises
    ------
    TypeError
        For anything else (a :class:`numpy.random.Generator` cannot be split reproducibly:
        pass an integer seed instead).
    """
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if seed is None:
        return np.random.SeedSequence()
    if isinstance(seed, numbers.Integral) and not isinstance(seed, bool):
        if int(seed) < 0:
            raise ValueError(f"seed must be a non-negative integer, got {seed}")
        return np.random.SeedSequence(int(seed))
    raise TypeError(
        f"seed must be None, a non-negative integer or a numpy SeedSequence, got {seed!r}"
    )


def make_generator(seed: Any) -> np.random.Generator:
    """Make a PCG64 :class:`numpy.random.Generator` seeded from :func:`seed_sequence`."""
    return np.random.Generator(np.random.PCG64(seed_sequence(seed)))


def check_fs(fs: float) -> float:
    """``fs`` as a positive finite float, else ValueError/TypeError naming the fix."""
    if isinstance(fs, bool) or not isinstance(fs, numbers.Real):
        raise TypeError(f"fs must be a sampling frequency in Hz (a number), got {fs!r}")
    value = float(fs)
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"fs must be a positive, finite sampling frequency in Hz, got {fs!r}")
    return check_fs_range(value)


def _check_count(name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if int(value) < minimum:
        raise ValueError(f"{name} must be at least {minimum}, got {value}")
    return int(value)


class TermStream(ABC):
    """Rate samples of one effect for ``n_channels`` independent channels, block by block.

    Subclasses implement :meth:`_generate`, which must produce the next ``BLOCK`` samples from
    the stream's own state and generator :attr:`rng`, always drawing the same random numbers
    for a block; :meth:`next` serves any chunk size from those blocks.

    Parameters
    ----------
    fs : float
        Sampling frequency in Hz.
    n_channels : int
        Number of independent channels ``C``.
    seed : None, int or numpy.random.SeedSequence
        Seed of this stream's generator.
    """

    def __init__(self, fs: float, n_channels: int, seed: Any = None) -> None:
        self.fs = check_fs(fs)
        self.dt = 1.0 / self.fs
        self.n_channels = _check_count("n_channels", n_channels, 1)
        self.rng = make_generator(seed)
        self.block = block_length(self.n_channels)
        self.position = 0  #: samples delivered so far
        self._generated = 0  # samples generated so far (a multiple of BLOCK)
        self._buffer: NDArray[np.float64] = np.empty((0, self.n_channels))
        self._offset = 0

    @abstractmethod
    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        """Generate samples ``start .. start + n - 1`` (``n == self.block``), shape ``(n, C)``."""

    def next(self, n: int) -> NDArray[np.float64]:
        """Return the next ``n`` rate samples, shape ``(n, C)``, float64."""
        n = _check_count("n", n, 0)
        out = np.empty((n, self.n_channels))
        filled = 0
        while filled < n:
            if self._offset == self._buffer.shape[0]:
                block = self._generate(self._generated, self.block)
                self._buffer = np.asarray(block, dtype=np.float64)
                self._generated += self.block
                self._offset = 0
            take = min(n - filled, self._buffer.shape[0] - self._offset)
            out[filled : filled + take] = self._buffer[self._offset : self._offset + take]
            self._offset += take
            filled += take
        self.position += n
        return out

    def times(self, start: int, n: int) -> NDArray[np.float64]:
        """Start times ``(start + k) dt`` of the samples ``start .. start + n - 1`` (column)."""
        return ((start + np.arange(n, dtype=np.float64)) * self.dt)[:, None]


class SumStream:
    """The sum of several streams of the same rate and channel count (a model's output)."""

    def __init__(self, streams: Sequence[TermStream], fs: float, n_channels: int) -> None:
        self.fs = check_fs(fs)
        self.n_channels = _check_count("n_channels", n_channels, 1)
        for s in streams:
            if s.n_channels != self.n_channels or s.fs != self.fs:
                raise ValueError("all streams of a sum need the same fs and channel count")
        self.streams = list(streams)
        self.position = 0

    def next(self, n: int) -> NDArray[np.float64]:
        """Return the next ``n`` samples of the sum, shape ``(n, C)``."""
        n = _check_count("n", n, 0)
        out = np.zeros((n, self.n_channels))
        for s in self.streams:
            out += s.next(n)
        self.position += n
        return out
