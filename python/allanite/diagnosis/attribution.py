r"""Attribution: fit every candidate effect on top of the simulated sensor and rank them.

Fit
---
The free parameters ``theta`` of a candidate (positive, fitted in log space) minimise the
tau-view statistic

.. math:: T(\theta) = r(\theta)^T C^{-1} r(\theta),\qquad
          r(\theta) = \log \mathrm{AVAR}_{real} - \log\bigl(\mathrm{AVAR}_{sim}
          + \mathrm{AVAR}_{effect}(\theta)\bigr) - b,

(``b`` the log bias of the estimator, taken from the Monte Carlo replicates), started from
dimensional guesses at every tau where the real curve lies above the simulated one and refined
by Nelder-Mead. Parameter uncertainties come from the Fisher matrix ``J^T C^{-1} J`` of the
log parameters (``J`` the Jacobian of ``r``).

Calibrated test and ranking
---------------------------
A candidate is kept when it improves the tau view significantly, ``Delta T = T_before -
T_after`` above the ``chi2(k)`` quantile ``1 - alpha`` (likelihood-ratio test, ``k`` free
parameters), or when it explains significant evidence of the other views (a spectral line,
a level jump, spikes, non-Gaussian block means). Kept candidates are ranked by the penalised
criterion

.. math:: S = T_{after} + k\,\chi^2_{1-\alpha}(1) + \sum_{e \in \text{unexplained}}
          \min(-2 \ln p_e, 1000),

a penalised tau-view fit (each parameter must earn its keep at level ``alpha``, so a simpler
effect wins a tie) plus the evidence the candidate leaves unexplained (Fisher's ``-2 ln p``
scale); a bias step, a warm-up and a ramp also pay the excess misfit of their shape on the
window means (:mod:`allanite.diagnosis.level_shape`); a slow stationary candidate explains
level evidence when the jump/level test, with its own slow noise added to the null spreads,
is no longer significant, and the low-frequency kurtosis evidence (platykurtic block means:
a random walk's or a slow Gauss-Markov process's path over one record) when the kurtosis the
candidate's own process predicts for the block means is consistent with the record's
(:meth:`~allanite.diagnosis.time_view.TimeView.lf_kurtosis_p_value`). A telegraph, whose
spectrum is a Gauss-Markov process's, is only kept when its two levels are shown: by that
kurtosis re-test, or by the two-level test of :mod:`allanite.diagnosis.two_level` (a hidden
two-state chain against the Gaussian twin, calibrated on the model's replicates) below the
evidence level ``alpha / n_evidence``; then the Gauss-Markov candidate of a correlation time
within ``DISTINCT_FACTOR`` of it leaves that evidence unexplained and pays ``-2 ln p`` like any
other (:func:`_refuted_twins`). ``consistent_after``
is true when the p-value of ``T_after`` (null law with ``k`` fewer degrees of freedom)
exceeds ``alpha``. Effects whose scores differ by
less than the penalty of one parameter are listed as each other's ``alternatives``. The gap
is ``G = max(0, T - T0)`` and the shrinkage ``1 - G_after / G_before`` (0 when the tau view
shows no gap to shrink).

Effects of negligible size
--------------------------
An effect is only an explanation when it has a size. :func:`negligible` is the one rule, used
for the ranking and for every step of the joint attribution (both fit through
:func:`fit_candidate`): a fitted effect whose *tau size* -- the Mahalanobis norm of the change
it makes to the expected log Allan variances, ``sqrt(d^T C^{-1} d)``, i.e. its Allan variance
contribution in the estimator's own standard errors -- is below ``NEGLIGIBLE_SE = 1`` is
dropped, because the data cannot tell it from zero (for a one-amplitude effect this is its
parameter below its own Fisher uncertainty). Such an effect explains no evidence either: a ramp
with ``R ~ 1e-12`` does not move the window means, bursts with ``N ~ 1e-12`` do not raise the
noise level. Exempt are the effects whose size another view measured: every parameter fixed
from the views (spikes: count and height), or a free parameter started from a view's
measurement (``Candidate.measured``: the amplitude of a detected line, the level of a
band-pass excess) that ends within ``MEASURED_FACTOR = 10`` of it; a weak line or rare spikes
are real with a tau size of zero. An effect that leaves the tau view unchanged carries the size
another view measured (``Candidate.view_size``, relative to the sensor's own level; e.g.
``white_drift`` keeps the record's mean noise level, its size is ``|ratio - 1|`` of the level
ratio the time view measured): it is negligible below ``LEVEL_NEGLIGIBLE`` (5 %), the level
change the headline calls slight.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import optimize, stats

from allanite.diagnosis.candidates import DISTINCT_FACTOR, Candidate
from allanite.diagnosis.level_shape import level_misfit
from allanite.diagnosis.tau_view import TauModel
from allanite.diagnosis.time_view import TimeView, added_block_kurtosis, added_level_variance
from allanite.diagnosis.two_level import two_level_p
from allanite.terms import TERM_TYPES

__all__ = ["LEVEL_NEGLIGIBLE", "Attribution", "fit_candidate", "negligible", "rank", "tau_size"]

#: slow processes whose window means move in jumps (two levels): the sparse-jump test, which
#: asks whether a Gaussian process explains the jumps, does not apply to them; one is only an
#: explanation when its own process reproduces the platykurtic block means (kurt_lf)
TWO_LEVEL = ("telegraph",)
#: the Gaussian process with a two-level process's spectrum (its Gaussian twin)
TWIN = "markov"

#: cap of one piece of evidence on the -2 ln p scale
EVIDENCE_CAP = 1000.0

#: an effect whose tau size is below this many of the tau view's standard errors is negligible
NEGLIGIBLE_SE = 1.0

#: a parameter started at another view's measurement counts as measured within this factor
MEASURED_FACTOR = 10.0

#: a noise level within this relative rms of the typical level is negligible in size (the
#: Allan variance in those windows within about +-10 %): the headline's wording, and the
#: threshold of a size another view measured (``Candidate.view_size``)
LEVEL_NEGLIGIBLE = 0.05


@dataclass(frozen=True)
class Attribution:
    """One candidate effect fitted on top of the simulated sensor.

    Attributes
    ----------
    effect : str
        Effect name.
    term : dict
        The fitted Term as JSON (add it to the model to close the gap).
    params, params_sigma : dict
        Fitted parameters and their one-sigma uncertainties (fixed parameters have sigma 0
        unless the view that fixed them supplies one).
    gap_before, gap_after : float
        ``G`` without and with the effect.
    shrinkage : float
        ``1 - gap_after / gap_before`` (0 when ``gap_before`` is 0).
    consistent_after : bool
        Whether the remaining tau-view gap is consistent with chance.
    p_after : float
        p-value of the remaining tau-view statistic.
    score : float
        Penalised ranking criterion (smaller is better).
    evidence : dict
        Per view: the tau statistic before/after and the likelihood-ratio p-value; the
        frequency/time evidence explained and left unexplained.
    sim_avar_after : numpy.ndarray
        Allan variance of the simulated sensor plus the effect on the tau-view grid (plots).
    alternatives : list of str
        Other kept effects whose score lies within the penalty of one parameter
        (``chi2_1`` quantile ``1 - alpha``) of this one: at level ``alpha`` the data do not tell
        them apart (e.g. a low-pass filter and a smaller quantization term that both lower
        only the shortest taus).
    """

    effect: str
    term: dict[str, Any]
    params: dict[str, float]
    params_sigma: dict[str, float]
    gap_before: float
    gap_after: float
    shrinkage: float
    consistent_after: bool
    p_after: float
    score: float
    evidence: dict[str, Any]
    sim_avar_after: NDArray[np.float64]
    alternatives: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (the CLI contract keys first)."""
        return {
            "effect": self.effect,
            "params": dict(self.params),
            "gap_before": self.gap_before,
            "gap_after": self.gap_after,
            "shrinkage": self.shrinkage,
            "consistent_after": self.consistent_after,
            "alternatives": list(self.alternatives),
            "params_sigma": dict(self.params_sigma),
            "term": dict(self.term),
            "p_after": self.p_after,
            "score": self.score,
            "evidence": self.evidence,
            "sim_avar_after": self.sim_avar_after.tolist(),
        }


