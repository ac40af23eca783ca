"""Holdout as validation on the record's whole length (``holdout=`` a fraction).

The gap is tested and the effects attributed on the *whole* record (the diagnosis's headline);
the holdout then validates: the effects are attributed again on the fit part alone (the
record's start) and carried, with their fitted parameters, to the held-out part (its end),
judged there with the tau view's test at the same level. Three outcomes are reported apart:

* the held-out part cannot check an effect whose signature lies beyond its taus: adding the
  effect to the sensor would not make a record of the held-out length differ significantly
  (:func:`detectable`); it is then "not checkable on the held-out part", never "shrinkage
  100 %";
* the fit part names other effects than the whole record: the two are flagged as disagreeing,
  and :func:`deciding_length` gives the record length on which the two sets would differ
  significantly;
* the fit part shows no gap of its own: nothing can be attributed on it (the gap lies in the
  held-out part, which the whole-record test covers).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from allanite.diagnosis.joint import Explanation, combined_terms
from allanite.diagnosis.tau_view import TauModel, octave_factors, tau_covariance
from allanite.terms import term_from_dict

__all__ = ["deciding_length", "detectable", "disagreement", "duration_text", "validation_note"]

#: record lengths tried by :func:`deciding_length`, as multiples of the whole record
LENGTH_FACTORS = (1, 2, 4, 8, 16, 32, 64)


def detectable(tm: TauModel, extra: NDArray[np.float64], alpha: float) -> bool:
    """Whether adding Allan variance ``extra`` would give a significant tau gap on ``tm``'s record.

    The effect moves the expected log AVAR by ``d = log(1 + extra / S)``; the statistic then
    averages ``T0 + d^T C^{-1} d``. The effect is detectable on that record when this mean
    lies beyond the null's ``1 - alpha`` quantile of ``T``.
    """
    d = (tm.reference(extra) - tm.reference()) / np.sqrt(tm.real_scale)
    shift = float(d @ tm.cov_inv @ d)
    return bool(tm.t0 + shift > float(np.quantile(tm.null_t, 1.0 - alpha)))


def _model_with(explanation: Explanation, model: Any) -> Any:
    """The simulated sensor (a model) with the explanation's effects added."""
    terms = combined_terms(explanation, model)
    return replace(model, terms=tuple(term_from_dict(t) for t in terms))


def deciding_length(
    first: Explanation, second: Explanation, model: Any, fs: float, n: int, alpha: float
) -> float | None:
    """Shortest record (s, a power-of-two multiple of ``n`` samples) that tells two sets apart.

    The sensor with ``first``'s effects is taken as the truth: its exact Gaussian AVAR
    covariance on octave taus gives the log-scale covariance ``L`` for a record of each length
    tried; the sets differ by ``d = log(S_second / S_first)`` and are told apart when
    ``d^T L^{-1} d`` exceeds the ``chi2_k`` quantile ``1 - alpha`` less ``k`` (the mean shift
    of ``T`` that makes it significant on average). None when no length up to 64 times the
    record does (or the sets have the same Allan variance).
    """
    if model is None:
        return None
    a, b = _model_with(first, model), _model_with(second, model)
    dt = 1.0 / fs
    for factor in LENGTH_FACTORS:
        length = n * factor
        m = octave_factors(length)
        tau = m * dt
        mu_a = np.asarray(a.avar(tau, dt), dtype=np.float64)
        mu_b = np.asarray(b.avar(tau, dt), dtype=np.float64)
        if np.any(mu_a <= 0) or np.any(mu_b <= 0):
            return None
        cov = tau_covariance(a, m, dt, length)
        cov[np.diag_indices_from(cov)] += np.asarray(a.avar_excess_variance(tau, dt, length))
        log_cov = cov / np.outer(mu_a, mu_a)
        d = np.log(mu_b / mu_a)
        shift = float(d @ np.linalg.solve(log_cov + 1e-12 * np.eye(d.size), d))
        if shift > float(stats.chi2.isf(alpha, d.size)) - d.size:
            return length * dt
    return None


def disagreement(whole: Explanation | None, fit: Explanation | None) -> bool:
    """Whether the fit part names other effects than the whole record."""
    names = [sorted(a.effect for a in e.effects) if e is not None else [] for e in (whole, fit)]
    return names[0] != names[1]


def duration_text(seconds: float) -> str:
    """A duration in h, min or s, whichever reads best."""
    if seconds >= 7200.0:
        return f"{seconds / 3600.0:.3g} h"
    if seconds >= 120.0:
        return f"{seconds / 60.0:.3g} min"
    return f"{seconds:.3g} s"


def _names(e: Explanation | None) -> str:
    return " + ".join(a.effect for a in e.effects) if e is not None else "no effect"


def validation_note(check: dict[str, Any], whole: Explanation | None) -> str:
    """One sentence on the held-out validation (``check``: :func:`engine` fraction check)."""
    fit_s, hold_s = duration_text(check["fit_duration_s"]), duration_text(check["held_duration_s"])
    head = (
        f"held-out validation (attributed on the first {fit_s}, checked on the last {hold_s}; "
        f"gap p = {check['fit_p_value']:.2g} on the fit part, {check['held_p_value']:.2g} on "
        "the held-out part)"
    )
    if not check["fit_significant"]:
        return head + ": the fit part shows no gap of its own, nothing to attribute there"
    parts = []
    if check["not_checkable"]:
        parts.append(
            ", ".join(check["not_checkable"]) + " not checkable on the held-out part (its "
            "signature lies beyond the held-out part's taus)"
        )
    elif check["held_gap_before"] <= 0:
        parts.append("the held-out part shows no tau gap to shrink")
    else:
        parts.append(
            f"{' + '.join(check['effects'])} on the held-out part: shrinkage "
            f"{100.0 * check['shrinkage']:.0f} %, "
            + ("consistent with chance" if check["consistent_after"] else "a gap remains")
        )
    if check["disagrees"]:
        text = (
            f"DISAGREES: the fit part alone names {' + '.join(check['effects']) or 'no effect'}, "
            f"the whole record {_names(whole)}"
        )
        length = check.get("deciding_length_s")
        text += (
            f"; a record of about {duration_text(length)} would tell them apart"
            if length is not None
            else "; no record up to 64 times this one tells them apart in the tau view"
        )
        parts.append(text)
    return head + ": " + "; ".join(parts)
