r"""Evidence about the time base: gaps and uneven steps in the time stamps, held samples.

Dropped samples leave no trace in a record of stationary noise (every statistic of the three
views stays the same), and the library's readers repair or split a time column before any
analysis. So the diagnosis reports what the time base itself says, next to the three views:

* **time stamps** (a :class:`~allanite.io.Record` read with a time column): every gap
  (an interval of at least 1.5 nominal periods, :data:`allanite.io.timebase.GAP_FACTOR`)
  with its time and length, the samples missing in all, how the reader handled them (filled
  by interpolation, or split and the longest segment analysed), and a time-stamp jitter above
  :data:`allanite.io.timebase.JITTER_WARN` of the period *that the record can show*
  (:func:`jitter_share`): sampling instants off by ``delta`` change a rate sample by its slope
  times ``delta``, and an angle or increment by the rate times the interval's error. At rest
  that is far below the noise (an ordinary ROS bag's 1 % jitter changes nothing), so the item
  is raised only when the predicted extra variance exceeds :data:`JITTER_SE` standard errors
  of the record's short-term variance; below that the reader's note stays the only mention.
  Repeated or backward time stamps never get this far: the readers refuse them with the row
  to repair.
* **held samples** (any record): a sensor or logger that repeats the previous value when a
  sample is missing leaves runs of exactly equal consecutive samples. Their number ``n_0`` is
  compared with what the record's own resolution explains
  (:mod:`allanite.diagnosis.resolution`): the resolution ``q`` is a lattice fit of the first
  differences that tolerates float rounding; for quantized samples the repeats expected
  without holding come from the record's own levels (the larger of independent levels,
  ``sum p_k^2`` in windows, and a quantized Gaussian difference fitted to the non-zero
  steps), block by block, and the held share beyond them is tested one-sided against
  :data:`~allanite.diagnosis.resolution.HELD_FLOOR`. Continuous (float) samples have no
  lattice: then ``e_0 = 1/2`` and the Poisson tail ``P(X >= n_0)`` is the p-value, so a
  handful of exact repeats already counts.

* **doubled increments** (angle or increment input without time stamps): a dropped sample
  makes one rate sample span two periods, one mean rate too high. On a turntable (a mean rate
  well above the noise) the time view finds these as spikes; when most located spikes lie
  within 25 % of the mean rate they are reported as dropped samples.

All are :class:`~allanite.diagnosis.verdict.Unexplained` items of view ``time``, evidence
``time base`` or ``held``; any of them keeps the diagnosis from reading "closed".
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from allanite.diagnosis.resolution import held_excess, output_resolution, rounding_floor
from allanite.diagnosis.verdict import Unexplained, Verdict
from allanite.io.record import Record
from allanite.io.timebase import JITTER_WARN

__all__ = [
    "doubled_increments_item",
    "held_samples_item",
    "time_base_evidence",
    "time_base_items",
    "with_time_base",
]

#: at most this many time segments are listed per item
MAX_SEGMENTS = 50
#: a jitter is evidence when its predicted extra short-term variance exceeds this many
#: standard errors (``sqrt(3 / n)`` relative, first differences of white noise) of that variance
JITTER_SE = 3.0
#: samples per block of the local rate (and its slope) that the jitter acts on
JITTER_BLOCK = 16


def _segments_text(segs: list[list[float]], limit: int = 4) -> str:
    text = ", ".join(f"{a:.4g}-{b:.4g} s" for a, b in segs[:limit])
    return text + (f" (+{len(segs) - limit} more)" if len(segs) > limit else "")


def jitter_share(
    rate: NDArray[np.float64], jitter_rms: float, fs: float, input_kind: str
) -> float | None:
    """Predicted extra variance of the rate samples from a time-stamp jitter, relative.

    Parameters
    ----------
    rate : ndarray
        The record as rate samples.
    jitter_rms : float
        RMS error of the intervals between time stamps (s), as
        :class:`allanite.io.record.Timing` measures it.
    fs : float
        Sampling frequency (Hz).
    input_kind : str
        ``"rate"``: a sample taken ``delta`` off its instant is off by the local slope times
        ``delta`` (each stamp carries ``1/sqrt(2)`` of the interval's error, a white error
        that adds ``slope^2 jitter_rms^2 / 2``); ``"angle"`` or ``"increment"``: a rate sample
        is the angle over an interval whose length is off by the difference of two stamps'
        errors, so it is off by the local rate times that; the error is a first difference
        and adds ``1.5 rate^2 (jitter_rms fs)^2`` to half the mean squared first difference.

    Returns
    -------
    float or None
        The jitter's share of the record's short-term variance ``mean(diff(rate)^2) / 2``,
        if the samples were taken at the stamped instants; the local rate and slope are block
        means of :data:`JITTER_BLOCK` samples (at rest their own noise adds about
        ``0.09 (jitter_rms fs)^2``, 1e-5 at a 1 % jitter, for angle input, and far less for
        rate input). None when it cannot be judged (fewer than two blocks, or no short-term
        variance).
    """
    x = np.asarray(rate, dtype=np.float64)
    n = x.size // JITTER_BLOCK * JITTER_BLOCK
    short = 0.5 * float(np.mean(np.diff(x) ** 2)) if x.size > 1 else 0.0
    if n < 2 * JITTER_BLOCK or short <= 0.0:
        return None
    local = x[:n].reshape(-1, JITTER_BLOCK).mean(axis=1)
    if input_kind == "rate":
        slope = np.diff(local) * fs / JITTER_BLOCK
        extra = float(np.mean(slope**2)) * jitter_rms**2 / 2.0
    else:
        extra = 1.5 * float(np.mean(local**2)) * (jitter_rms * fs) ** 2
    return extra / short


def _jitter_item(
    timing: Any, rate: NDArray[np.float64] | None, fs: float, input_kind: str
) -> Unexplained | None:
    """The jitter as an item when the record can show it (always when that cannot be judged)."""
    dt = timing.dt_nominal
    if timing.jitter_rms <= JITTER_WARN * dt:
        return None
    rel = timing.jitter_rms / dt
    size = {"jitter_rms_relative": rel, "jitter_max_s": timing.jitter_max}
    effect = ""
    share = None if rate is None else jitter_share(rate, timing.jitter_rms, fs, input_kind)
    if share is not None and rate is not None:
        if share <= JITTER_SE * np.sqrt(3.0 / max(rate.size, 1)):
            return None
        size["extra_variance_share"] = share
        effect = (
            f"; sampled at those instants, it accounts for about {100 * min(share, 1.0):.2g} % "
            "of the short-term noise variance"
        )
    return Unexplained(
        "time",
        "time base",
        {"time_segments_s": []},
        size,
        0.0,
        f"time view: the time stamps are uneven: jitter {100 * rel:.2g} % rms of the period "
        f"(largest {timing.jitter_max:.3g} s){effect}; the analysis assumes even sampling",
    )


def time_base_items(
    record: Any, rate: NDArray[np.float64] | None = None, input_kind: str = "rate"
) -> list[Unexplained]:
    """Gaps and jitter of a Record's time column as unexplained items (none without one).

    With the record's ``rate`` samples the jitter is an item only when it changes them
    measurably (:func:`jitter_share`); without, any jitter above the reader's warning level is.
    """
    timing = getattr(record, "timing", None) if isinstance(record, Record) else None
    if timing is None:
        return []
    items: list[Unexplained] = []
    dt = timing.dt_nominal
    if timing.gaps:
        segs: list[list[float]] = []
        before = 0
        for index, duration, missing in timing.gaps:
            start = (index - 1 + before) * dt
            segs.append([start, start + duration])
            before += missing
        total_missing = int(sum(g[2] for g in timing.gaps))
        total_s = float(sum(g[1] for g in timing.gaps))
        n_total = record.n_samples + (0 if timing.filled else total_missing)
        how = (
            f"filled by interpolation ({timing.filled} samples)"
            if timing.filled
            else f"split into {len(record.segments)} segments, the longest analysed"
        )
        text = (
            f"time view: the time stamps have {len(timing.gaps)} gap(s), {total_missing} missing "
            f"sample(s) ({100.0 * total_missing / max(n_total, 1):.2g} %) at "
            f"{_segments_text(segs)}; {how}: the samples are not what the sensor measured "
            "there"
        )
        items.append(
            Unexplained(
                "time",
                "time base",
                {"time_segments_s": segs[:MAX_SEGMENTS], "gaps": len(timing.gaps)},
                {
                    "gaps": float(len(timing.gaps)),
                    "missing_samples": float(total_missing),
                    "missing_fraction": total_missing / max(n_total, 1),
                    "gap_seconds": total_s,
                    "filled_samples": float(timing.filled),
                },
                0.0,
                text,
            )
        )
    jitter = _jitter_item(timing, rate, 1.0 / dt, input_kind)
    if jitter is not None:
        items.append(jitter)
    return items


def _held_runs(held: NDArray[np.bool_], fs: float, gap_s: float) -> list[list[float]]:
    """Times of the held samples, merged when closer than ``gap_s``."""
    idx = np.flatnonzero(held) + 1  # sample k repeats sample k - 1
    out: list[list[float]] = []
    for k in idx:
        t = float(k) / fs
        if out and t - out[-1][1] <= gap_s:
            out[-1][1] = t + 1.0 / fs
        else:
            out.append([t, t + 1.0 / fs])
    return out


def held_samples_item(samples: Any, fs: float, level: float) -> Unexplained | None:
    """Held (repeated) samples as an unexplained item, or None when the record explains them.

    Parameters
    ----------
    samples : array_like
        The record as given (rate, increments or angle), one channel.
    fs : float
        Sampling frequency in Hz.
    level : float
        Significance level of the test.
    """
    x = np.asarray(samples, dtype=np.float64).ravel()
    if x.size < 3:
        return None
    q = output_resolution(x)
    if q is None:  # continuous samples: an exact repeat (within rounding) is a held sample
        held = np.abs(np.diff(x)) <= rounding_floor(x)
        n0 = int(held.sum())
        if n0 == 0:
            return None
        expected = 0.5
        p = float(stats.poisson.sf(n0 - 1, expected))
        basis = "the record's resolution"
    else:
        held = np.diff(np.rint((x - x[0]) / q)) == 0
        test = held_excess(x, q)
        n0, expected, p = test.count, test.expected, test.p_value
        basis = f"the record's resolution {q:.4g} and its level distribution"
    if p >= level:
        return None
    segs = _held_runs(held, fs, gap_s=0.01 * x.size / fs)
    text = (
        f"time view: {n0} held samples (a value repeated exactly, {100.0 * n0 / held.size:.2g} % "
        f"of the samples; {expected:.3g} expected from {basis}) at "
        f"{_segments_text(segs)}: a logger or sensor that repeats the last value when a sample "
        f"is missing, p = {p:.2g}"
    )
    return Unexplained(
        "time",
        "held",
        {"time_segments_s": segs[:MAX_SEGMENTS]},
        {"count": float(n0), "fraction": n0 / held.size, "expected": expected}
        | ({} if q is None else {"resolution": q}),
        p,
        text,
    )


def doubled_increments_item(input_kind: str, mean_rate: float, view: Any) -> Unexplained | None:
    """Spikes of the size of the mean rate in angle or increment input: dropped samples.

    A dropped angle sample makes one rate sample span two periods: it reads ``mean rate +
    noise`` too high. When most spikes the time view located (``view.spike_amplitudes``, above
    the running median) lie within 25 % of the record's mean rate, they are reported as
    dropped samples; None otherwise (rate input, no spikes, a mean rate of zero).
    """
    heights = np.asarray(getattr(view, "spike_amplitudes", []), dtype=np.float64)
    if input_kind == "rate" or heights.size == 0 or mean_rate == 0.0:
        return None
    near = np.abs(heights - mean_rate) < 0.25 * abs(mean_rate)
    if near.mean() < 0.5:
        return None
    times = np.asarray(view.spike_times_s, dtype=np.float64)[near]
    segs = [[float(t), float(t)] for t in times[:MAX_SEGMENTS]]
    text = (
        f"time view: {int(near.sum())} samples one mean rate too high "
        f"({float(np.median(heights[near])):.3g} vs a mean rate of {mean_rate:.3g}) at "
        f"{', '.join(f'{t:.4g}' for t in times[:4])} s"
        f"{f' (+{times.size - 4} more)' if times.size > 4 else ''}: dropped {input_kind} samples "
        "(each a doubled increment)"
    )
    return Unexplained(
        "time",
        "time base",
        {"time_segments_s": segs},
        {"doubled_increments": float(near.sum()), "mean_rate": mean_rate},
        0.0,
        text,
    )


def time_base_evidence(
    record: Any,
    samples: Any,
    fs: float,
    level: float,
    *,
    input_kind: str = "rate",
    samples_rate: NDArray[np.float64] | None = None,
    view: Any = None,
) -> list[Unexplained]:
    """Every time-base item: time stamps, held samples, doubled increments.

    Time stamps of ``record`` (a Record; its jitter judged on ``samples_rate``, the record as
    rates), held samples of ``samples`` (as given), doubled increments among the spikes of
    the time ``view`` (angle or increment input).
    """
    rate = np.asarray(samples_rate, dtype=np.float64) if samples_rate is not None else None
    mean_rate = float(rate.mean()) if rate is not None and rate.size else 0.0
    items = time_base_items(record, rate, input_kind)
    for item in (
        held_samples_item(samples, fs, level),
        doubled_increments_item(input_kind, mean_rate, view),
    ):
        if item is not None:
            items.append(item)
    return items


def with_time_base(head: Verdict, items: list[Unexplained]) -> Verdict:
    """The verdict with the time-base items added: not closed when there is any."""
    if not items:
        return head
    text = "; ".join(i.text for i in items)
    if head.closed:
        headline = f"{head.headline}; but not everything is explained: {text}"
    else:
        headline = f"{head.headline}; {text}"
    return replace(head, closed=False, unexplained=[*head.unexplained, *items], headline=headline)
