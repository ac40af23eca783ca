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

The curve asks for a filter when the power-law fit is rejected, or when its shortest tau
lies more than :data:`DEMAND_Z` standard errors below it (the filter's roll-off starts at
the shortest taus). ``terms="auto+filter"`` tries the filters on every curve.
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

__all__ = ["DEMAND_Z", "filter_demanded", "select_with_filters"]

#: standardized residual of the shortest tau under which the search tries the filters
DEMAND_Z = -3.0

_Selection = tuple[GLSSolution, Ambiguity | None, tuple[dict[str, Any], ...], list[dict[str, Any]]]


def _rank(sol: GLSSolution, n_points: int, penalty: float, level: float) -> tuple[bool, float]:
    dof = n_points - n_params(sol.specs)
    p = float(stats.chi2.sf(sol.chi2, dof)) if dof > 0 else float("nan")
    return bool(p < level), score(sol, penalty)


def filter_demanded(sol: GLSSolution, data: GLSData, misfit_level: float) -> bool:
    """Whether the power-law fit ``sol`` misses the curve as a sensor filter would."""
    rejected, _ = _rank(sol, data.y.size, 0.0, misfit_level)
    if rejected:
        return True
    z = (data.y[0] - sol.fitted[0]) / np.sqrt(sol.model_cov[0, 0])
    return bool(z < DEMAND_Z)


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
    if not filters or not (force or filter_demanded(best[0], data, misfit_level)):
        return best
    rank = _rank(best[0], data.y.size, penalty, misfit_level)
    others = [s for s in specs if s.cls not in (White, Quantization)]
    subsets = list(best[3])
    for spec in filters:
        if n_params([spec]) >= data.y.size:
            continue
        found = select_terms(
            [spec, *others], data, edf, penalty, misfit_level, starts, spec, discrepancy=False
        )
        kind = getattr(spec.template, "filter", "rc")
        subsets.extend({**s, "filter": kind} for s in found[3])
        candidate = _rank(found[0], data.y.size, penalty, misfit_level)
        if not candidate[0] and candidate < rank:
            best, rank = found, candidate
    return best[0], best[1], best[2], sorted(subsets, key=lambda s: s["score"])