def _starts(cand: Candidate, tm: TauModel) -> list[NDArray[np.float64]]:
    """Return starting log-parameter vectors (dimensional analysis at each positive residual)."""
    if cand.base is not None:
        return [np.log([s]) for s in (0.3, 0.6, 0.85, 1.2, 1.6, 2.5, 5.0)]
    specs = {p.name: p for p in cand.term_cls.params}
    r = tm.real - tm.ref
    excess = tm.sim_avar * np.expm1(np.clip(r, -50, 50))
    starts = []
    for i in np.flatnonzero(excess > 0):
        vec = []
        for name in cand.free:
            if name in cand.start:
                vec.append(np.log(cand.start[name]))
                continue
            spec = specs[name]
            vec.append(spec.rate * 0.5 * np.log(excess[i]) + spec.time * np.log(tm.tau[i]))
        starts.append(np.array(vec))
    if not starts:
        scale = np.log(np.sqrt(tm.sim_avar[0]))
        starts.append(
            np.array([specs[n].rate * scale + specs[n].time * np.log(tm.tau[0]) for n in cand.free])
        )
    return starts


def _values(cand: Candidate, logp: NDArray[np.float64]) -> dict[str, float]:
    return {n: float(np.exp(v)) for n, v in zip(cand.free, logp, strict=True)}


