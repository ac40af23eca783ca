r"""The slope table: which noise term the measured Allan deviation shows over which tau range.

The local log-log slope :math:`\mu = d\ln\sigma/d\ln\tau` of a deviation curve names the
dominant noise term (IEEE Std 952-1997, Annex C): -1 quantization (or white angle noise),
-1/2 angle random walk, 0 bias instability, +1/2 rate random walk, +1 rate ramp. Here the
slope is the least-squares slope over a sliding half-decade window (so that the scatter of the
long-tau points does not flip the classification point by point), each point is assigned the
nearest canonical slope, runs of equal slopes become rows of the table, and each row is named
after the canonical slope nearest to its own least-squares slope.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "ACCEL_SLOPE_TERMS",
    "FILTER_ROLLOFF",
    "MIN_EDF",
    "MIN_POINTS",
    "SLOPE_TERMS",
    "SlopeRow",
    "local_slopes",
    "rolloff_end",
    "slope_table",
]

#: canonical Allan-deviation slopes with their labels and IEEE symbols
_CANONICAL: tuple[tuple[float, str, str], ...] = (
    (-1.0, "−1", "Q"),
    (-0.5, "−1/2", "N"),
    (0.0, "0", "B"),
    (0.5, "+1/2", "K"),
    (1.0, "+1", "R"),
)


def _slope_terms(names: tuple[str, ...]) -> dict[float, tuple[str, str, str]]:
    """Canonical slope -> (label, term that produces it, IEEE symbol), one name per slope."""
    return {
        slope: (label, name, symbol)
        for (slope, label, symbol), name in zip(_CANONICAL, names, strict=True)
    }


#: canonical Allan-deviation slope -> (label, term that produces it, IEEE symbol)
SLOPE_TERMS = _slope_terms(
    (
        "quantization / white angle noise",
        "angle random walk (white rate noise)",
        "bias instability (flicker rate noise)",
        "rate random walk",
        "rate ramp",
    )
)
#: the same for an accelerometer (IEEE Std 1293-2018 names)
ACCEL_SLOPE_TERMS = _slope_terms(
    (
        "velocity quantization / white velocity noise",
        "velocity random walk (white acceleration noise)",
        "bias instability (flicker acceleration noise)",
        "acceleration random walk",
        "acceleration ramp",
    )
)
_WINDOW_DECADES = 0.5
#: what the rows before :func:`rolloff_end` show (they name no noise term)
FILTER_ROLLOFF = "sensor output filter's roll-off (not a noise term)"
#: a short-tau hump: the curve starts at least this flat before it falls to -1/2
_HUMP_SLOPE = -0.1
#: points with fewer equivalent degrees of freedom are not classified (about 16 % scatter)
MIN_EDF = 20.0
#: shortest run of points reported as a row
MIN_POINTS = 3


@dataclass(frozen=True)
class SlopeRow:
    """A tau range over which the measured slope is near one canonical value."""

    tau_min: float
    tau_max: float
    slope: float
    canonical: float
    label: str
    term: str
    symbol: str
    n_points: int


def local_slopes(tau: NDArray[np.float64], dev: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least-squares log-log slope in a half-decade window around each point."""
    lt, ld = np.log10(tau), np.log10(dev)
    out = np.empty(tau.size)
    for k in range(tau.size):
        sel = np.abs(lt - lt[k]) <= _WINDOW_DECADES / 2
        if sel.sum() < 3:  # widen to the three nearest points
            sel = np.zeros(tau.size, dtype=bool)
            sel[np.argsort(np.abs(lt - lt[k]))[:3]] = True
        x, y = lt[sel], ld[sel]
        out[k] = np.polyfit(x, y, 1)[0]
    return out


def rolloff_end(tau: NDArray[np.float64], dev: NDArray[np.float64]) -> float | None:
    """Where a hump at the shortest taus ends (a sensor output filter's roll-off), else None.

    The log-log slope of a sum of power-law terms never decreases along tau (the curve is
    convex). A curve that starts flat or rising and then falls to the -1/2 of white noise
    is not such a sum: at its shortest taus it shows the roll-off of the sensor's own output
    filter (or a correlated noise with a time constant near the sample interval), and its
    slopes there name no noise term. Returns the first tau whose local slope (half-decade
    window) is nearer -1/2 than 0, when a slope of ``_HUMP_SLOPE`` or more precedes it.
    """
    tau = np.asarray(tau, dtype=np.float64)
    dev = np.asarray(dev, dtype=np.float64)
    good = np.isfinite(dev) & (dev > 0) & np.isfinite(tau) & (tau > 0)
    tau, dev = tau[good], dev[good]
    if tau.size < 3:
        return None
    return _rolloff_at(tau, local_slopes(tau, dev))


def _rolloff_at(tau: NDArray[np.float64], slopes: NDArray[np.float64]) -> float | None:
    """:func:`rolloff_end` from the curve's local slopes (computed once by the slope table)."""
    falling = np.flatnonzero(slopes < -0.25)
    if falling.size == 0 or falling[0] == 0 or slopes[: falling[0]].max() < _HUMP_SLOPE:
        return None
    return float(tau[falling[0]])


