"""A record read from a file: samples with their sampling frequency, input kind and units."""

from __future__ import annotations

import dataclasses
import re
import shlex
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.errors import check_fs_range
from allanite.units import record_rate_unit

__all__ = ["INPUT_KINDS", "Record", "Segment", "Timing", "time_like"]

_TIME_NAME = re.compile(
    r"^(t|time|times|timestamp|timestamps|stamp|sec|secs|seconds)"
    r"([ _\-]?(s|sec|\[s\]|\(s\)|\[sec\]))?$",
    re.I,
)


def time_like(name: str) -> bool:
    """Whether a column name reads as a time stamp column (``t``, ``time``, ``time_s``, ...)."""
    return bool(_TIME_NAME.match(name.strip()))


#: what the samples are: angular rate, angle increments per sample, or angle
INPUT_KINDS: tuple[str, ...] = ("rate", "increment", "angle")


@dataclass(frozen=True)
class Segment:
    """A contiguous, evenly sampled stretch of a record: samples ``start`` to ``stop - 1``.

    Attributes
    ----------
    start, stop : int
        Sample indices (half-open range) in :attr:`Record.samples`.
    t0 : float
        Time stamp of the first sample in seconds (0 when the record had no time column).
    """

    start: int
    stop: int
    t0: float = 0.0

    @property
    def n_samples(self) -> int:
        """Number of samples in the segment."""
        return self.stop - self.start


@dataclass(frozen=True)
class Timing:
    """What the time column said about the sampling.

    Attributes
    ----------
    fs : float
        Sampling frequency inferred from the time column, ``1 / dt_nominal``, in Hz.
    dt_nominal : float
        Nominal sample period: mean of the regular intervals (gaps excluded), in seconds.
    jitter_rms, jitter_max : float
        RMS and largest absolute deviation of the sample intervals from ``dt_nominal`` (gaps
        excluded), in seconds.
    gaps : tuple of tuple
        ``(index, duration_s, missing_samples)`` for every interval longer than 1.5 periods;
        ``index`` is the sample after the gap.
    filled : int
        Number of samples inserted by the ``"fill"`` gap policy.
    """

    fs: float
    dt_nominal: float
    jitter_rms: float
    jitter_max: float
    gaps: tuple[tuple[int, float, int], ...] = ()
    filled: int = 0

    @property
    def jitter_relative(self) -> float:
        """RMS jitter as a fraction of the sample period."""
        return self.jitter_rms / self.dt_nominal

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "fs": self.fs,
            "dt_nominal": self.dt_nominal,
            "jitter_rms": self.jitter_rms,
            "jitter_max": self.jitter_max,
            "jitter_relative": self.jitter_relative,
            "gaps": [list(g) for g in self.gaps],
            "filled": self.filled,
        }