def _extra(cand: Candidate, logp: NDArray[np.float64], tm: TauModel) -> NDArray[np.float64] | None:
    try:
        # the optimiser explores extreme parameters: overflow there just means "no fit"
        with np.errstate(all="ignore"):
            values = _values(cand, logp)
            extra = np.asarray(cand.extra_avar(values, tm.tau, tm.dt), dtype=np.float64)
    except (ValueError, ZeroDivisionError, OverflowError, FloatingPointError):
        return None
    if extra.shape != tm.tau.shape or not np.all(np.isfinite(extra)):
        return None
    return extra


#: the smallest rescale factor fitted: a rescale there says the term is absent from the record
#: as far as it can tell (not determined, bounded from above), never a measured factor
RESCALE_FLOOR = 1e-3


def _bounds(cand: Candidate, tm: TauModel) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return log bounds of the free parameters.

    Times lie within ``[dt/4, 4T]`` and rates within ``[1/(4T), 2 fs]``: a correlation time
    longer than the record is a drift, not a process. A rescale factor lies within
    ``[1e-3, 1e3]``.
    """
    if cand.base is not None:  # a rescale between 1/1000 (the term is absent) and 1000
        return np.array([np.log(RESCALE_FLOOR)]), np.array([np.log(1.0 / RESCALE_FLOOR)])
    specs = {p.name: p for p in cand.term_cls.params}
    bounds = []
    for name in cand.free:
        spec = specs.get(name)
        if spec is not None and spec.rate == 0 and spec.time == 1:
            bounds.append((np.log(tm.dt / 4), np.log(4 * tm.duration)))
        elif spec is not None and spec.rate == 0 and spec.time == -1:
            bounds.append((np.log(1 / (4 * tm.duration)), np.log(2 / tm.dt)))
        else:
            bounds.append((-700.0, 700.0))
    arr = np.array(bounds, dtype=np.float64).reshape(-1, 2)
    return arr[:, 0], arr[:, 1]


def _degenerate(
    cand: Candidate,
    logp: NDArray[np.float64],
    lo: NDArray[np.float64],
    dt: float,
    hi: NDArray[np.float64] | None = None,
    extra: NDArray[np.float64] | None = None,
) -> bool:
    """Whether the fit sits where the effect is not identified.

    A parameter at its lower bound, a correlation time shorter than one sample (a
    Gauss-Markov or telegraph process with ``tau_c < dt`` is white noise at this sample rate),
    or a time parameter at its upper bound ``hi`` (four times the record: a Gauss-Markov or
    telegraph process, or a warm-up, that never decorrelates within the record is a drift,
    which the ramp and the random walk describe with fewer parameters): a simpler candidate
    describes the same curve. Likewise a stationary process with a fitted time whose Allan
    variance ``extra`` (on the tau grid) still rises at the longest tau: its turnover, the
    only mark of its correlation time, lies beyond the taus the record measures (a
    Gauss-Markov process peaks at ``1.89 tau_c``), so over the measured taus it is a random
    walk with a second parameter the record does not determine (a random walk next to noise
    bursts read as a Gauss-Markov process of ``tau_c`` 27 s with the longest tau 20 s).
    :func:`fit_candidate` leaves ``extra`` out (keeps the process) when the bend of a
    Gauss-Markov curve already tells it from that walk (:func:`_bend_identified`).
    """
    if np.any((logp - lo < 0.01) & (lo > -700.0)):
        return True
    specs = {p.name: p for p in cand.term_cls.params}
    timed = False
    for i, (name, v) in enumerate(zip(cand.free, logp, strict=True)):
        spec = specs.get(name)
        if spec is None or spec.rate != 0 or spec.time != 1:
            continue
        timed = True
        if np.exp(v) < dt or (hi is not None and hi[i] - v < 0.01):
            return True
    rising = extra is not None and extra.size > 1 and bool(extra[-1] >= np.max(extra))
    return bool(timed and cand.term_cls.stationary and rising)


#: effects with a Lorentzian spectrum whose random-walk limit ``tau_c -> inf`` is ``rrw``, for
#: which a curve still rising at the longest tau may be identified by its bend
BENDING = ("markov",)


def _bend_identified(
    cand: Candidate, logp: NDArray[np.float64], tm: TauModel, alpha: float
) -> bool:
    """Whether a fitted Gauss-Markov process is told apart from its random-walk limit.

    Below its correlation time a Gauss-Markov process is a rate random walk
    (``K^2 = 2 sigma^2 / tau_c``); its Allan variance bends away from the walk's ``tau`` slope
    long before its turnover at ``1.89 tau_c``. The tau grid stops at a tenth of the record, so
    a process of ``tau_c`` a twelfth of the record (1200 s at 200 Hz, ``tau_c`` 100 s) still
    rises at the longest tau (82 s) and yet its bend is measured. The bend is identified when
    the process's statistic lies below that of the best random walk (the one-parameter limit,
    ``K`` fitted on the same view) by more than the ``chi2_1`` quantile ``1 - alpha``: the
    likelihood-ratio test of the correlation time. Otherwise the rising curve is a random walk
    with a parameter the record does not determine (:func:`_degenerate`).
    """
    if cand.effect not in BENDING or cand.base is not None or cand.replaces is not None:
        return False
    values = _values(cand, logp)
    extra = _extra(cand, logp, tm)
    walk_cls = TERM_TYPES.get("rrw")
    if extra is None or walk_cls is None or "sigma" not in values or "tau_c" not in values:
        return False
    if extra.size < 2 or extra[-1] < np.max(extra):
        return False  # it turns over within the grid: nothing to rescue
    walk = Candidate(effect="rrw", term_cls=walk_cls, free=("K",))
    f = _objective(walk, tm)
    k0 = float(np.log(values["sigma"] * np.sqrt(2.0 / values["tau_c"])))
    res = optimize.minimize_scalar(
        lambda v: f(np.array([v])),
        bounds=(k0 - 5.0, k0 + 5.0),
        method="bounded",
        options={"xatol": 1e-4},
    )
    t_walk = min(float(res.fun), f(np.array([k0])))
    return bool(t_walk - tm.statistic(extra) > float(stats.chi2.isf(alpha, 1)))


def tau_size(extra: NDArray[np.float64], tm: TauModel) -> float:
    """Size of an added Allan variance ``extra`` in the tau view's own standard errors.

    The Mahalanobis norm ``sqrt(d^T C^-1 d)`` of the change ``d`` it makes to the expected log
    Allan variances (the tau view's statistic of the effect alone).
    """
    d = (tm.reference(extra) - tm.reference()) / np.sqrt(tm.real_scale)
    return float(np.sqrt(max(float(d @ tm.cov_inv @ d), 0.0)))


def negligible(
    cand: Candidate, values: dict[str, float], extra: NDArray[np.float64], tm: TauModel
) -> bool:
    """Whether a fitted effect is too small to be named (see the module docstring).

    Parameters
    ----------
    cand : Candidate
        The candidate.
    values : dict
        Its fitted free parameters.
    extra : numpy.ndarray
        The Allan variance it adds on the tau grid.
    tm : TauModel
        The tau view it was fitted on.

    Returns
    -------
    bool
        True when its tau size is below ``NEGLIGIBLE_SE`` and no other view measured its size,
        or when the size a view measured (``Candidate.view_size``) is below
        ``LEVEL_NEGLIGIBLE``.
    """
    if cand.view_size is not None:  # sized by another view, not by the tau view
        return bool(cand.view_size < LEVEL_NEGLIGIBLE)
    if not cand.free:  # every parameter measured by the frequency/time views
        return False
    for name in cand.measured:
        start = cand.start.get(name)
        if start is not None and start > 0 and values[name] >= start / MEASURED_FACTOR:
            return False
    return tau_size(extra, tm) < NEGLIGIBLE_SE


def _objective(cand: Candidate, tm: TauModel) -> Any:
    lo, hi = _bounds(cand, tm)

    def f(logp: NDArray[np.float64]) -> float:
        if not (np.all(logp > lo) and np.all(logp < hi)):
            return 1e300
        extra = _extra(cand, logp, tm)
        return 1e300 if extra is None else tm.statistic(extra)

    return f


def _fisher_sigma(cand: Candidate, tm: TauModel, logp: NDArray[np.float64]) -> NDArray[np.float64]:
    if logp.size == 0:
        return np.zeros(0)
    h = 1e-4
    cols = []
    for k in range(logp.size):
        up, dn = logp.copy(), logp.copy()
        up[k] += h
        dn[k] -= h
        e_up, e_dn = _extra(cand, up, tm), _extra(cand, dn, tm)
        if e_up is None or e_dn is None:
            return np.full(logp.size, np.inf)
        cols.append((tm.reference(e_up) - tm.reference(e_dn)) / (2 * h))
    jac = np.stack(cols, axis=1) / np.sqrt(tm.real_scale)
    fisher = jac.T @ tm.cov_inv @ jac
    cov = np.linalg.pinv(fisher)
    return np.asarray(np.sqrt(np.maximum(np.diag(cov), 0.0)), dtype=np.float64)


#: the kurt_lf re-test simulates the candidate over the fitted record: up to this many samples
LF_KURTOSIS_MAX_SAMPLES = 2**18

#: the kurt_lf re-test takes the most favourable block-mean variance of the candidate within
#: this factor of its fitted one: an allowance for a systematic trade, not a statistical
#: interval (a telegraph next to more white noise is fitted with ~0.7 of its variance, while
#: the fit's own 99 % Fisher interval of the amplitude is only about x1.25; see
#: docs/diagnosis.md, "Jump-like effects and their random look-alikes")
LF_VARIANCE_FACTOR = 2.0


def _lf_kurtosis_p(
    cand: Candidate, values: dict[str, float], time_view: TimeView, dt: float, duration: float
) -> float | None:
    """p-value of the time view's low-frequency kurtosis with the candidate's process added.

    The largest over the candidate's block-mean variance within :data:`LF_VARIANCE_FACTOR` of
    its fitted one. None when the candidate adds no process of its own, the record is longer than
    :data:`LF_KURTOSIS_MAX_SAMPLES` or the time view has no block detail.
    """
    added = cand.added_term(values)
    lf = time_view.lf_kurtosis
    n_fit = round(duration / dt)
    if added is None or not lf or n_fit > LF_KURTOSIS_MAX_SAMPLES:
        return None
    n_windows = time_view.level.size
    if n_fit < 2 * n_windows:
        return None
    var, k, sd = added_block_kurtosis(added, 1.0 / dt, n_fit, n_windows, tuple(lf["blocks"]))
    p = [
        time_view.lf_kurtosis_p_value((var * f, k, sd))
        for f in np.geomspace(1.0 / LF_VARIANCE_FACTOR, LF_VARIANCE_FACTOR, 9)
    ]
    return max((x for x in p if x is not None), default=None)


#: the Gaussian twins a telegraph must be told from: its fit's corners at this many of the
#: fit's own (Fisher) standard errors of the amplitude and the correlation time, log scale
TWIN_SIGMAS = 2.0


def _plausible_twins(
    cand: Candidate, logp: NDArray[np.float64], tm: TauModel
) -> list[tuple[float, float]] | None:
    """Gauss-Markov processes the tau view cannot tell from the fitted telegraph.

    The four corners ``(a e^{+-z s_a}, T_c e^{+-z s_T})`` with ``z`` = :data:`TWIN_SIGMAS`
    and ``s`` the fit's Fisher standard errors (log scale); None when they are not finite.
    """
    values = _values(cand, logp)
    sig = dict.fromkeys(("amplitude", "tau_c"), 0.0)
    sig.update(zip(cand.free, _fisher_sigma(cand, tm, logp), strict=True))
    if not all(np.isfinite(v) for v in sig.values()):
        return None
    z = TWIN_SIGMAS
    return [
        (values["amplitude"] * np.exp(i * z * sig["amplitude"]),
         values["tau_c"] * np.exp(j * z * sig["tau_c"]))
        for i in (-1, 1)
        for j in (-1, 1)
    ]  # fmt: skip


def _context(time_view: TimeView | None) -> dict[str, Any] | None:
    """The two-level context of the time view (None: the test does not run on this record)."""
    if time_view is None:
        return None
    ctx: dict[str, Any] | None = time_view.lf_kurtosis.get("two_level")
    return ctx


def _two_level(
    cand: Candidate,
    logp: NDArray[np.float64],
    tm: TauModel,
    time_view: TimeView | None,
    level: float,
) -> dict[str, float]:
    """The two-level test of a telegraph candidate (:func:`two_level_p`).

    ``p_gauss`` is the test against the Gaussian twin of the fit (``p_gauss_fit``) and, when
    that is below ``level``, against every twin the fit's uncertainty allows
    (:func:`_plausible_twins`): the largest of their p-values (two levels are shown only when
    every plausible twin is rejected). Empty when the time view carries no two-level context
    (a record longer than :data:`LF_KURTOSIS_MAX_SAMPLES`, a simulated record instead of a
    model) or the record is too short for the fitted correlation time.
    """
    ctx = _context(time_view)
    added = cand.added_term(_values(cand, logp))
    if ctx is None or added is None:
        return {}
    got = two_level_p(added, ctx)
    if got is None:
        return {}
    out = {"p_gauss": got[0], "p_gauss_fit": got[0], "p_own": got[1], "block_samples": got[2]}
    if got[0] < level:
        twins = _plausible_twins(cand, logp, tm)
        wide = two_level_p(added, ctx, twins) if twins is not None else None
        out["p_gauss"] = max(got[0], wide[0]) if wide is not None else 1.0
    return {k: float(v) for k, v in out.items()}


def _two_levels_shown(
    cand: Candidate,
    logp: NDArray[np.float64],
    tm: TauModel,
    time_view: TimeView | None,
    level: float,
) -> tuple[dict[str, float], bool]:
    """The two-level test of a telegraph and whether it shows two levels at ``level``.

    Shown: every plausible Gaussian twin rejected, the telegraph itself not.
    """
    if cand.effect not in TWO_LEVEL:
        return {}, False
    two_level = _two_level(cand, logp, tm, time_view, level)
    return two_level, bool(two_level) and two_level["p_gauss"] < level <= two_level["p_own"]


def _refuted_twins(kept: list[Attribution], alpha: float, n_evidence: int) -> list[Attribution]:
    """The kept attributions, a Gaussian twin of a telegraph with two levels shown penalised.

    A Gauss-Markov process whose correlation time lies within ``DISTINCT_FACTOR`` of a kept
    telegraph's, when the telegraph's two-level test rejected its Gaussian twin at the
    evidence level, leaves that evidence unexplained: its score pays
    ``min(-2 ln p_gauss, EVIDENCE_CAP)`` (unless it already pays for ``kurt_lf``).
    """
    level = alpha / max(n_evidence, 1)
    shown = [
        a
        for a in kept
        if a.effect in TWO_LEVEL and a.evidence.get("two_level", {}).get("p_gauss", 1.0) < level
    ]
    if not shown:
        return kept
    out = []
    for a in kept:
        twin = next(
            (
                t
                for t in shown
                if a.effect == TWIN
                and abs(np.log(a.params["tau_c"] / t.params["tau_c"])) < np.log(DISTINCT_FACTOR)
            ),
            None,
        )
        if twin is None or "kurt_lf" in a.evidence.get("unexplained", []):
            out.append(a)
            continue
        p = max(twin.evidence["two_level"]["p_gauss"], 1e-300)
        cost = min(-2.0 * np.log(p), EVIDENCE_CAP)
        evidence = {**a.evidence, "two_level_unexplained": {"p_gauss": p, "cost": cost}}
        out.append(replace(a, score=a.score + cost, evidence=evidence))
    return out


def _level_p_with(
    cand: Candidate, values: dict[str, float], time_view: TimeView, dt: float, duration: float
) -> dict[str, float]:
    """p-values of the time view's ``jump``/``level`` tests with the candidate's noise added."""
    window = np.array([time_view.window_s])
    with np.errstate(all="ignore"):
        a_w = np.asarray(cand.extra_avar(values, window, dt), dtype=float)
    if not (a_w.size and np.isfinite(a_w[0]) and a_w[0] > 0):
        return {}
    added = cand.added_term(values)
    n_fit = round(duration / dt)
    level_var = None
    if added is not None and n_fit >= 2 * time_view.level.size:
        level_var = added_level_variance(added, 1.0 / dt, n_fit, time_view.level.size)
    return time_view.level_p_values(float(a_w[0]), level_var, gaussian=cand.effect not in TWO_LEVEL)


def fit_candidate(
    cand: Candidate,
    tm: TauModel,
    *,
    alpha: float,
    evidence_p: dict[str, float],
    significant: dict[str, bool],
    time_view: TimeView | None = None,
    duration: float = 0.0,
) -> Attribution | None:
    """Fit one candidate; None when it neither improves the tau view nor explains evidence."""
    if cand.effect in TWO_LEVEL and not significant.get("kurt_lf") and not _context(time_view):
        return None  # no test can show its two levels (not fitted: the cost on long records)
    f = _objective(cand, tm)
    lo, hi = _bounds(cand, tm)
    inside = [np.clip(x0, lo + 1e-6, hi - 1e-6) for x0 in _starts(cand, tm)]
    starts = sorted(inside, key=f)[:3]
    if not cand.free:  # every parameter fixed by the other views
        starts = []
    best: Any = None
    for x0 in starts:
        res = optimize.minimize(
            f, x0, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-4, "maxiter": 600}
        )
        if best is None or res.fun < best.fun:
            best = res
    if cand.free and (best is None or best.fun >= 1e299):
        return None
    logp = np.asarray(best.x if cand.free else [], dtype=np.float64)
    extra = _extra(cand, logp, tm)
    # a Gauss-Markov curve still rising at the longest tau is degenerate unless its bend
    # towards the turnover already tells it from its random-walk limit
    curve = None if _bend_identified(cand, logp, tm, alpha) else extra
    if cand.base is None and _degenerate(cand, logp, lo, tm.dt, hi, curve):
        return None
    if extra is None or negligible(cand, _values(cand, logp), extra, tm):
        return None
    n_ev = max(len(evidence_p), 1)
    two_level, shown = _two_levels_shown(cand, logp, tm, time_view, alpha / n_ev)
    if cand.effect in TWO_LEVEL and not shown and not significant.get("kurt_lf", False):
        return None  # neither test below can show its two levels
    k = len(cand.free)
    t_before, t_after = tm.statistic(), tm.statistic(extra)
    delta = t_before - t_after
    lr_p = float(stats.chi2.sf(max(delta, 0.0), k))
    explained = sorted(e for e in cand.explains if significant.get(e, False))
    # slow stationary noise explains level wander too: re-test jump/level with the candidate
    level_p: dict[str, float] = {}
    pending = [e for e in ("jump", "level") if significant.get(e, False) and e not in explained]
    if time_view is not None and pending:
        level_p = _level_p_with(cand, _values(cand, logp), time_view, tm.dt, duration)
        for e, p in level_p.items():
            if significant.get(e, False) and p >= alpha / n_ev and e not in explained:
                explained.append(e)
        explained.sort()
    # slow stationary noise makes block means platykurtic too: re-test kurt_lf with it
    if time_view is not None and significant.get("kurt_lf", False) and "kurt_lf" not in explained:
        p_lf = _lf_kurtosis_p(cand, _values(cand, logp), time_view, tm.dt, duration)
        if p_lf is not None and p_lf >= alpha / n_ev:
            explained = sorted([*explained, "kurt_lf"])
    if lr_p >= alpha and not explained:
        return None
    if cand.effect in TWO_LEVEL and "kurt_lf" not in explained and not shown:
        # neither its own two levels reproduce the platykurtic block means nor do the
        # record's block means look two-level beyond its Gaussian twin: it is a
        # Gauss-Markov process with the same spectrum, and the simpler term is the answer
        return None
    unexplained = sorted(e for e, s in significant.items() if s and e not in explained)
    penalty = sum(min(-2.0 * np.log(max(evidence_p[e], 1e-300)), EVIDENCE_CAP) for e in unexplained)
    per_param = float(stats.chi2.isf(alpha, 1))
    penalty += k * per_param
    shape = (
        level_misfit(cand.effect, time_view, duration, per_param) if time_view is not None else 0.0
    )
    penalty += shape
    sig = _fisher_sigma(cand, tm, logp)
    values = _values(cand, logp)
    params = dict(values)
    sigma = {n: float(values[n] * s) for n, s in zip(cand.free, sig, strict=True)}
    term = cand.term(values)
    if cand.base is not None:
        coef = cand.term_cls.params[0].name
        params[coef] = float(term.values()[coef])
        sigma[coef] = float(sigma["scale"] * cand.base.values()[coef])
    else:
        for name, value in cand.fixed.items():
            params[name] = float(value)
            sigma.setdefault(name, 0.0)
    g_before, g_after = tm.gap(), tm.gap(extra)
    p_after = tm.holding([cand.added_term(values)]).p_value(extra, n_params=k)
    return Attribution(
        effect=cand.effect,
        term=term.to_dict(),
        params=params,
        params_sigma=sigma,
        gap_before=g_before,
        gap_after=g_after,
        shrinkage=float(1.0 - g_after / g_before) if g_before > 0 else 0.0,
        consistent_after=bool(p_after > alpha),
        p_after=p_after,
        score=float(t_after + penalty),
        evidence={
            "tau": {"T_before": t_before, "T_after": t_after, "delta_T": delta, "lr_p_value": lr_p},
            "explained": explained,
            "unexplained": unexplained,
            "level_shape_misfit": shape,
            "level_p_with_effect": level_p,
            **({"two_level": two_level} if two_level else {}),
        },
        sim_avar_after=np.asarray(tm.sim_avar + extra, dtype=np.float64),
    )


def rank(
    candidates: list[Candidate],
    tm: TauModel,
    *,
    alpha: float,
    evidence_p: dict[str, float],
    significant: dict[str, bool],
    time_view: TimeView | None = None,
    duration: float = 0.0,
) -> list[Attribution]:
    """Fit all candidates and return the kept ones, best (smallest score) first."""
    fitted = [
        fit_candidate(
            c,
            tm,
            alpha=alpha,
            evidence_p=evidence_p,
            significant=significant,
            time_view=time_view,
            duration=duration,
        )
        for c in candidates
    ]
    kept = _refuted_twins([a for a in fitted if a is not None], alpha, len(evidence_p))
    kept = sorted(kept, key=lambda a: a.score)
    margin = float(stats.chi2.isf(alpha, 1))
    return [
        replace(
            a,
            alternatives=tuple(
                b.effect for b in kept if b is not a and abs(b.score - a.score) < margin
            ),
        )
        for a in kept
    ]
