r"""Automatic term selection (``terms="auto"``): an exhaustive search over the candidate subsets.

The candidates are the five power-law terms Q, N, B, K, R, so there are only 31 non-empty
subsets (30 with a noise term: a ramp alone would predict estimates without spread), and
every one is fitted (a stepwise search can stop in a poor local optimum: on a
30-minute example record it kept white noise alone, p = 0, while quantization + white + rate
random walk fits with p = 0.6). Each subset is scored by the penalized Gaussian
-2 log-likelihood of the Allan variance estimates,

.. math:: S = \chi^2 + \log\det C + \text{penalty}\cdot p,

with :math:`C` the covariance of the estimates under that subset's own fitted model, ``p`` its
number of parameters. The choice is lexicographic:

1. among the subsets the goodness-of-fit test does not reject (generalized chi-square
   p-value at least ``misfit_level``), the one with the lowest score;
2. only when every subset is rejected, all subsets are refitted with the relative model
   discrepancy of :func:`allanite.fit.gls.solve` (one more parameter) and the lowest score
   wins; the fit then reports itself as rejected.

So the result is never rejected when a subset that is not rejected exists, and it never has
a worse score than any subset evaluated, simpler ones included, with two exceptions, both
likelihood-ratio tests under one fixed covariance:

3. a chosen ramp must be significant against the rate random walk, its stationary
   look-alike at the end of the tau range (:func:`_ramp_against_rrw`): the ramp has no
   variance of its own, so the ``log det C`` of the score favours it wherever the two
   cannot be told apart, typically when either dominates only the last, low-EDF taus.
   If adding the ramp to the alternative (ramp replaced by K) lowers the chi-square under
   the alternative's covariance by less than the penalty, the alternative is returned
   (when it is not rejected). Where the record cannot tell them apart, K is the safer
   reading: a random walk fitted to a ramp is a conservative model of it for a filter,
   a ramp fitted to a random walk sets K = 0.
4. symmetrically, a term left out is added when it is significant against the chosen
   model (:func:`_add_significant`): adding it lowers the chi-square under the chosen
   model's covariance by at least the penalty (a noise term raises ``log det C`` where it
   dominates, so the score alone asks more than the penalty of a term confined to the last
   taus). The superset must not be rejected; an added ramp must pass step 3.

Finally the choices the record does not make are recorded (:func:`_exchangeable`): a
non-rejected subset that swaps one chosen term for another candidate at a score within the
penalty, or a left-out term whose chi-square drop against the chosen model is positive but
below the penalty. :func:`allanite.fit.fit` widens the swapped-out terms' intervals to the
hull with the union fit (chosen plus all alternative terms), reports the alternative terms
from that fit and the other left-out terms as not detected, with upper limits.

The reweighted fit of one subset is not convex (the covariance depends on the estimate), so
each subset is fitted from several starting covariances and the best score is kept: the
diagonal one from the estimates' EDF, the covariance of the model read off the curve by the
IEEE slope method (:mod:`allanite.fit.classic`), and, when a subset fits worse than one of
its subsets with one term fewer (a superset can always reproduce its subsets' curves), the
covariance of that better subset's fit.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from allanite.fit.gls import GLSData, GLSSolution, _covariance, solve
from allanite.fit.spec import TermSpec

__all__ = ["Ambiguity", "Candidate", "n_params", "score", "select_terms"]


def n_params(specs: Sequence[TermSpec]) -> int:
    """Number of fitted parameters of ``specs`` (amplitudes and nonlinear parameters)."""
    return sum(1 + (s.nonlinear_name is not None) for s in specs)


def score(sol: GLSSolution, penalty: float) -> float:
    """Return ``chi2 + log det C + penalty * parameters`` of a solution.

    The -2 log-likelihood of the Gaussian approximation under the covariance ``C`` the fit
    used, plus the penalty, so that models with different covariances stay comparable. A
    model that needed a model discrepancy (see :func:`allanite.fit.gls.solve`) pays for it
    as one more parameter.
    """
    _, logdet = np.linalg.slogdet(sol.cov)
    count = n_params(sol.specs) + (sol.discrepancy > 0)
    return float(sol.chi2_fit + logdet + penalty * count)


@dataclass(frozen=True)
class Candidate:
    """One evaluated subset: its solution, score, generalized chi-square and p-value."""

    solution: GLSSolution
    score: float
    chi2: float
    p_value: float

    @property
    def names(self) -> frozenset[str]:
        """Term types of the subset."""
        return frozenset(s.cls.type for s in self.solution.specs)


def _p_value(sol: GLSSolution, n_points: int) -> float:
    dof = n_points - n_params(sol.specs)
    return float(stats.chi2.sf(sol.chi2, dof)) if dof > 0 else math.nan


def _evaluate(
    subset: tuple[TermSpec, ...],
    data: GLSData,
    edf: NDArray[np.float64],
    penalty: float,
    misfit_level: float,
    starts: Sequence[NDArray[np.float64] | None],
) -> Candidate:
    best: Candidate | None = None
    for start in starts:
        sol = solve(subset, data, edf, start=start, misfit_level=misfit_level)
        cand = Candidate(sol, score(sol, penalty), sol.chi2, _p_value(sol, data.y.size))
        if best is None or cand.score < best.score:
            best = cand
    assert best is not None
    return best


def _search(
    specs: Sequence[TermSpec],
    data: GLSData,
    edf: NDArray[np.float64],
    penalty: float,
    misfit_level: float,
    starts: Sequence[NDArray[np.float64] | None],
    required: TermSpec | None = None,
) -> dict[tuple[TermSpec, ...], Candidate]:
    """Fit every subset of ``specs`` (smallest first), with the starts described above.

    With ``required``, only the subsets that contain it.
    """
    found: dict[tuple[TermSpec, ...], Candidate] = {}
    for size in range(1, len(specs) + 1):
        for subset in itertools.combinations(specs, size):
            if n_params(subset) >= data.y.size:
                continue
            if required is not None and required not in subset:
                continue
            if not any(s.cls.stationary for s in subset):
                continue  # a ramp alone has no noise: its estimates would have no spread
            cand = _evaluate(subset, data, edf, penalty, misfit_level, starts)
            smaller = [
                found[sub]
                for sub in itertools.combinations(subset, size - 1)
                if sub in found and found[sub].solution.chi2_fit < cand.solution.chi2_fit
            ]
            if smaller:  # a superset fits worse than its subset: restart from the subset's fit
                better = min(smaller, key=lambda c: c.solution.chi2_fit)
                again = _evaluate(subset, data, edf, penalty, misfit_level, [better.solution.cov])
                if again.score < cand.score:
                    cand = again
            found[subset] = cand
    return found


def _delta_chi2(
    base: Candidate,
    added: str,
    specs: Sequence[TermSpec],
    data: GLSData,
    edf: NDArray[np.float64],
) -> float:
    """Drop of the generalized chi-square when the term ``added`` joins ``base``'s terms.

    Both fits use one covariance, the one of ``base``'s own fitted model (the null
    hypothesis "without the term"), so the ``log det C`` terms cancel and the drop is a
    likelihood-ratio statistic for the one added parameter: about ``(theta/se)**2`` of the
    term's squared amplitude.
    """
    # the covariance of the fitted base model itself: the reweighting can stop with a
    # covariance of another iterate (on a ramp record, N + K ended at K = 0 with the wide
    # covariance of the slope-method start, and the ramp looked insignificant)
    cov0 = base.solution.model_cov
    if base.solution.basis is not None:
        own = _covariance(base.solution.basis, base.solution.theta)
        cov0 = cov0 if own is None else own
    names = base.names | {added}
    union = tuple(s for s in specs if s.cls.type in names)
    without = solve(base.solution.specs, data, edf, cov=cov0, misfit_level=0.0)
    with_term = solve(union, data, edf, cov=cov0, misfit_level=0.0)
    return float(without.chi2_fit - with_term.chi2_fit)


RAMP, RRW = "ramp", "rrw"


@dataclass(frozen=True)
class _Context:
    """What every test after the search reads: the candidates, their fits and the curve.

    Attributes
    ----------
    specs : sequence of TermSpec
        The candidate terms.
    by_names : dict
        The evaluated subsets' candidates, by their term types.
    data : GLSData
        The curve.
    edf : numpy.ndarray
        EDF of the points.
    penalty : float
        Penalty per parameter (also the threshold of the likelihood-ratio tests).
    misfit_level : float
        Significance level of the goodness-of-fit test.
    """

    specs: Sequence[TermSpec]
    by_names: dict[frozenset[str], Candidate]
    data: GLSData
    edf: NDArray[np.float64]
    penalty: float
    misfit_level: float

    def delta_chi2(self, base: Candidate, added: str) -> float:
        """:func:`_delta_chi2` of ``added`` against ``base`` on this curve."""
        return _delta_chi2(base, added, self.specs, self.data, self.edf)

    def usable(self, candidate: Candidate | None) -> bool:
        """Whether ``candidate`` exists and its goodness-of-fit test does not reject it."""
        return candidate is not None and not candidate.p_value < self.misfit_level


def _ramp_against_rrw(
    chosen: Candidate,
    ctx: _Context,
) -> dict[str, Any] | None:
    r"""Test a chosen ramp against its stationary look-alike, the rate random walk.

    A ramp has no variance of its own, so a subset that explains the rise of the last taus
    by a ramp predicts them far more precise than one that explains it by a random walk,
    and the :math:`\log\det C` of the score rewards it for that even when its curve fits
    worse (on a 2000 s white + random-walk record at 200 Hz the ramp won with a larger
    chi-square, 3 records in 6). The score cannot tell the two apart where the data cannot.
    The ramp is therefore kept only if it is significant *against* the random walk: with
    the covariance :math:`C_0` of the alternative (the chosen terms with the ramp replaced
    by, or if present kept as, the random walk; the "no ramp" hypothesis), the generalized
    chi-square must drop by at least ``penalty`` when the ramp is added to the alternative,

    .. math:: \Delta = \chi^2_{C_0}(\text{alternative})
              - \chi^2_{C_0}(\text{alternative} + R) \ge \text{penalty},

    a likelihood-ratio test with one common covariance (the :math:`\log\det C` terms cancel),
    at the same price per parameter as the score. Otherwise the alternative is chosen, when
    it is not itself rejected.

    Returns
    -------
    dict or None
        None when the chosen subset has no ramp (or no random walk is a candidate); else
        ``alternative`` (term names), ``delta_chi2``, ``kept``.
    """
    names = chosen.names
    by_type = {s.cls.type: s for s in ctx.specs}
    if RAMP not in names or RRW not in by_type:
        return None
    alternative = (names - {RAMP}) | {RRW}
    alt = ctx.by_names.get(frozenset(alternative))
    if alt is None:
        return None
    delta = ctx.delta_chi2(alt, RAMP)
    return {
        "alternative": sorted(alternative),
        "delta_chi2": delta,
        "kept": bool(delta >= ctx.penalty or not ctx.usable(alt)),
    }


def _add_significant(
    chosen: Candidate,
    ctx: _Context,
) -> tuple[Candidate, dict[str, dict[str, float]]]:
    r"""Add the terms that are significant against the chosen model (the ramp test's mirror).

    A noise term raises the predicted variance of the taus it dominates, so its
    :math:`\log\det C` makes the score ask more of it than ``penalty`` (on the validation
    grid, a random walk confined to the last octaves lowered the chi-square by 9.2 and paid
    3.3 in :math:`\log\det C`). With the chosen model's own covariance :math:`C_0` (the "without
    the term" hypothesis) held fixed, the term is added when the generalized chi-square
    drops by at least ``penalty``, the same likelihood-ratio test at the same price as the
    ramp test (:func:`_delta_chi2`), i.e. when its squared amplitude is about
    ``sqrt(penalty)`` standard errors above zero. The most significant term is added first,
    and the search repeats; a superset the goodness-of-fit test rejects is not taken, and
    an added ramp must also pass :func:`_ramp_against_rrw`.

    Returns
    -------
    chosen : Candidate
        The chosen subset with the added terms.
    additions : dict
        Per added term, ``{"delta_chi2": ...}``.
    """
    additions: dict[str, dict[str, float]] = {}
    excluded: set[str] = set()
    while True:
        tests: dict[str, float] = {}
        for spec in ctx.specs:
            name = spec.cls.type
            if name in chosen.names or name in excluded:
                continue
            if not ctx.usable(ctx.by_names.get(chosen.names | {name})):
                continue
            tests[name] = ctx.delta_chi2(chosen, name)
        best = max(tests, key=lambda k: tests[k], default=None)
        if best is None or tests[best] < ctx.penalty:
            return chosen, additions
        new = ctx.by_names[chosen.names | {best}]
        if best == RAMP:
            test = _ramp_against_rrw(new, ctx)
            if test is not None and not test["kept"]:
                excluded.add(best)
                continue
        chosen = new
        additions[best] = {"delta_chi2": tests[best]}


@dataclass(frozen=True)
class Ambiguity:
    """Selections the record cannot tell from the chosen one (:func:`_exchangeable`).

    Attributes
    ----------
    alternatives : tuple of dict
        Per alternative subset: ``terms`` (its term types), ``swap_out`` (the chosen term
        it lacks; None for an addition), ``swap_in`` (the candidate it has instead or in
        addition), ``score_delta`` (its score minus the chosen one's), ``p_value``, and for
        an addition ``delta_chi2``.
    union : GLSSolution or None
        The fit of the chosen terms plus every alternative term: the model that contains
        every reading, whose intervals of the exchangeable terms reach what the data allow
        (None when it has too many parameters for the taus; then ``with_term`` serves).
    alternative_fits : dict
        The fitted solution of each alternative subset, by ``swap_in`` term type.
    with_term : dict
        The fit of the chosen terms plus one candidate left out, by its term type, for every
        such candidate whose fit is not rejected (an alternative term's interval when there
        is no union fit; otherwise the upper limit of a term not detected).
    exchangeable : frozenset of str
        The chosen term types swapped out by an alternative (their intervals are widened).
    """

    alternatives: tuple[dict[str, Any], ...]
    union: GLSSolution | None
    alternative_fits: dict[str, GLSSolution]
    with_term: dict[str, GLSSolution]
    exchangeable: frozenset[str]


#: chi-square drop (under the chosen model's covariance) above which a term left out is
#: reported as an alternative: any fitted amount of it (the designed ambiguous set's minor
#: terms, 20-45 % of the variance at the last taus, were left out with drops below 1)
ADD_EVIDENCE = 0.01


def _exchangeable(
    chosen: Candidate,
    ctx: _Context,
) -> Ambiguity | None:
    r"""Find the alternatives the record cannot tell from the chosen subset.

    Two kinds, both among the subsets the goodness-of-fit test does not reject:

    * a swap: the chosen terms with one exchanged for another candidate, at a score within
      the selection's own penalty (:math:`S_\text{alt} - S_\text{chosen} < \text{penalty}`;
      on a 3 h navigation record the excess of the last taus was rate random walk by 1.4 over
      flicker, the truth being flicker plus a tenth of the random walk);
    * an addition: a candidate left out whose chi-square drop against the chosen model
      (:func:`_delta_chi2`, the mirror test's statistic) is above :data:`ADD_EVIDENCE`
      but below the penalty: the data show some of it, not enough to select it; its
      interval is that of the fit with it (lower bound typically 0).

    The intervals of the chosen terms swapped out, conditional on the selection, claim what
    the record cannot show; the caller widens them to the hull with the union fit (the
    chosen plus every alternative term), where the alternative terms' intervals are read
    too. An addition the record shows some of widens the chosen intervals to the hull with
    the fit with it (:func:`allanite.fit.api._ambiguous`).

    Returns
    -------
    Ambiguity or None
        None when the chosen model is rejected; else the alternatives (possibly none) and,
        for every candidate left out, the fit with it (``with_term``: the upper limits of
        the terms not detected).
    """
    if not ctx.usable(chosen):
        return None  # a rejected model: the intervals already carry the model discrepancy
    names = chosen.names
    best: dict[str, dict[str, Any]] = {}
    fits: dict[str, GLSSolution] = {}
    for key, cand in ctx.by_names.items():
        out, into = names - key, key - names
        if len(into) != 1 or len(out) > 1 or not ctx.usable(cand):
            continue
        (i,) = tuple(into)
        if out:
            delta = cand.score - chosen.score
            if not delta < ctx.penalty:
                continue
            entry = {"swap_out": next(iter(out)), "score_delta": float(delta)}
        else:
            drop = ctx.delta_chi2(chosen, i)
            if not ADD_EVIDENCE < drop < ctx.penalty:
                continue
            entry = {"swap_out": None, "score_delta": float(cand.score - chosen.score)}
            entry["delta_chi2"] = float(drop)
        if i in best and best[i]["score_delta"] <= entry["score_delta"]:
            continue  # one alternative per candidate: the closest
        best[i] = {"terms": sorted(key), "swap_in": i, **entry, "p_value": cand.p_value}
        fits[i] = cand.solution
    alternatives = sorted(best.values(), key=lambda a: a["score_delta"])
    union = ctx.by_names.get(names | set(best))
    if union is None:  # too many parameters for the taus: each term's own superset instead
        alternatives = [a for a in alternatives if names | {a["swap_in"]} in ctx.by_names]
    involved = {a["swap_out"] for a in alternatives if a["swap_out"] is not None}
    # every candidate left out, with the fit that has it: the alternatives' fallback and
    # the upper limits of the terms not detected
    added = {
        i: sup.solution
        for i in {s.cls.type for s in ctx.specs} - names
        if (sup := ctx.by_names.get(names | {i})) is not None and ctx.usable(sup)
    }
    return Ambiguity(
        tuple(alternatives),
        None if union is None else union.solution,
        {a["swap_in"]: fits[a["swap_in"]] for a in alternatives},
        added,
        frozenset(involved),
    )


def select_terms(
    specs: Sequence[TermSpec],
    data: GLSData,
    edf: NDArray[np.float64],
    penalty: float,
    misfit_level: float,
    starts: Sequence[NDArray[np.float64] | None] = (None,),
    required: TermSpec | None = None,
    discrepancy: bool = True,
) -> tuple[GLSSolution, Ambiguity | None, tuple[dict[str, Any], ...], list[dict[str, Any]]]:
    """Choose the terms by the exhaustive, lexicographic search described in the module.

    Parameters
    ----------
    specs : sequence of TermSpec
        The candidate terms.
    data : GLSData
        The curve.
    edf : numpy.ndarray
        EDF of the points (diagonal starting covariance).
    penalty : float
        Penalty per parameter.
    misfit_level : float
        Significance level of the goodness-of-fit test.
    starts : sequence
        Starting covariances (None: the diagonal one from ``edf``).
    required : TermSpec, optional
        A term every evaluated subset contains (a sensor filter, which stands in for the
        white noise: :func:`allanite.fit.fit` searches with and without it).
    discrepancy : bool
        False: no second search with the model discrepancy when every subset is rejected.

    Returns
    -------
    solution : GLSSolution
        The chosen fit.
    ambiguity : Ambiguity or None
        The alternatives the record cannot tell from the chosen subset (:func:`_exchangeable`).
    selection : tuple of dict
        Per candidate term: ``score_gain`` (how much the score drops when the term is added
        to the best evaluated subset without it, given the other chosen terms; positive
        for a kept term) and ``kept``.
    subsets : list of dict
        Every subset evaluated: ``terms``, ``score``, ``chi2``, ``p_value``, ``rejected``.
    """
    found = _search(specs, data, edf, penalty, 0.0, starts, required)
    accepted = {k: c for k, c in found.items() if not c.p_value < misfit_level}
    pool = accepted
    if (
        not pool and misfit_level > 0 and discrepancy
    ):  # every subset rejected: allow the model discrepancy
        found = _search(specs, data, edf, penalty, misfit_level, starts, required)
        pool = found
    chosen = min((pool or found).values(), key=lambda c: c.score)
    by_names = {c.names: c for c in found.values()}
    ctx = _Context(specs, by_names, data, edf, penalty, misfit_level)
    ramp_test = _ramp_against_rrw(chosen, ctx)
    if ramp_test is not None and not ramp_test["kept"]:
        chosen = by_names[frozenset(ramp_test["alternative"])]
    chosen, additions = _add_significant(chosen, ctx)
    kept = chosen.names
    selection = []
    for spec in specs:
        name = spec.cls.type
        with_term, without = (kept, kept - {name}) if name in kept else (kept | {name}, kept)
        a, b = by_names.get(with_term), by_names.get(without)
        gain = math.inf if b is None else (-math.inf if a is None else b.score - a.score)
        entry: dict[str, Any] = {"term": name, "score_gain": float(gain), "kept": name in kept}
        if name == RAMP and ramp_test is not None:
            entry["ramp_test"] = ramp_test
        if name in additions:
            entry["added"] = additions[name]
        selection.append(entry)
    subsets = [
        {
            "terms": [s.cls.type for s in key],
            "score": c.score,
            "chi2": c.chi2,
            "p_value": c.p_value,
            "rejected": bool(c.p_value < misfit_level),
        }
        for key, c in sorted(found.items(), key=lambda kv: kv[1].score)
    ]
    ambiguity = _exchangeable(chosen, ctx)
    return chosen.solution, ambiguity, tuple(selection), subsets
