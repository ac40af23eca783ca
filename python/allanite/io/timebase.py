"""Time columns: infer the sampling frequency, detect gaps and jitter, apply a gap policy.

An Allan variance assumes evenly spaced samples. A time column tells whether that holds: the
nominal period is the mean of the regular intervals (those shorter than ``GAP_FACTOR`` times
the median interval), the jitter is the spread of those intervals around it, and a gap is an
interval of ``GAP_FACTOR`` periods or more. Timestamps that repeat or go backwards are errors:
the file was concatenated or sorted wrongly and only the user knows how to repair it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from allanite.errors import InputError
from allanite.io.record import Segment, Timing

__all__ = [
    "FS_CONFLICT",
    "FS_SOURCES",
    "GAP_FACTOR",
    "GAP_POLICIES",
    "JITTER_WARN",
    "TimeBase",
    "resolve_time",
]

#: an interval of at least this many nominal periods is a gap
GAP_FACTOR = 1.5
#: RMS jitter (fraction of the period) above which a warning is attached
JITTER_WARN = 0.01
#: relative difference between a given fs and the time column's rate beyond which the record
#: is refused unless ``fs_source`` says which wins (a clock off by 10 % is not drift)
FS_CONFLICT = 0.1
#: what ``fs_source`` may name: the time stamps or the given fs
FS_SOURCES = ("time", "fs")
#: what to do about gaps
GAP_POLICIES: tuple[str, ...] = ("error", "split", "fill")


@dataclass(frozen=True)
class TimeBase:
    """Samples made evenly spaced, with what was found on the way."""

    samples: NDArray[np.float64]
    fs: float
    segments: tuple[Segment, ...]
    timing: Timing
    warnings: tuple[str, ...]


def _default_where(row: int) -> str:
    return f"row {row + 1}"


def resolve_time(
    t: NDArray[np.float64],
    samples: NDArray[np.float64],
    *,
    source: str,
    policy: str = "error",
    fs: float | None = None,
    where: Callable[[int], str] = _default_where,
    fs_source: str | None = None,
) -> TimeBase:
    """Check a time column and return evenly sampled data under a gap policy.

    Parameters
    ----------
    t : numpy.ndarray
        Time stamps in seconds, shape ``(N,)``.
    samples : numpy.ndarray
        ``(N, C)`` samples.
    source : str
        File name for messages.
    policy : {"error", "split", "fill"}
        ``error`` refuses gaps; ``split`` keeps the samples and marks contiguous segments;
        ``fill`` inserts the missing samples by linear interpolation between the neighbours.
    fs : float, optional
        Sampling frequency given by the user; it wins over the inferred one (a warning is
        attached when they differ by more than 1 %). When they differ by more than
        :data:`FS_CONFLICT` the record is refused unless ``fs_source`` says which wins.
    where : callable
        Maps a row index to a location for messages (``"line 12"``).
    fs_source : {"time", "fs"}, optional
        Which rate wins when ``fs`` and the time column disagree.

    Returns
    -------
    TimeBase
    """
    if policy not in GAP_POLICIES:
        raise ValueError(f"unknown gap policy {policy!r}; use one of {', '.join(GAP_POLICIES)}")
    t = np.asarray(t, dtype=np.float64)
    _check_stamps(t, source, where)
    dt = np.diff(t)
    is_gap = dt >= GAP_FACTOR * float(np.median(dt))
    regular = dt[~is_gap]
    dt_nominal = float(regular.mean())
    deviation = regular - dt_nominal
    jitter_rms = float(np.sqrt(np.mean(deviation**2)))
    jitter_max = float(np.max(np.abs(deviation)))
    gap_idx = np.flatnonzero(is_gap)
    missing = np.rint(dt[gap_idx] / dt_nominal).astype(np.int64) - 1
    gaps = tuple((int(i) + 1, float(dt[i]), int(k)) for i, k in zip(gap_idx, missing, strict=True))
    inferred = 1.0 / dt_nominal
    warnings: list[str] = []
    if jitter_rms > JITTER_WARN * dt_nominal:
        warnings.append(
            f"time stamps jitter by {100 * jitter_rms / dt_nominal:.2g} % rms of the period "
            f"(largest {100 * jitter_max / dt_nominal:.2g} %); the Allan variance assumes even "
            "sampling"
        )
    rate = _chosen_rate(fs, inferred, fs_source, source, warnings)
    samples, segments, filled = _apply_gap_policy(
        t,
        samples,
        gaps,
        gap_idx,
        missing,
        policy=policy,
        source=source,
        where=where,
        warnings=warnings,
    )
    timing = Timing(
        fs=inferred,
        dt_nominal=dt_nominal,
        jitter_rms=jitter_rms,
        jitter_max=jitter_max,
        gaps=gaps,
        filled=filled,
    )
    return TimeBase(
        samples=samples, fs=rate, segments=segments, timing=timing, warnings=tuple(warnings)
    )


def _check_stamps(t: NDArray[np.float64], source: str, where: Callable[[int], str]) -> None:
    """Refuse too few, non-finite, unsorted or duplicated time stamps, naming the row."""
    if t.size < 3:
        raise InputError(
            f"only {t.size} time stamps; a record needs at least 3 samples", path=source
        )
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise InputError(
            f"{where(int(bad[0]))}: time stamp is {t[bad[0]]}; remove the row or repair the time "
            "column",
            path=source,
        )
    dt = np.diff(t)
    back = np.flatnonzero(dt < 0)
    if back.size:
        i = int(back[0]) + 1
        raise InputError(
            f"{where(i)}: time stamps are not sorted ({t[i]:.9g} s comes after {t[i - 1]:.9g} s); "
            "sort the rows by time (e.g. sort -g) or check that files were not concatenated "
            "out of order",
            path=source,
        )
    dup = np.flatnonzero(dt == 0)
    if dup.size:
        i = int(dup[0]) + 1
        raise InputError(
            f"{where(i)}: duplicated time stamp {t[i]:.9g} s ({dup.size} duplicate(s) in all); "
            "remove the repeated rows (e.g. uniq) before the analysis",
            path=source,
        )


def _apply_gap_policy(
    t: NDArray[np.float64],
    samples: NDArray[np.float64],
    gaps: tuple[tuple[int, float, int], ...],
    gap_idx: NDArray[np.int64],
    missing: NDArray[np.int64],
    *,
    policy: str,
    source: str,
    where: Callable[[int], str],
    warnings: list[str],
) -> tuple[NDArray[np.float64], tuple[Segment, ...], int]:
    """Samples, segments and filled count after the gap policy (a warning says what was done)."""
    n = t.size
    if not gaps:
        return samples, (Segment(0, n, float(t[0])),), 0
    first = gaps[0]
    described = (
        f"{len(gaps)} gap(s) in the time column, the first at {where(first[0])} "
        f"({first[1]:.6g} s, about {first[2]} missing sample(s))"
    )
    if policy == "error":
        raise InputError(
            f"{described}; choose a gap policy: split into segments (--gaps split, "
            "gaps='split') or fill by interpolation (--gaps fill, gaps='fill')",
            path=source,
        )
    if policy == "split":
        starts = [0, *(g[0] for g in gaps)]
        stops = [*(g[0] for g in gaps), n]
        segments = tuple(Segment(a, b, float(t[a])) for a, b in zip(starts, stops, strict=True))
        warnings.append(f"{described}; split into {len(segments)} segments")
        return samples, segments, 0
    steps = np.ones(n - 1, dtype=np.int64)
    steps[gap_idx] = missing + 1
    slots = np.concatenate([[0], np.cumsum(steps)])
    grid = np.arange(slots[-1] + 1, dtype=np.float64)
    filled_samples = np.column_stack(
        [np.interp(grid, slots, samples[:, c]) for c in range(samples.shape[1])]
    )
    filled = int(grid.size - n)
    warnings.append(f"{described}; filled {filled} sample(s) by linear interpolation")
    return filled_samples, (Segment(0, grid.size, float(t[0])),), filled


def _chosen_rate(
    fs: float | None, inferred: float, fs_source: str | None, source: str, warnings: list[str]
) -> float:
    """The sampling rate of a record with a time column and perhaps a given ``fs``.

    A given ``fs`` within 1 % of the time column's rate is used silently, within
    :data:`FS_CONFLICT` with a warning; beyond it, only when ``fs_source`` says which wins.
    """
    if fs_source is not None and fs_source not in FS_SOURCES:
        raise ValueError(f"fs_source must be one of {', '.join(FS_SOURCES)}, got {fs_source!r}")
    if fs is None:
        return inferred
    differ = abs(fs - inferred) > 0.01 * inferred
    if fs_source is None and abs(fs - inferred) > FS_CONFLICT * inferred:
        raise ValueError(
            f"{source}: the given fs = {fs:g} Hz contradicts the {inferred:.6g} Hz of the time "
            f"column ({max(fs, inferred) / min(fs, inferred):.3g}x apart); say which wins with "
            "fs_source='time' (CLI: --fs-source time) to use the time stamps, or "
            "fs_source='fs' (CLI: --fs-source fs) to use the given fs"
        )
    if fs_source == "time":
        if differ:
            warnings.append(
                f"the given fs = {fs:g} Hz differs from the {inferred:.6g} Hz of the time column; "
                "using the time column (--fs-source time)"
            )
        return inferred
    if differ:
        how = "(--fs-source fs)" if fs_source == "fs" else ""
        warnings.append(
            f"the given fs = {fs:g} Hz differs from the {inferred:.6g} Hz of the time column; "
            f"using the given value {how}".rstrip()
        )
    return float(fs)
