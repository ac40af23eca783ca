r"""The sensor's own output filter in the automatic search (``terms="auto"``).

Real sensors low-pass their output (a digital one-pole or Butterworth, a decimating moving
average), which lowers the Allan variance at the taus near and below :math:`1/f_c` under
the unfiltered white noise's :math:`N^2/\tau`. No power-law subset fits that roll-off (on
a 10 Hz phone record the search returned B alone, rejected). So, after the power-law search
(:func:`allanite.fit.select.select_terms`), when the curve asks for it, the search is run
again once per filter kind with the filter term (:class:`allanite.terms.LowPassWhite`,
which carries the unfiltered sensor's ``N`` and the filter's ``bandwidth``) in place of
white noise, over the subsets with flicker, random walk and ramp (without quantization,
whose :math:`1/\tau^2` the filter's own :math:`-3R_1/(2m^2)` part would cancel). The best
is kept by the search's own lexicographic rule: a fit the goodness-of-fit test accepts
beats a rejected one, then the lower penalized score (the filter costs its bandwidth as one
more parameter). A filter fit is only taken when the test accepts it (a filter kind that
does not fit is not refitted with a model discrepancy, which would cost minutes).

The curve asks for a filter (:func:`filter_demanded`) when the power-law fit is rejected,
its shortest tau lies more than :data:`DEMAND_Z` standard errors below it, and the measured
curve itself starts flatter than white noise and then steepens: the log-log slope of a sum
of power laws never decreases along tau (the curve is convex), a filter's roll-off makes it
do so from the first taus on. A record rejected for other reasons (a Gauss-Markov or
sinusoidal hump, drift, steps) starts as white noise and does not ask. The kinds are then
tried cheapest law first (:data:`allanite.fit.spec.FILTER_CANDIDATES`; plain ``auto``
tries the one-pole and the moving average, as a Butterworth search costs 20-30 s on a
1e6-sample record) and the search stops at the first one the test accepts. When every fit
is rejected, the filter fit of least chi-square replaces the power-law one if it lowers the
chi-square :data:`FILTER_GAIN` times or more (the roll-off was most of the misfit), refitted
with the model discrepancy that carries the rest into its intervals (on the ADIS16405's
100-point grid: chi-square 42 for 13 dof against 24220 for 14).
``terms="auto+filter"`` tries every kind on every curve and keeps the best.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from allanite.fit.gls import GLSData, GLSSolution
from allanite.fit.select import Ambiguity, n_params, score, select_terms
from allanite.fit.spec import TermSpec
from allanite.terms import Quantization, White

__all__ = ["DEMAND_Z", "FILTER_GAIN", "filter_demanded", "select_with_filters"]

#: standardized residual of the shortest tau under which the search tries the filters
DEMAND_Z = -3.0
#: a rejected filter fit replaces a rejected power-law fit when its chi-square is this
#: many times lower (the roll-off was most of the misfit); it then carries a discrepancy
FILTER_GAIN = 10.0
#: least change of the Allan variance's log-log slope read as a filter's roll-off
_SLOPE_MARGIN = 0.05
#: slopes are read on the points with at least this many degrees of freedom
_SLOPE_EDF = 100.0

_Selection = tuple[GLSSolution, Ambiguity | None, tuple[dict[str, Any], ...], list[dict[str, Any]]]


def _rank(sol: GLSSolution, n_points: int, penalty: float, level: float) -> tuple[bool, float]:
    dof = n_points - n_params(sol.specs)
    p = float(stats.chi2.sf(sol.chi2, dof)) if dof > 0 else float("nan")
    return bool(p < level), score(sol, penalty)


def _starts_flat_then_falls(data: GLSData, edf: NDArray[np.float64]) -> bool:
    """Whether the Allan variance starts flatter than white noise and then falls.

    Its first log-log slope exceeds white noise's -1, and a later one (on the points with
    at least :data:`_SLOPE_EDF` degrees of freedom) falls below it, each by more than
    :data:`_SLOPE_MARGIN` or four standard errors.
    """
    ok = edf >= _SLOPE_EDF
    if ok.sum() < 3:
        return False
    logs = np.log(data.y[ok]), np.log(data.m[ok])
    slopes = np.diff(logs[0]) / np.diff(logs[1])
    rel = 2.0 / edf[ok]
    se = np.sqrt(rel[:-1] + rel[1:]) / np.diff(logs[1])
    margin = np.maximum(_SLOPE_MARGIN, 4.0 * se)
    return bool(slopes[0] > -1.0 + margin[0] and np.any(slopes[1:] < slopes[0] - margin[1:]))


def filter_demanded(
    sol: GLSSolution, data: GLSData, edf: NDArray[np.float64], misfit_level: float
) -> bool:
    """Whether the power-law fit ``sol`` misses the curve as a sensor filter would.

    It is rejected at ``misfit_level``, its shortest tau lies more than :data:`DEMAND_Z`
    standard errors (under its own covariance) below the curve, and the curve starts
    flatter than white noise and then falls (see the module docstring).
    """
    rejected, _ = _rank(sol, data.y.size, 0.0, misfit_level)
    z = (data.y[0] - sol.fitted[0]) / np.sqrt(sol.model_cov[0, 0])
    return bool(rejected and z < DEMAND_Z and _starts_flat_then_falls(data, edf))


def select_with_filters(
    specs: Sequence[TermSpec],
    filters: Sequence[TermSpec],
    force: bool,
    data: GLSData,
    edf: NDArray[np.float64],
    penalty: float,
    misfit_level: float,
    starts: Sequence[NDArray[np.float64] | None],
) -> _Selection:
    """The automatic selection, with the sensor filters tried as the module describes.

    Returns what :func:`~allanite.fit.select.select_terms` returns; the subsets list gains
    the filter searches' subsets (each with its ``filter`` kind).
    """
    best = select_terms(specs, data, edf, penalty, misfit_level, starts)
    if not filters or not (force or filter_demanded(best[0], data, edf, misfit_level)):
        return best
    rank = _rank(best[0], data.y.size, penalty, misfit_level)
    others = [s for s in specs if s.cls not in (White, Quantization)]
    subsets = list(best[3])
    closest: tuple[float, TermSpec] | None = None  # the rejected filter fit of least chi2
    for spec in filters:
        if n_params([spec]) >= data.y.size:
            continue
        try:
            found = select_terms(
                [spec, *others], data, edf, penalty, misfit_level, starts, spec, discrepancy=False
            )
        except ValueError:  # the search ran to a bandwidth the exact law cannot hold
            continue
        kind = getattr(spec.template, "filter", "rc")
        subsets.extend({**s, "filter": kind} for s in found[3])
        candidate = _rank(found[0], data.y.size, penalty, misfit_level)
        if candidate[0] and (closest is None or found[0].chi2 < closest[0]):
            closest = (found[0].chi2, spec)
        if not candidate[0] and candidate < rank:
            best, rank = found, candidate
            if not force:
                break
    if rank[0] and closest is not None and closest[0] * FILTER_GAIN < best[0].chi2:
        # every fit rejected, the filter's roll-off most of the misfit: the filter fit,
        # with the model discrepancy that carries the rest into its intervals
        best = select_terms(
            [closest[1], *others], data, edf, penalty, misfit_level, starts, closest[1]
        )
    return best[0], best[1], best[2], sorted(subsets, key=lambda s: s["score"])