@dataclass(frozen=True)
class Record:
    """Samples of one or more channels, ready for :func:`allanite.avar`.

    Attributes
    ----------
    samples : numpy.ndarray
        ``(N, C)`` array (samples, channels), already multiplied by any scale factor.
    fs : float or None
        Sampling frequency in Hz (given, or inferred from a time column); None if unknown.
    input : str
        ``"rate"``, ``"increment"`` or ``"angle"``.
    units : str or None
        Unit of the samples after scaling (e.g. ``"deg/s"`` for rate, ``"deg"`` for angle).
    channels : tuple of str
        One name per column of :attr:`samples`.
    source : str
        Where the samples came from (file name, ``"DataFrame"``, ...).
    segments : tuple of Segment
        Contiguous stretches; one segment spanning everything unless a time column showed gaps
        and the ``"split"`` policy was chosen.
    warnings : tuple of str
        Things the reader noticed and the user should know (jitter, filled gaps, ...).
    timing : Timing or None
        Analysis of the time column, when there was one.
    scale : float or None
        Scale factor that was applied (counts to units).
    temperature : numpy.ndarray or None
        Sensor temperature in °C at every sample, shape ``(N,)`` (a column, variable or topic
        named by ``temperature=``, resampled onto the sample times), or None.
    """

    samples: NDArray[Any]
    fs: float | None
    input: str = "rate"
    units: str | None = None
    channels: tuple[str, ...] = ()
    source: str = "array"
    segments: tuple[Segment, ...] = ()
    warnings: tuple[str, ...] = ()
    timing: Timing | None = None
    scale: float | None = None
    temperature: NDArray[np.float64] | None = field(default=None, compare=False, repr=False)
    meta: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        samples = np.asarray(self.samples)
        if samples.ndim == 1:
            samples = samples.reshape(-1, 1)
        if samples.ndim != 2:
            raise ValueError(f"samples must be (N,) or (N, C), got shape {samples.shape}")
        object.__setattr__(self, "samples", samples)
        if self.input not in INPUT_KINDS:
            raise ValueError(f"unknown input {self.input!r}; use 'rate', 'increment' or 'angle'")
        if self.fs is not None and not (np.isfinite(self.fs) and self.fs > 0):
            raise ValueError(f"fs must be a positive, finite frequency in Hz, got {self.fs!r}")
        if self.fs is not None:
            check_fs_range(float(self.fs))
        if not self.channels:
            object.__setattr__(self, "channels", tuple(f"ch{i}" for i in range(samples.shape[1])))
        elif len(self.channels) != samples.shape[1]:
            raise ValueError(
                f"{len(self.channels)} channel names for {samples.shape[1]} columns of samples"
            )
        if not self.segments:
            object.__setattr__(self, "segments", (Segment(0, samples.shape[0]),))
        if self.temperature is not None:
            object.__setattr__(self, "temperature", _checked_temperature(self.temperature, samples))

    @property
    def n_samples(self) -> int:
        """Number of samples (rows)."""
        return int(self.samples.shape[0])

    @property
    def n_channels(self) -> int:
        """Number of channels (columns)."""
        return int(self.samples.shape[1])

    @property
    def duration(self) -> float | None:
        """Record length ``N / fs`` in seconds (None without fs)."""
        return None if self.fs is None else self.n_samples / self.fs

    def require_fs(self) -> float:
        """Return the sampling frequency, or raise a ValueError telling how to give it."""
        if self.fs is None:
            named = next((c for c in self.channels if time_like(c)), None)
            hint = (  # quoted: ``t [s]`` pasted unquoted is two shell words
                f"; column {named!r} looks like the time: --time-column {shlex.quote(named)}"
                if named is not None
                else ""
            )
            raise ValueError(
                f"{self.source}: the sampling frequency is unknown; give it with fs= (CLI: "
                f"--fs HZ) or name a time column (--time-column){hint}"
            )
        return self.fs

    def rate_unit(self) -> str | None:
        """Rate unit of the record: its unit for rate samples, unit per second for angle/increment.

        Raises
        ------
        ValueError
            If the unit is not a rate or acceleration for rate samples, or not an angle or a
            velocity for angle/increment samples (e.g. ``input="angle", units="deg/s"``).
        """
        return record_rate_unit(self.units, self.input, strict=True)

    def select(self, channels: list[int | str] | tuple[int | str, ...]) -> Record:
        """Return a record with only the given channels (by index or name), in the given order."""
        idx = [_channel_index(self.channels, c, self.source) for c in channels]
        if not idx:
            raise ValueError("select at least one channel")
        return dataclasses.replace(
            self,
            samples=self.samples[:, idx],
            channels=tuple(self.channels[i] for i in idx),
        )

    def rows(self, start: int, stop: int, *, t0: float = 0.0) -> Record:
        """Return samples ``start`` to ``stop - 1`` (and their temperatures) as one segment."""
        return dataclasses.replace(
            self,
            samples=self.samples[start:stop],
            segments=(Segment(0, stop - start, t0),),
            temperature=None if self.temperature is None else self.temperature[start:stop],
        )

    def segment(self, index: int) -> Record:
        """Return one segment of a split record as a record of its own."""
        seg = self.segments[index]
        return self.rows(seg.start, seg.stop, t0=seg.t0)

    def longest_segment(self) -> Record:
        """Return the longest contiguous segment (the record itself when it has one segment)."""
        if len(self.segments) == 1:
            return self
        lengths = [s.n_samples for s in self.segments]
        return self.segment(int(np.argmax(lengths)))

    def summary(self) -> dict[str, Any]:
        """JSON-ready description (no samples): source, fs, shape, units, segments, warnings."""
        return {
            "source": self.source,
            "fs": self.fs,
            "input": self.input,
            "units": self.units,
            "n_samples": self.n_samples,
            "duration_s": self.duration,
            "channels": list(self.channels),
            "scale": self.scale,
            "segments": [[s.start, s.stop, s.t0] for s in self.segments],
            "timing": None if self.timing is None else self.timing.to_dict(),
            "warnings": list(self.warnings),
            "temperature": None
            if self.temperature is None
            else {"min": float(self.temperature.min()), "max": float(self.temperature.max())},
        }


def _checked_temperature(values: Any, samples: NDArray[Any]) -> NDArray[np.float64]:
    """The temperatures as a finite float64 ``(N,)`` array matching the samples, or ValueError."""
    temperature = np.asarray(values, dtype=np.float64).reshape(-1)
    if temperature.size != samples.shape[0]:
        raise ValueError(
            f"temperature has {temperature.size} values for {samples.shape[0]} samples; give "
            "one temperature per sample (resample it onto the sample times)"
        )
    if not np.all(np.isfinite(temperature)):
        bad = int(np.flatnonzero(~np.isfinite(temperature))[0])
        raise ValueError(
            f"temperature at sample {bad} is {temperature[bad]}; give a finite value at every "
            "sample (interpolate the missing ones)"
        )
    return temperature


def _channel_index(names: tuple[str, ...], key: int | str, source: str) -> int:
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        i = int(key)
        if i < 0:
            raise ValueError(
                f"{source}: channel {i}: channels are numbered from 0 to {len(names) - 1}; "
                f"negative indices are not accepted (the last channel is {len(names) - 1}, "
                f"named {names[-1]!r})"
            )
        if i >= len(names):
            raise ValueError(
                f"{source}: channel {i} out of range; the record has {len(names)} channels "
                f"({', '.join(names)})"
            )
        return i
    if isinstance(key, str):
        if key in names:
            return names.index(key)
        if key.lstrip("-").isdigit():
            return _channel_index(names, int(key), source)
        raise ValueError(f"{source}: no channel named {key!r}; available: {', '.join(names)}")
    raise TypeError(f"channels are selected by index or name, got {key!r}")
