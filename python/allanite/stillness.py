r"""Motion in a record that should be still: where the sensor was handled, and the still parts.

An Allan variance of a record that contains handling (a gyro picked up and turned, a robot
bag that starts and ends with driving) measures the motion, not the noise: one minute at a
few rad/s in an hour of rest raises the white-noise level several times over. This module
finds the motion and the still segments, so the commands can say so and analyse the still
part (``--still auto``).

The record is cut into windows of :data:`WINDOW_S` (at least :data:`MIN_WINDOW` samples) and
every channel, as rate (and, for an accelerometer triad, the specific-force magnitude), gives
two statistics per window:

* the **variance jump** ``log v_w``, the log of the window's variance;
* the **rate change** ``m_w - m_{w-1}``, the difference of neighbouring windows' 10 %
  trimmed means (so that a spike of a few samples does not move it, and a quantized output
  still gives a continuous statistic).

Both are local, so the slow wander of a random walk or flicker noise moves neither much, and
both are calibrated against the record itself: a window is moving when a statistic lies more
than ``z`` robust standard deviations (1.4826 MAD over all windows) from its median, with
``z`` the two-sided Bonferroni quantile of :data:`FALSE_ALARM` over the windows and
statistics, and the variance also at least :data:`MIN_VARIANCE_FACTOR` times the median. The
rule holds for any stationary noise whatever its spectrum, since the windows' statistics of
stationary noise are identically distributed (a random walk's increments, a flicker's, a
filtered white noise's all are); motion is what breaks that. Isolated windows (a spike) are
not motion: a moving stretch needs :data:`MIN_RUN` windows in a row (3 s; a 2 s burst of
outliers in the Xsens MTi-G record of the shared data is not called motion); each is widened by one
window on both sides (the start and end of a movement are slower than its middle).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from allanite.io.record import Record
from allanite.units import sensor_kind

__all__ = ["STILL_MODES", "Stillness", "find_motion", "still_record"]

#: window length in seconds (the windows hold at least MIN_WINDOW samples)
WINDOW_S = 1.0
MIN_WINDOW = 32
#: family-wise false-alarm probability of the windows of a still record
FALSE_ALARM = 1e-3
#: a moving window's variance is also at least this many times the median window's
MIN_VARIANCE_FACTOR = 1.5
#: consecutive flagged windows that make motion (fewer: a spike, not a movement)
MIN_RUN = 3
#: share trimmed from each end of a window for its mean rate
TRIM = 0.1
#: the values of ``--still``
STILL_MODES = ("warn", "auto", "off")


@dataclass(frozen=True)
class Stillness:
    """Motion found in a record.

    Attributes
    ----------
    fs : float
        Sampling frequency (Hz).
    n_samples : int
        Samples of the record.
    moving : tuple of (int, int)
        Sample ranges ``[start, stop)`` of motion.
    still : tuple of (int, int)
        Sample ranges of the still segments (the complement), longest first.
    """

    fs: float
    n_samples: int
    moving: tuple[tuple[int, int], ...]
    still: tuple[tuple[int, int], ...]

    @property
    def has_motion(self) -> bool:
        """Whether any motion was found."""
        return bool(self.moving)

    def times(self, ranges: tuple[tuple[int, int], ...]) -> str:
        """Sample ranges as times, e.g. ``"0-120 s, 300-3600 s"``."""
        return ", ".join(f"{a / self.fs:.6g}-{b / self.fs:.6g} s" for a, b in ranges)

    def message(self) -> str:
        """One line: where the motion is and the still segments' times."""
        moved = sum(b - a for a, b in self.moving) / self.fs
        still = self.times(self.still[:5]) or "none"
        more = f" (+{len(self.still) - 5} more)" if len(self.still) > 5 else ""
        return (
            f"the record contains motion ({moved:.6g} s at {self.times(self.moving[:5])}"
            f"{' ...' if len(self.moving) > 5 else ''}): its Allan variance measures the "
            f"motion, not the noise; still segments: {still}{more}; analyse the longest with "
            "--still auto"
        )


def _as_rate(x: NDArray[np.float64], input_kind: str) -> NDArray[np.float64]:
    if input_kind == "angle":
        return np.diff(x, axis=0)
    return x


