"""The classic graphical readouts of IEEE Std 952-1997 / 1431-2004 (the "slope method").

Each power-law term shows as a straight line of known slope on the log-log Allan deviation
plot; its coefficient is read where the line crosses a conventional tau:

* quantization Q: slope -1 line at tau = sqrt(3) s,
* angle random walk N: slope -1/2 line at tau = 1 s,
* bias instability B: the flat minimum divided by sqrt(2 ln 2 / pi) = 0.664,
* rate random walk K: slope +1/2 line at tau = 3 s,
* rate ramp R: slope +1 line at tau = sqrt(2) s.

Points before a short-tau hump (a sensor output filter's roll-off,
:func:`allanite.slopes.rolloff_end`) are not read: no power-law line runs there.

These readouts carry no uncertainty and assume the term dominates somewhere on the curve; they
are given for comparison with datasheets, not as estimates (use :func:`allanite.fit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from allanite.slopes import rolloff_end
from allanite.terms.flicker import PLATEAU

__all__ = ["ClassicReadout", "classic_readout"]

LABEL = "IEEE Std 952/1431 slope method (graphical readout, no uncertainty)"

#: (symbol, slope of the ADEV line, tau where it is read, value of the line there -> coefficient)
_LINES = (
    ("Q", -1.0, math.sqrt(3.0)),
    ("N", -0.5, 1.0),
    ("K", 0.5, 3.0),
    ("R", 1.0, math.sqrt(2.0)),
)


@dataclass(frozen=True)
class ClassicReadout:
    """Slope-method coefficients (None where the curve has no segment of that slope).

    Attributes
    ----------
    values : dict
        Coefficient by symbol (Q, N, B, K, R) in the curve's rate units and seconds.
    tau : dict
        The tau at which each line touches the curve.
    slope : dict
        The local log-log slope of the deviation found there.
    label : str
        Names the method: a graphical readout, not a statistical estimate.
    """

    values: dict[str, float | None]
    tau: dict[str, float | None]
    slope: dict[str, float | None]
    label: str = LABEL


def classic_readout(
    tau: NDArray[np.float64], adev: NDArray[np.float64], *, tolerance: float = 0.2
) -> ClassicReadout:
    """Read Q, N, B, K, R off an Allan deviation curve by the IEEE slope method.

    Parameters
    ----------
    tau, adev : numpy.ndarray
        The curve (seconds, rate units); non-finite points are ignored.
    tolerance : float
        A line is read only where the local slope is within this of the line's slope.

    Returns
    -------
    ClassicReadout
    """
    t = np.asarray(tau, dtype=np.float64)
    a = np.asarray(adev, dtype=np.float64)
    ok = np.isfinite(t) & np.isfinite(a) & (a > 0) & (t > 0)
    t, a = t[ok], a[ok]
    # a sensor filter's roll-off at the short taus names no term (allanite.slopes)
    end = rolloff_end(t, a)
    if end is not None:
        t, a = t[t >= end], a[t >= end]
    values: dict[str, float | None] = {}
    where: dict[str, float | None] = {}
    slopes: dict[str, float | None] = {}
    if t.size < 3:
        for sym in ("Q", "N", "B", "K", "R"):
            values[sym] = where[sym] = slopes[sym] = None
        return ClassicReadout(values, where, slopes)
    lt, la = np.log(t), np.log(a)
    local = np.gradient(la, lt)
    for sym, slope, tau_read in _LINES:
        i = int(np.argmin(np.abs(local - slope)))
        if abs(local[i] - slope) > tolerance:
            values[sym] = where[sym] = slopes[sym] = None
            continue
        line_at = a[i] * (tau_read / t[i]) ** slope
        values[sym] = float(line_at)
        where[sym], slopes[sym] = float(t[i]), float(local[i])
    i = int(np.argmin(a))
    flat = abs(local[i]) <= tolerance and 0 < i < a.size - 1
    values["B"] = float(a[i] / math.sqrt(PLATEAU)) if flat else None
    where["B"] = float(t[i]) if flat else None
    slopes["B"] = float(local[i]) if flat else None
    return ClassicReadout(values, where, slopes)