def _rolloff_rows(rows: list[SlopeRow], end: float | None) -> list[SlopeRow]:
    """The rows before ``end`` named as the filter's roll-off (no term, no symbol)."""
    if end is None:
        return rows
    return [
        dataclasses.replace(row, term=FILTER_ROLLOFF, symbol="") if row.tau_max < end else row
        for row in rows
    ]


def slope_table(
    tau: NDArray[np.float64],
    dev: NDArray[np.float64],
    edf: NDArray[np.float64] | None = None,
    *,
    min_edf: float = MIN_EDF,
    sensor: str = "gyro",
) -> list[SlopeRow]:
    """Group the measured curve into tau ranges of one canonical slope.

    Parameters
    ----------
    tau, dev : numpy.ndarray
        Averaging times and Allan deviation of one channel (at least 3 points).
    edf : numpy.ndarray, optional
        Equivalent degrees of freedom of each point; points with fewer than ``min_edf`` are
        left out (their relative standard error exceeds ``1/sqrt(2 min_edf)``, so their scatter
        would invent slopes).
    min_edf : float
        Smallest EDF of a point that is classified.
    sensor : {"gyro", "accelerometer"}
        Names the terms as for that sensor (angle random walk or velocity random walk, ...).

    Returns
    -------
    list of SlopeRow
        In increasing tau; runs of a single point are merged into their neighbours and runs of
        fewer than ``MIN_POINTS`` points are left out (two points do not make a slope). Rows
        before a short-tau hump's end (:func:`rolloff_end`) name the filter's roll-off
        (:data:`FILTER_ROLLOFF`, empty symbol), not a noise term.
    """
    tau = np.asarray(tau, dtype=np.float64)
    dev = np.asarray(dev, dtype=np.float64)
    good = np.isfinite(dev) & (dev > 0)
    if edf is not None:
        good &= np.asarray(edf, dtype=np.float64) >= min_edf
    tau, dev = tau[good], dev[good]
    if tau.size < 3:
        return []
    slopes = local_slopes(tau, dev)
    canon = np.array(sorted(SLOPE_TERMS))
    nearest = canon[np.argmin(np.abs(slopes[:, None] - canon[None, :]), axis=1)]
    # merge isolated single points into the previous run
    for k in range(1, nearest.size - 1):
        if nearest[k] != nearest[k - 1] and nearest[k] != nearest[k + 1]:
            nearest[k] = nearest[k - 1]
    rows: list[SlopeRow] = []
    start = 0
    for k in range(1, nearest.size + 1):
        if k == nearest.size or nearest[k] != nearest[start]:
            sel = slice(start, k)
            if k - start >= 2:
                fit = float(np.polyfit(np.log10(tau[sel]), np.log10(dev[sel]), 1)[0])
            else:
                fit = float(slopes[start])
            # the row is named after its own least-squares slope, so label and value agree
            c = float(canon[np.argmin(np.abs(canon - fit))])
            names = ACCEL_SLOPE_TERMS if sensor == "accelerometer" else SLOPE_TERMS
            label, term, symbol = names[c]
            rows.append(
                SlopeRow(
                    tau_min=float(tau[start]),
                    tau_max=float(tau[k - 1]),
                    slope=fit,
                    canonical=c,
                    label=label,
                    term=term,
                    symbol=symbol,
                    n_points=k - start,
                )
            )
            start = k
    merged = [r for r in _merge_equal(rows, tau, dev, canon, sensor) if r.n_points >= MIN_POINTS]
    return _rolloff_rows(merged, _rolloff_at(tau, slopes))


def _merge_equal(
    rows: list[SlopeRow],
    tau: NDArray[np.float64],
    dev: NDArray[np.float64],
    canon: NDArray[np.float64],
    sensor: str,
) -> list[SlopeRow]:
    """Merge neighbouring rows that their own slopes put in the same class.

    Runs are cut where the local slope changes class, but a row is named after its own
    least-squares slope, so two neighbours can both read as, say, a flat 0 (``15.9 – 39 s``
    and ``43.6 – 61 s``): one row, refitted over both, when the merged slope keeps the class.
    """
    names = ACCEL_SLOPE_TERMS if sensor == "accelerometer" else SLOPE_TERMS
    out: list[SlopeRow] = []
    for row in rows:
        prev = out[-1] if out else None
        if prev is None or prev.canonical != row.canonical:
            out.append(row)
            continue
        sel = (tau >= prev.tau_min) & (tau <= row.tau_max)
        fit = float(np.polyfit(np.log10(tau[sel]), np.log10(dev[sel]), 1)[0])
        if float(canon[np.argmin(np.abs(canon - fit))]) != row.canonical:
            out.append(row)
            continue
        label, term, symbol = names[row.canonical]
        out[-1] = SlopeRow(
            tau_min=prev.tau_min,
            tau_max=row.tau_max,
            slope=fit,
            canonical=row.canonical,
            label=label,
            term=term,
            symbol=symbol,
            n_points=int(sel.sum()),
        )
    return out