def _flags(v: NDArray[np.float64], m: NDArray[np.float64], n_tests: int) -> NDArray[np.bool_]:
    """Windows whose variance or mean change departs from the record's own spread."""
    z = float(stats.norm.isf(FALSE_ALARM / (2.0 * n_tests)))
    logv = np.log(np.maximum(v, np.finfo(np.float64).tiny))
    med = float(np.median(logv))
    s = 1.4826 * float(np.median(np.abs(logv - med)))
    jump = logv - med > max(z * s, np.log(MIN_VARIANCE_FACTOR))
    dm = np.diff(m)
    dmed = float(np.median(dm))
    ds = 1.4826 * float(np.median(np.abs(dm - dmed)))
    step = np.abs(dm - dmed) > z * ds if ds > 0 else np.zeros(dm.size, dtype=bool)
    change = np.zeros(v.size, dtype=bool)
    change[1:] |= step
    change[:-1] |= step
    return np.asarray(jump | change)


def _runs(flag: NDArray[np.bool_]) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.concatenate(([0], flag.astype(np.int8), [0]))))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def find_motion(
    samples: NDArray[np.float64],
    *,
    fs: float,
    input: str = "rate",
    accelerometer_triad: bool = False,
) -> Stillness:
    """Find the motion in a record and its still segments.

    Parameters
    ----------
    samples : ndarray
        ``(N,)`` or ``(N, C)`` samples (rate, increments or angle).
    fs : float
        Sampling frequency (Hz).
    input : {"rate", "increment", "angle"}
        What the samples are (angle is differenced into increments first).
    accelerometer_triad : bool
        The three channels are an accelerometer's axes: their magnitude is tested too.

    Returns
    -------
    Stillness
    """
    x = np.asarray(samples, dtype=np.float64)
    x = _as_rate(x.reshape(-1, 1) if x.ndim == 1 else x, input)
    if accelerometer_triad and x.shape[1] == 3:
        x = np.column_stack([x, np.sqrt(np.sum(x**2, axis=1))])
    n = x.shape[0]
    w = max(MIN_WINDOW, round(WINDOW_S * fs))
    n_win = n // w
    offset = 1 if input == "angle" else 0
    if n_win < 8:
        return Stillness(fs, n + offset, (), ((0, n + offset),))
    blocks = x[: n_win * w].reshape(n_win, w, x.shape[1])
    v = blocks.var(axis=1)
    m = stats.trim_mean(blocks, TRIM, axis=1)  # a spike of a few samples does not move it
    n_tests = 2 * n_win * x.shape[1]
    flag = np.zeros(n_win, dtype=bool)
    for c in range(x.shape[1]):
        flag |= _flags(v[:, c], m[:, c], n_tests)
    moving_w = [(a, b) for a, b in _runs(flag) if b - a >= MIN_RUN]
    wide = np.zeros(n_win, dtype=bool)
    for a, b in moving_w:
        wide[max(0, a - 1) : min(n_win, b + 1)] = True
    moving = [(a * w, min(b * w, n) + offset) for a, b in _runs(wide)]
    if moving and moving[-1][1] >= n_win * w:  # the tail after the last window moves too
        moving[-1] = (moving[-1][0], n + offset)
    still = [(a * w, b * w + (offset if b * w >= n else 0)) for a, b in _runs(~wide)]
    if still and not wide[-1]:
        still[-1] = (still[-1][0], n + offset)
    still.sort(key=lambda r: r[0] - r[1])
    return Stillness(fs, n + offset, tuple(moving), tuple(still))


def still_record(record: Record, mode: str = "warn") -> tuple[Record, Stillness | None]:
    """The record with a warning when it moves; with ``mode="auto"`` its longest still segment.

    Parameters
    ----------
    record : Record
        A record with a sampling frequency.
    mode : {"warn", "auto", "off"}
        ``"warn"``: the record, with :meth:`Stillness.message` added to its warnings when it
        contains motion; ``"auto"``: the longest still segment (a note with its times);
        ``"off"``: the record unchanged, not examined.

    Returns
    -------
    (Record, Stillness or None)
    """
    if mode not in STILL_MODES:
        raise ValueError(f"--still {mode}: choose one of {', '.join(STILL_MODES)}")
    if mode == "off" or record.fs is None:
        return record, None
    try:
        triad = sensor_kind(record.rate_unit() or "") == "accelerometer"
    except ValueError:
        triad = False
    found = find_motion(record.samples, fs=record.fs, input=record.input,
                        accelerometer_triad=triad)  # fmt: skip
    if not found.has_motion:
        return record, found
    if mode == "warn" or not found.still:
        return dataclasses.replace(record, warnings=(*record.warnings, found.message())), found
    a, b = found.still[0]
    note = (
        f"--still auto: analysing the longest still segment, {found.times(((a, b),))} "
        f"({(b - a) / found.fs:.6g} s of {found.n_samples / found.fs:.6g} s); motion at "
        f"{found.times(found.moving[:5])}"
    )
    part = dataclasses.replace(
        record.rows(a, b, t0=a / found.fs), warnings=(*record.warnings, note)
    )
    return part, found
