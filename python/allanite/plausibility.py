r"""Plausibility checks: records that look like a mistaken input, said out loud.

A wrong ``input`` kind, counts without a scale factor or a stuck sensor all give an Allan
deviation that looks like an answer. These checks look for the signature of each mistake and
return one warning line per finding (the CLI prints them on stderr and keeps them in the
record's ``warnings``, so they reach the JSON and the report); a record whose samples are
all equal is refused, since it has no noise to analyse.

* **angle given as rate?** An angle record read as rate is a ramp (the bias) plus a random
  walk, whose Allan deviation rises as :math:`\tau^{+1}` (or :math:`\tau^{+1/2}` without
  a bias) from the shortest tau over a decade or more. A rate sensor shows white noise, a
  falling curve, at its shortest averaging times.
* **rate given as angle?** Rate samples read as angle are differenced into white angle noise,
  whose deviation falls as :math:`\tau^{-1}` over the whole range (a real angle record
  flattens into angle random walk, -1/2, and bias instability, 0).
* **counts without a scale?** Whole-number samples whose mean lies many short-tau deviations
  away from zero: raw ADC counts with an offset.
* **stuck segments.** A value repeated for far longer than the record's own runs of equal
  samples (ten times their 99.9th percentile, and at least 20 samples).
* **wrong --units?** Noise coefficients outside the range of any real sensor
  (:data:`COEFFICIENT_BOUNDS`): a deg/h record given as deg/s has 3600 times its angle random
  walk. The finding names the common unit of the same quantity that would put every checked
  coefficient back in range (the one closest to a typical sensor), e.g. "the record looks like
  deg/h given as deg/s: N would be 0.367 deg/sqrt(h)".

The slopes come from :mod:`allanite.slopes` (half-decade windows, points with at least
20 EDF), so the checks read the curve the way the report's slope table does.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from allanite.errors import ImplausibleInputWarning
from allanite.slopes import MIN_EDF, local_slopes, slope_table
from allanite.units import SYMBOL_POWERS, coefficient_unit, convert, sensor_kind

__all__ = [
    "Finding",
    "check_allan",
    "check_channel_units",
    "check_coefficients",
    "check_means",
    "check_samples",
    "constant_channels",
    "is_triad",
    "refuse_constant",
    "stuck_segments",
    "warn_coefficients",
]

#: kinds whose power-law slopes are those of the Allan deviation (-1, -1/2, 0, +1/2, +1)
_ADEV_SLOPE_KINDS = ("overlapping", "standard", "hadamard", "standard_hadamard", "total")
#: slope rows at least this steep (+1/2 random walk, +1 ramp) from the shortest tau over a
#: decade read as "angle given as rate"
RISING_SLOPE = 0.35
#: ... when the rise begins at most this many shortest taus in
RISING_START = 5.0
#: a falling slope at least this steep over the whole range reads as "rate given as angle"
FALLING_SLOPE = -0.8
#: |mean| / short-tau deviation above which whole-number samples look like offset counts
COUNTS_RATIO = 100.0
#: shortest run of equal samples ever reported as stuck
MIN_STUCK = 20
#: ... and at least this many times the 99.9th percentile of the record's own run lengths
STUCK_FACTOR = 10.0
#: at most this many stuck segments are listed per channel
MAX_LISTED = 3

#: Range of the noise coefficients of real sensors, per sensor kind and symbol:
#: ``(lowest, highest, typical, unit)`` (None: no bound on that side). Gyros: angle random
#: walk from strategic-grade ring-laser and hemispherical resonator gyros (~1e-4 deg/sqrt(h))
#: to the cheapest consumer MEMS (a few deg/sqrt(h)), a decade of margin each side, so
#: [1e-5, 100] deg/sqrt(h); bias instability up to 1e5 deg/h (~30 deg/s, beyond the
#: turn-on bias of any gyro; consumer MEMS are 1-100 deg/h; 1e4 deg/h would flag synthetic
#: records of benchmarks/validate_fit.py's grid, whose B reaches 8e4 deg/h with N 0.01
#: deg/sqrt(h), a mix-up no unit explains). Accelerometers: velocity random walk from
#: navigation grade (~1e-3 m/s/sqrt(h), 5 ug/sqrt(Hz)) to consumer MEMS (~0.3 m/s/sqrt(h),
#: 1 mg/sqrt(Hz)), a decade and more of margin: [1e-5, 10] m/s/sqrt(h); bias instability up
#: to 1e6 ug (1 g; consumer MEMS are 10-1000 ug; the validate_fit grid's synthetic
#: m/s^2 records reach 1.1e5 ug). No lower bound on B (an upper limit of a
#: term the record hardly shows can be tiny). ``typical`` ranks the candidate units of a
#: suggested mix-up (the geometric middle of the classes).
COEFFICIENT_BOUNDS: dict[str, dict[str, tuple[float | None, float | None, float, str]]] = {
    "gyro": {
        "N": (1e-5, 100.0, 0.03, "deg/sqrt(h)"),
        "B": (None, 1e5, 1.0, "deg/h"),
    },
    "accelerometer": {
        "N": (1e-5, 10.0, 0.01, "m/s/sqrt(h)"),
        "B": (None, 1e6, 100.0, "ug"),
    },
}
#: units a record is commonly given in, by mistake for one another (same dimension only)
COMMON_UNITS = (
    "deg/s",
    "deg/h",
    "rad/s",
    "mrad/s",
    "rad/h",
    "m/s^2",
    "g",
    "mg",
    "ug",
    "deg",
    "rad",
    "mrad",
    "arcsec",
    "m/s",
)


@dataclass(frozen=True)
class Finding:
    """One plausibility warning.

    Attributes
    ----------
    code : str
        ``"angle_as_rate"``, ``"rate_as_angle"``, ``"counts_without_scale"``, ``"stuck"`` or
        ``"unit_vs_name"``.
    channel : str
        The channel it concerns.
    message : str
        One line naming the channel, what was seen and what to do.
    """

    code: str
    channel: str
    message: str

    def __str__(self) -> str:
        return self.message

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"code": self.code, "channel": self.channel, "message": self.message}


def _columns(samples: NDArray[Any]) -> NDArray[Any]:
    arr = np.asarray(samples)
    return arr.reshape(-1, 1) if arr.ndim == 1 else arr


def constant_channels(samples: NDArray[Any]) -> list[int]:
    """Indices of the channels whose samples are all equal (none for fewer than 2 samples)."""
    x = _columns(samples)
    if x.shape[0] < 2:
        return []
    return [c for c in range(x.shape[1]) if x[:, c].min() == x[:, c].max()]


def refuse_constant(
    samples: NDArray[Any], channels: Sequence[str] = (), *, source: str = "record"
) -> None:
    """Raise a ValueError if any channel's samples are all equal.

    A constant record has an Allan deviation of zero at every tau; that is not a measurement
    of noise but a dead channel, a wrong column or a sensor that was not running.
    """
    x = _columns(samples)
    dead = constant_channels(x)
    names = list(channels) or [f"ch{i}" for i in range(x.shape[1])]
    if not dead:
        return
    which = ", ".join(f"{names[c]} (all {x.shape[0]} samples equal {x[0, c]:.6g})" for c in dead)
    hint = (
        "leave it out with --channels"
        if len(dead) < x.shape[1]
        else "check the column (--channels), the file and that the sensor was running"
    )
    raise ValueError(
        f"{source}: channel {which} is constant; a constant record has no noise to analyse "
        f"(its Allan deviation is zero at every tau): {hint}"
    )


def _runs(v: NDArray[Any], chunk: int = 1 << 18) -> Iterator[tuple[NDArray[Any], NDArray[Any]]]:
    """Runs of equal consecutive samples as ``(starts, lengths)`` arrays, chunk by chunk.

    Memory is O(chunk) whatever the record's length; a run crossing a chunk border is carried
    over and reported once, whole.
    """
    n = v.size
    open_start = 0  # start of the run still open at the end of the previous chunk
    for lo in range(0, n, chunk):
        hi = min(n, lo + chunk)
        block = v[lo:hi]
        change = np.flatnonzero(block[1:] != block[:-1]) + 1 + lo
        if lo > 0 and v[lo] != v[lo - 1]:
            change = np.concatenate(([lo], change))
        if change.size == 0:
            continue
        starts = np.concatenate(([open_start], change[:-1]))
        yield starts, change - starts
        open_start = int(change[-1])
    yield np.array([open_start]), np.array([n - open_start])


def stuck_segments(x: NDArray[Any]) -> list[tuple[int, int]]:
    """Runs of equal consecutive samples too long for the record, as ``(start, stop)`` indices.

    A run is stuck when it holds at least ``MIN_STUCK`` samples and ``STUCK_FACTOR`` times the
    99.9th percentile of the record's own run lengths. The record is its own reference: float
    samples almost never repeat, so 20 equal ones are stuck; quantized or slowly varying
    samples repeat naturally (noise below the step, a resting angle), and only a run far
    longer than their longest ordinary dwell is reported. One streaming pass, O(1) memory.
    """
    v = np.asarray(x).ravel()
    if v.size < 2 * MIN_STUCK:
        return []
    cap = 1 << 16  # run lengths are counted exactly up to cap; longer ones are kept
    counts = np.zeros(cap + 1, dtype=np.int64)
    long_starts: list[NDArray[Any]] = []
    long_lengths: list[NDArray[Any]] = []
    for starts, lengths in _runs(v):
        counts += np.bincount(np.minimum(lengths, cap), minlength=cap + 1)
        keep = lengths >= MIN_STUCK
        long_starts.append(starts[keep])
        long_lengths.append(lengths[keep])
    starts = np.concatenate(long_starts)
    lengths = np.concatenate(long_lengths)
    if lengths.size == 0:
        return []
    # 99.9th percentile of the run lengths from their histogram (lengths above cap only
    # matter when they are that common, and then the record is not judged run by run anyway)
    rank = int(np.searchsorted(np.cumsum(counts), 0.999 * counts.sum()))
    longest = max(MIN_STUCK, STUCK_FACTOR * rank)
    keep = lengths >= longest
    return [(int(a), int(a + n)) for a, n in zip(starts[keep], lengths[keep], strict=True)]


def check_samples(
    samples: NDArray[Any],
    *,
    fs: float,
    input: str = "rate",
    channels: Sequence[str] = (),
    scale: float | None = None,
    short_dev: NDArray[np.float64] | None = None,
) -> list[Finding]:
    """Checks on the samples themselves: stuck segments and counts without a scale.

    Parameters
    ----------
    samples : numpy.ndarray
        ``(N,)`` or ``(N, C)`` record.
    fs : float
        Sampling frequency in Hz (for the times of stuck segments).
    input : {"rate", "increment", "angle"}
        What the samples are; the counts check applies to rate and increment records.
    channels : sequence of str
        Channel names for the messages.
    scale : float, optional
        The counts-to-units factor already applied (no counts check when given).
    short_dev : numpy.ndarray, optional
        Deviation at the shortest tau per channel (the counts check needs it).

    Returns
    -------
    list of Finding
    """
    x = _columns(samples)
    names = list(channels) or [f"ch{i}" for i in range(x.shape[1])]
    out: list[Finding] = []
    for c in range(x.shape[1]):
        col = x[:, c]
        runs = stuck_segments(col)
        if runs:
            listed = "; ".join(
                f"at {col[a]:.6g} for {b - a} samples ({(b - a) / fs:.4g} s) from t = "
                f"{a / fs:.6g} s"
                for a, b in runs[:MAX_LISTED]
            )
            more = f"; and {len(runs) - MAX_LISTED} more" if len(runs) > MAX_LISTED else ""
            out.append(
                Finding(
                    "stuck",
                    names[c],
                    f"channel {names[c]}: stuck {listed}{more} (far longer than the record's "
                    "other runs of equal samples); check the sensor or the logger, or analyse "
                    "a stretch without it",
                )
            )
        if scale is None and input != "angle" and short_dev is not None:
            dev = float(short_dev[c])
            step = max(1, col.size // 1_000_000)
            sub = col[::step]
            whole = np.issubdtype(sub.dtype, np.integer) or bool(np.all(sub == np.round(sub)))
            mean = float(np.mean(col, dtype=np.float64))
            if whole and dev > 0 and abs(mean) > COUNTS_RATIO * dev:
                out.append(
                    Finding(
                        "counts_without_scale",
                        names[c],
                        f"channel {names[c]}: every sample is a whole number and the mean "
                        f"({mean:.6g}) is {abs(mean) / dev:.3g} times the deviation at the "
                        f"shortest tau ({dev:.3g}): raw counts without a scale factor? give "
                        "the units per count (--scale) and --units",
                    )
                )
    return out


def check_allan(result: Any, channels: Sequence[str] = ()) -> list[Finding]:
    """Checks on the Allan curve: slopes that betray a wrong ``input`` kind.

    Parameters
    ----------
    result : AllanResult
        The analysis (an Allan/Hadamard/total deviation; other kinds are not judged).
    channels : sequence of str
        Channel names for the messages.

    Returns
    -------
    list of Finding
    """
    if result.kind not in _ADEV_SLOPE_KINDS:
        return []
    dev = np.asarray(result.dev, dtype=np.float64).reshape(result.tau.size, -1)
    edf = np.asarray(result.edf, dtype=np.float64).reshape(dev.shape)
    names = list(channels) or [f"ch{i}" for i in range(dev.shape[1])]
    tau0 = float(result.tau[0])
    out: list[Finding] = []
    for c in range(dev.shape[1]):
        if result.input != "angle":
            rows = slope_table(result.tau, dev[:, c], edf[:, c])
            # skip what precedes the rise within the first RISING_START * tau0 (white angle
            # noise read as rate is flat there), then collect the rising rows
            k = 0
            while k < len(rows) and rows[k].slope < RISING_SLOPE:
                k += 1
            rising = []
            for row in rows[k:]:
                if row.slope < RISING_SLOPE:
                    break
                rising.append(row)
            if (
                rising
                and rising[0].tau_min <= RISING_START * tau0
                and rising[-1].tau_max >= 10.0 * rising[0].tau_min
            ):
                sel = (result.tau >= rising[0].tau_min) & (result.tau <= rising[-1].tau_max)
                slope = float(np.polyfit(np.log10(result.tau[sel]), np.log10(dev[sel, c]), 1)[0])
                out.append(
                    Finding(
                        "angle_as_rate",
                        names[c],
                        f"channel {names[c]}: the Allan deviation rises (as tau^{slope:+.2f}) "
                        f"from the shortest tau to {rising[-1].tau_max:.4g} s, as an angle "
                        f"record read as {result.input} does (a rate sensor shows white noise, "
                        "a falling curve, at short tau): angle given as rate? if the samples "
                        "are angles, give --input angle",
                    )
                )
            continue
        good = np.isfinite(dev[:, c]) & (dev[:, c] > 0) & (edf[:, c] >= MIN_EDF)
        tau, d = result.tau[good], dev[good, c]
        if tau.size < 3 or tau[0] > 2.0 * tau0 or np.log10(tau[-1] / tau[0]) < 1.0:
            continue
        whole = float(np.polyfit(np.log10(tau), np.log10(d), 1)[0])
        flattest = float(np.max(local_slopes(tau, d)))
        if whole <= FALLING_SLOPE and flattest <= FALLING_SLOPE + 0.1:
            out.append(
                Finding(
                    "rate_as_angle",
                    names[c],
                    f"channel {names[c]}: the Allan deviation falls as tau^{whole:+.2f} over "
                    f"the whole range ({tau[0]:.4g} to {tau[-1]:.4g} s), never flatter than "
                    f"tau^{flattest:+.2f}, as rate samples read as angle do (or an angle "
                    "sensor whose quantization dominates everywhere): rate given as angle? "
                    "if the samples are rates, give --input rate",
                )
            )
    return out


#: channel names that say which sensor a column is (gx, gyro_y, wz, omega_x / ax, acc_y, ...)
_NAMED_SENSOR = (
    (re.compile(r"^(g|gyr|gyro|w|omega|angular_velocity)[_.\-]?[xyz0-9]?$", re.I), "gyro"),
    (re.compile(r"^(a|acc|accel|linear_acceleration)[_.\-]?[xyz0-9]?$", re.I), "accelerometer"),
)


def check_channel_units(channels: Sequence[str], unit: str) -> list[Finding]:
    """Channels whose name says one sensor while their unit measures the other.

    A six-axis file read with ``--units deg/s,m/s^2,g`` puts ``gz`` in m/s^2: the grouping rule
    allows it, the names say it is a mistake (``gz`` is a gyro, ``ax`` an accelerometer).
    """
    from allanite.units import sensor_kind

    try:
        kind = sensor_kind(unit)
    except ValueError:
        return []
    out = []
    for name in channels:
        for pattern, named in _NAMED_SENSOR:
            if pattern.match(name.strip()) and kind in ("gyro", "accelerometer") and kind != named:
                out.append(
                    Finding(
                        "unit_vs_name",
                        name,
                        f"channel {name} is named like a{'n' if named[0] == 'a' else ''} "
                        f"{named} but its unit {unit} is for a{'n' if kind[0] == 'a' else ''} "
                        f"{kind}; check the order of --units",
                    )
                )
    return out


def _out_of_range(
    scaled: dict[str, float], bounds: dict[str, tuple[float | None, float | None, float, str]]
) -> list[str]:
    """The symbols whose value (in the bound's unit) lies outside the bounds."""
    bad = []
    for symbol, value in scaled.items():
        lo, hi, _, _ = bounds[symbol]
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            bad.append(symbol)
    return bad


_Bounds = dict[str, tuple[float | None, float | None, float, str]]
#: the largest mean a still gyro reads, in deg/s: beyond the turn-on bias of any gyro
#: (consumer MEMS datasheets give at most +-20 deg/s zero-rate offset; Earth rate is 4e-3
#: deg/s). A gyro on a turntable may read more: the finding says "if the gyro was still".
GYRO_MEAN_MAX = 30.0
#: the largest mean one still accelerometer axis reads, in g (1 g of gravity plus a bias)
ACCEL_MEAN_MAX = 2.0
#: a still accelerometer triad's mean has a magnitude of 1 g within this (consumer MEMS
#: offsets are up to ~0.1 g per axis)
TRIAD_TOLERANCE = 0.2
#: the mean of a still sensor in these units (the bound's unit)
_MEAN_UNIT = {"gyro": "deg/s", "accelerometer": "g"}


@dataclass(frozen=True)
class _Evidence:
    """What a channel's numbers say, in the units of the bounds, as given."""

    scaled: dict[str, float]
    mean: float | None  # |mean| in _MEAN_UNIT
    ceiling: float | None  # upper bound on N in N's bound unit

    def failures(
        self,
        kind: str,
        factor: float,
        bounds: dict[str, tuple[float | None, float | None, float, str]],
    ) -> list[str]:
        """Which checks fail when every number is multiplied by ``factor``."""
        moved = {s: v * factor for s, v in self.scaled.items()}
        bad = _out_of_range(moved, bounds)
        if self.mean is not None and self.mean * factor > _mean_max(kind):
            bad.append("mean")
        lo = bounds["N"][0]
        if self.ceiling is not None and lo is not None and self.ceiling * factor < lo:
            bad.append("noise")
        return bad


def _mean_max(kind: str) -> float:
    return GYRO_MEAN_MAX if kind == "gyro" else ACCEL_MEAN_MAX


def _candidates(
    unit: str, plausible: Callable[[float], bool], typical: Callable[[float], float]
) -> list[tuple[str, float]]:
    """Common units of the same quantity in which the numbers would be plausible.

    Each is ``(unit, factor)``, the numbers given in ``unit`` being ``factor`` times theirs in
    the candidate; most typical first.
    """
    found = []
    for other in COMMON_UNITS:
        if other == unit:
            continue
        try:
            factor = convert(1.0, other, unit)
        except ValueError:
            continue
        if plausible(factor):
            found.append((typical(factor), other, factor))
    return [(other, factor) for _, other, factor in sorted(found)]


def _fix_text(
    what: str,
    unit: str,
    candidates: Sequence[tuple[str, str]],
    spelling: Literal["cli", "python"],
) -> str:
    """The finding's advice: one unit named when exactly one makes the record plausible.

    A suggestion must never be worse than the input: when several units would make the
    record plausible (a 1 Hz logger's mrad/s given as rad/s reads like deg/h as well), the
    record alone cannot tell which, so they are listed and none is proposed.
    """
    if not candidates:
        return (
            f"{what}: check --units ({unit}) and --scale"
            if spelling == "cli"
            else f"{what}: check units={unit!r} (CLI: --units) and the reader's scale= (CLI: "
            "--scale)"
        )
    if len(candidates) == 1:
        ((other, would),) = candidates
        return f"{what}: the record looks like {other} given as {unit}: {would}; if so, pass " + (
            f"--units {other}" if spelling == "cli" else f"units={other!r} (CLI: --units {other})"
        )
    listed = "; or ".join(f"{other} given as {unit}: {would}" for other, would in candidates)
    return (
        f"{what}: it would be plausible as {listed} - the record alone cannot tell which, so "
        "no unit is proposed: pass the unit the logger writes with "
        + ("--units" if spelling == "cli" else "units= (CLI: --units)")
    )


def check_coefficients(
    values: Mapping[str, float | None],
    unit: str | None,
    *,
    input: str = "rate",
    channel: str = "ch0",
    spelling: Literal["cli", "python"] = "cli",
    mean: float | None = None,
    n_ceiling: float | None = None,
) -> list[Finding]:
    """Find noise coefficients or a mean outside any real sensor's range (a wrong ``--units``).

    Parameters
    ----------
    values : mapping
        Coefficient by symbol (``N``, ``B``, ...; others are ignored, None = not measured)
        in the record's rate unit times seconds to the term's power (a fit's
        ``model.coefficients()``, or the slope readouts of :mod:`allanite.fit.classic`).
    unit : str or None
        The record's unit as given (``deg/s``, ``deg`` for an angle record, ...); no check
        without one.
    input : {"rate", "increment", "angle"}
        What the samples are (the rate unit of the coefficients follows from it).
    channel : str
        Channel name for the message.
    spelling : {"cli", "python"}
        How the fix is spelled: ``--units deg/h`` for the command line, ``units='deg/h'
        (CLI: --units deg/h)`` for a library call (the CLI prints it as ``--units deg/h``,
        :func:`allanite.cli.cli_spelling`).
    mean : float, optional
        The channel's mean in ``unit`` (rate records only): a still gyro reads at most
        :data:`GYRO_MEAN_MAX` deg/s, an accelerometer axis :data:`ACCEL_MEAN_MAX` g.
    n_ceiling : float, optional
        An upper bound on N in the record's rate unit times sqrt(s): the deviation at the
        shortest tau times sqrt(tau) (every noise adds to it). Below the lowest N of any
        sensor, the numbers are too small for the unit (rad/s given as deg/h), even on a
        record whose N cannot be read off the curve.

    Returns
    -------
    list of Finding
        At most one (code ``"implausible_units"``), naming what is out of range, the
        bounds (:data:`COEFFICIENT_BOUNDS`) and the common units (:data:`COMMON_UNITS`) in
        which everything checked would be plausible; a fix (``--units X``) is proposed only
        when exactly one unit does, since a wrong proposal can be worse than the input.
    """
    from allanite.units import record_rate_unit

    if unit is None:
        return []
    try:
        rate = record_rate_unit(unit, input)
        kind = sensor_kind(rate) if rate is not None else "unknown"
    except ValueError:
        return []
    bounds = COEFFICIENT_BOUNDS.get(kind)
    if bounds is None or rate is None:
        return []
    scaled = {}
    for symbol, value in values.items():
        if symbol in bounds and value is not None and np.isfinite(value) and value > 0:
            own = coefficient_unit(rate, *SYMBOL_POWERS[symbol])
            scaled[symbol] = convert(float(value), own, bounds[symbol][3])
    evidence = _Evidence(
        scaled,
        abs(convert(float(mean), rate, _MEAN_UNIT[kind]))
        if mean is not None and input == "rate" and np.isfinite(mean)
        else None,
        convert(float(n_ceiling), coefficient_unit(rate, *SYMBOL_POWERS["N"]), bounds["N"][3])
        if n_ceiling is not None and n_ceiling > 0
        else None,
    )
    bad = evidence.failures(kind, 1.0, bounds)
    if not bad:
        return []
    what = f"channel {channel}: " + "; ".join(_seen(evidence, bad, bounds, kind, unit))

    def typical(factor: float) -> float:
        return float(sum(abs(np.log10(v * factor / bounds[s][2])) for s, v in scaled.items()))

    found = _candidates(unit, lambda f: not evidence.failures(kind, f, bounds), typical)
    described = [(other, _would(evidence, bad, factor, bounds, kind)) for other, factor in found]
    return [Finding("implausible_units", channel, _fix_text(what, unit, described, spelling))]


def _seen(
    evidence: _Evidence,
    bad: list[str],
    bounds: dict[str, tuple[float | None, float | None, float, str]],
    kind: str,
    unit: str,
) -> list[str]:
    """The findings' first half: what is out of range, and the range."""
    out = []
    coefficients = [s for s in bad if s in evidence.scaled]
    if coefficients:
        seen = ", ".join(f"{s} = {evidence.scaled[s]:.4g} {bounds[s][3]}" for s in coefficients)
        limits = "; ".join(f"{s} {_bounds_text(bounds[s])} {bounds[s][3]}" for s in coefficients)
        verb = "is" if len(coefficients) == 1 else "are"
        out.append(f"{seen} {verb} outside any real {kind}'s range ({limits})")
    if "mean" in bad and evidence.mean is not None:
        where = "Earth rate is 0.004 deg/s" if kind == "gyro" else "gravity is 1 g"
        out.append(
            f"the mean, {evidence.mean:.4g} {_MEAN_UNIT[kind]}, is beyond any still {kind}'s "
            f"bias (|mean| <= {_mean_max(kind):g} {_MEAN_UNIT[kind]}; {where}; if the "
            "sensor was moving, ignore this)"
        )
    if "noise" in bad and evidence.ceiling is not None:
        out.append(
            f"the deviation at the shortest tau bounds N to <= {evidence.ceiling:.3g} "
            f"{bounds['N'][3]}, quieter than any real {kind} (N >= {bounds['N'][0]:g})"
        )
    return out


def _would(
    evidence: _Evidence,
    bad: list[str],
    factor: float,
    bounds: dict[str, tuple[float | None, float | None, float, str]],
    kind: str,
) -> str:
    """What the checked numbers would be, each multiplied by ``factor``.

    The mean and the noise floor are shown only when they were out of range.
    """
    parts = [f"{s} would be {v * factor:.3g} {bounds[s][3]}" for s, v in evidence.scaled.items()]
    if evidence.mean is not None and "mean" in bad:
        parts.append(f"the mean {evidence.mean * factor:.3g} {_MEAN_UNIT[kind]}")
    if "noise" in bad and "N" not in evidence.scaled and evidence.ceiling is not None:
        parts.append(f"N <= {evidence.ceiling * factor:.3g} {bounds['N'][3]}")
    return ", ".join(parts)


#: the magnitude of gravity in the two units an accelerometer is commonly logged in
_GRAVITY = (("m/s^2", 9.80665), ("g", 1.0))
#: a gyro record's mean matches gravity within this fraction: accelerometer data?
GRAVITY_MATCH = 0.05


def _groups(n: int) -> list[list[int]]:
    """Channel groups judged together: triads when the channels come in threes."""
    return [[c, c + 1, c + 2] for c in range(0, n, 3)] if n % 3 == 0 else [[c] for c in range(n)]


def is_triad(unit: str | None, n_channels: int, input: str = "rate") -> bool:
    """True when the record is an accelerometer triad whose mean :func:`check_means` judges."""
    return n_channels == 3 and input == "rate" and _kind(unit) == "accelerometer"


def _kind(unit: str | None) -> str:
    if unit is None:
        return "unknown"
    try:
        return sensor_kind(unit)
    except ValueError:
        return "unknown"


def check_means(
    means: Sequence[float],
    unit: str | None,
    *,
    input: str = "rate",
    channels: Sequence[str] = (),
    spelling: Literal["cli", "python"] = "cli",
) -> list[Finding]:
    """Means that betray a wrong unit across channels: gravity where it should (not) be.

    * An accelerometer triad at rest reads gravity: the magnitude of its mean is 1 g within
      :data:`TRIAD_TOLERANCE`. 9.8 in a record labelled g is m/s^2 given as g; 1.0 labelled
      m/s^2 is g given as m/s^2 (the unit that restores 1 g is named when exactly one does).
    * A gyro record whose mean (one channel, or a triad) has the magnitude of gravity in
      m/s^2 or g, far beyond a still gyro's bias, is accelerometer data given a gyro's unit.

    Parameters
    ----------
    means : sequence of float
        Each channel's mean in ``unit``.
    unit : str or None
        The record's unit as given (no check without one; rate records only).
    input, channels, spelling
        As for :func:`check_coefficients`.

    Returns
    -------
    list of Finding
        Code ``"implausible_units"``.
    """
    kind = _kind(unit)
    if unit is None or input != "rate" or kind not in ("gyro", "accelerometer"):
        return []
    names = list(channels) or [f"ch{i}" for i in range(len(means))]
    out = []
    if is_triad(unit, len(means), input):
        magnitude = convert(float(np.linalg.norm(means)), unit, "g")
        if abs(magnitude - 1.0) > TRIAD_TOLERANCE:
            what = (
                f"channels {', '.join(names)}: the magnitude of the mean is {magnitude:.4g} g, "
                f"not the 1 g of gravity a still accelerometer triad reads (within "
                f"{TRIAD_TOLERANCE:g} g; if the sensor was moving, ignore this)"
            )
            found = _candidates(
                unit,
                lambda f: abs(magnitude * f - 1.0) <= TRIAD_TOLERANCE,
                lambda f: abs(np.log10(magnitude * f)),
            )
            described = [(o, f"the magnitude would be {magnitude * f:.4g} g") for o, f in found]
            out.append(
                Finding("implausible_units", names[0], _fix_text(what, unit, described, spelling))
            )
        return out
    if kind != "gyro":
        return out
    for group in _groups(len(means)):
        magnitude = float(np.linalg.norm([means[c] for c in group]))
        if convert(magnitude, unit, "deg/s") <= GYRO_MEAN_MAX:
            continue
        for accel, g in _GRAVITY:
            if abs(magnitude / g - 1.0) <= GRAVITY_MATCH:
                which = ", ".join(names[c] for c in group)
                out.append(
                    Finding(
                        "accelerometer_as_gyro",
                        names[group[0]],
                        f"channel{'s' if len(group) > 1 else ''} {which}: the magnitude of the "
                        f"mean, {magnitude:.4g} {unit}, is gravity's in {accel} and far beyond "
                        f"a still gyro's bias: accelerometer data given as {unit}? give the "
                        f"accelerometer's unit (--units {accel}) or pick the gyro's columns "
                        "(--channels)",
                    )
                )
                break
    return out


def warn_coefficients(
    values: Mapping[str, float | None],
    unit: str | None,
    *,
    input: str = "rate",
    channel: str = "ch0",
    stacklevel: int = 2,
) -> list[Finding]:
    """Run :func:`check_coefficients` for a library call and ``warnings.warn`` each finding.

    The library's side of the wrong-units check (the CLI prints the same findings on stderr):
    each finding becomes an :class:`~allanite.errors.ImplausibleInputWarning` whose fix is
    spelled as a keyword (``units='deg/h'``).

    Parameters
    ----------
    values, unit, input, channel
        As for :func:`check_coefficients`.
    stacklevel : int
        Passed to :func:`warnings.warn` (count from this function's caller).

    Returns
    -------
    list of Finding
        The findings warned about.
    """
    findings = check_coefficients(values, unit, input=input, channel=channel, spelling="python")
    for finding in findings:
        warnings.warn(finding.message, ImplausibleInputWarning, stacklevel=stacklevel + 1)
    return findings


def _bounds_text(bound: tuple[float | None, float | None, float, str]) -> str:
    lo, hi, _, _ = bound
    if lo is not None and hi is not None:
        return f"{lo:g} to {hi:g}"
    return f"<= {hi:g}" if hi is not None else f">= {lo:g}"
