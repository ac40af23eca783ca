"""``allanite.fit``: noise coefficients from an Allan curve or a record, with uncertainty."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from allanite._deprecation import keyword_only_fs
from allanite.errors import RecordTooShortError
from allanite.fit.classic import ClassicReadout, classic_readout
from allanite.fit.covariance import avar_covariance
from allanite.fit.filters import select_with_filters
from allanite.fit.gls import GLSData, GLSSolution, score_interval, solve
from allanite.fit.result import NO_EVIDENCE_CHI2, Coefficient, FitResult
from allanite.fit.seed import SCALE, coefficient_bounds, seed_fit
from allanite.fit.select import Ambiguity, n_params
from allanite.fit.spec import AUTO_CANDIDATES, Resolved, TermSpec, resolve_terms
from allanite.io.record import Record
from allanite.model import NoiseModel
from allanite.plausibility import warn_coefficients
from allanite.terms import Flicker, Quantization, RateRamp, RateRandomWalk, Term, White
from allanite.units import RECORD_UNIT, SYMBOL_POWERS, coefficient_unit, rate_unit
from allanite.variance import AllanResult, avar

__all__ = ["fit", "fit_factors"]

Method = Literal["gls", "seed"]


def _curve(
    source: AllanResult | Record | ArrayLike,
    fs: float | None,
    input: str | None,
    units: str | None,
    method: str,
) -> AllanResult:
    taus = "octave" if method == "gls" else "log"
    if isinstance(source, AllanResult):
        if fs is not None and not math.isclose(float(fs), source.fs, rel_tol=1e-9):
            raise ValueError(f"fs={fs} contradicts the AllanResult's fs={source.fs}; leave fs out")
        if source.var.ndim != 1 and source.n_channels == 1:
            source = source.channel(0)
        if source.var.ndim != 1:
            raise ValueError(
                f"the AllanResult has {source.n_channels} channels; fit one at a time: "
                "fit(result.channel(i))"
            )
        return source
    if isinstance(source, Record):
        if source.n_channels != 1:
            raise ValueError(
                f"fit one channel at a time; the Record has {source.n_channels}: "
                "fit(record.select([0]))"
            )
        return avar(source, fs=fs, input=input, taus=taus, units=units)  # type: ignore[arg-type]
    if fs is None:
        raise ValueError("fitting a record needs its sampling frequency: fit(x, fs=100.0)")
    x = np.asarray(source)
    if x.ndim != 1:
        raise ValueError(f"fit one channel at a time; got a record of shape {x.shape}")
    return avar(x, fs=fs, input=input or "rate", taus=taus, units=units)  # type: ignore[arg-type]


def _points(result: AllanResult, method: str, max_fraction: float) -> NDArray[np.bool_]:
    var = np.asarray(result.var, dtype=np.float64)
    if not np.any(np.isfinite(var)):
        raise ValueError("the Allan curve is all NaN/inf: nothing to fit; check the record")
    finite = np.isfinite(var)
    if np.any(var[finite] < 0):
        raise ValueError(
            "the Allan curve has negative variances; variances cannot be negative (pass the "
            "variance, not a signed quantity)"
        )
    keep = finite & (var > 0)
    if method == "gls":
        n = result.n_samples
        keep &= result.m <= max_fraction * n
    return keep


def _thin(m: NDArray[np.int64], keep: NDArray[np.bool_], min_ratio: float) -> NDArray[np.bool_]:
    """Keep, from the smallest factor up, only factors at least ``min_ratio`` times the last kept.

    A dense grid (``taus="log"`` with 100 points, ``"all"``) adds almost no information over
    octave spacing (neighbouring estimates correlate nearly perfectly) but makes the
    covariance nearly singular and the fit slow; an octave-like subset keeps the fit fast,
    well conditioned and independent of how densely the curve was computed.
    """
    out = np.zeros_like(keep)
    last = -math.inf
    for i in np.flatnonzero(keep)[np.argsort(m[keep], kind="stable")]:
        if m[i] >= last * min_ratio * (1.0 - 1e-9):
            out[i] = True
            last = float(m[i])
    return out


def fit_factors(
    m: ArrayLike, n_samples: int, *, max_fraction: float = 0.125, min_ratio: float = 2.0
) -> NDArray[np.int64]:
    """The averaging factors the GLS fit uses of a curve computed at factors ``m``.

    The factors with ``m <= max_fraction * n_samples`` (enough independent differences),
    thinned from the smallest up to ratios of at least ``min_ratio`` (:func:`_thin`), as
    :func:`fit` does with its defaults when every variance is finite and positive. Use it to
    place a design's terms inside the taus a fit will actually see.

    Parameters
    ----------
    m : array_like of int
        Averaging factors of the curve (e.g. ``AllanResult.m``).
    n_samples : int
        Record length (``AllanResult.n_samples``).
    max_fraction, min_ratio : float
        As in :func:`fit`.

    Returns
    -------
    numpy.ndarray
        The fitted factors, sorted.
    """
    factors = np.asarray(m, dtype=np.int64)
    enough = factors <= max_fraction * n_samples
    return np.sort(factors[_thin(factors, enough, min_ratio)])


#: usable taus an automatic fit needs: with two, every single term fits exactly and the
#: selection between them is chance (20 white samples read as Q or B in 5 of 20 seeds)
AUTO_MIN_POINTS = 3


def min_auto_samples() -> int:
    """The shortest record on which an automatic fit can choose terms.

    The smallest ``n`` whose fitted factors (:func:`fit_factors` with the fit's defaults) on
    a grid holding every factor number :data:`AUTO_MIN_POINTS`; the default log grid holds
    every short factor, so it needs exactly this many samples (sparser grids need more).
    """
    n = 1
    while len(fit_factors(np.arange(1, n + 1), n)) < AUTO_MIN_POINTS:
        n += 1
    return n


def _check_auto_count(n_points: int, n_samples: int) -> None:
    if n_points < AUTO_MIN_POINTS:
        raise RecordTooShortError(
            f"the record is too short for an automatic fit: {n_samples} samples give only "
            f"{n_points} usable taus, and choosing the terms needs at least {AUTO_MIN_POINTS} "
            f"({min_auto_samples()} samples or more on the default grid)",
            "use a longer record, or name the terms yourself (allanite.fit(curve, ['N']))",
        )


def _check_count(n_points: int, n_params: int, what: str) -> None:
    if n_points < n_params + 1:
        raise ValueError(
            f"{what} has {n_params} parameters but only {n_points} usable taus; need at least "
            f"{n_params + 1}: use a longer record, a denser tau grid (taus='log' or 'all') with a "
            "smaller min_ratio, or fewer terms"
        )


def _n_params(specs: Sequence[TermSpec]) -> int:
    return n_params(specs)


def _slope_start(classic: ClassicReadout, data: GLSData, units: str) -> NDArray[np.float64] | None:
    """Covariance of the estimates under the model read off the curve by the slope method."""
    terms: list[Term] = []
    for symbol, cls in (
        ("Q", Quantization),
        ("N", White),
        ("B", Flicker),
        ("K", RateRandomWalk),
    ):
        value = classic.values.get(symbol)
        if value is not None and math.isfinite(value) and value > 0:
            terms.append(cls(value))
    if not terms:
        return None
    model = NoiseModel(tuple(terms), {"rate": units, "time": "s"})
    cov = avar_covariance(model, data.m, data.dt, data.n_samples)
    if not np.all(np.isfinite(cov)) or np.any(np.diag(cov) <= 0):
        return None
    return cov


def _coefficients(sol: GLSSolution, model: NoiseModel) -> dict[str, Coefficient]:
    rate = model.units["rate"]
    out: dict[str, Coefficient] = {}
    labels = model.labelled_parameters()
    k = 0
    index = 0
    for j, spec in enumerate(sol.specs):
        theta = max(float(sol.theta[j]), 0.0)
        se_theta = math.sqrt(max(sol.param_cov[j, j], 0.0))
        amp = math.sqrt(theta)
        stderr = se_theta / (2.0 * amp) if amp > 0 and se_theta < theta else math.sqrt(se_theta)
        label, _, pspec = labels[index]
        index += 1

        def amp_interval(level: float, j: int = j) -> tuple[float, float]:
            z = float(stats.norm.ppf(0.5 + level / 2.0))
            lo, hi = score_interval(sol, j, z)
            return math.sqrt(max(lo, 0.0)), math.sqrt(max(hi, 0.0))

        unit = coefficient_unit(rate, pspec.rate, pspec.time).text
        out[label] = Coefficient(label, amp, stderr, unit, amp_interval)
        if spec.nonlinear_name is not None:
            p = len(sol.specs) + k
            log_value = float(sol.log_phi[k])
            se_log = math.sqrt(max(sol.param_cov[p, p], 0.0))
            value = math.exp(log_value)
            label, _, pspec = labels[index]
            index += 1

            def log_interval(
                level: float, v: float = value, s: float = se_log
            ) -> tuple[float, float]:
                z = float(stats.norm.ppf(0.5 + level / 2.0))
                return v * math.exp(-z * s), v * math.exp(z * s)

            out[label] = Coefficient(
                label,
                value,
                value * se_log,
                coefficient_unit(rate, pspec.rate, pspec.time).text,
                log_interval,
            )
            k += 1
    return out


def _fit_gls(
    result: AllanResult,
    resolved: Resolved,
    units: str,
    penalty: float,
    max_fraction: float,
    misfit_level: float,
    min_ratio: float,
) -> FitResult:
    if result.kind != "overlapping":
        raise ValueError(
            f"method='gls' models the overlapping Allan variance, got kind={result.kind!r}; "
            "compute avar(x, fs, kind='overlapping') or use method='seed'"
        )
    specs, auto = resolved.specs, resolved.auto
    filters, force_filters = resolved.filters, resolved.force_filters
    enough = _points(result, "gls", max_fraction)
    keep = _thin(result.m, enough, min_ratio)
    if auto:
        _check_auto_count(int(keep.sum()), result.n_samples)
    else:
        _check_count(int(keep.sum()), _n_params(specs), "the model")
    dt = 1.0 / result.fs
    data = GLSData(
        tau=result.tau[keep],
        m=result.m[keep].astype(np.float64),
        y=np.asarray(result.var, dtype=np.float64)[keep],
        dt=dt,
        n_samples=result.n_samples,
        units=units,
    )
    edf = np.asarray(result.edf, dtype=np.float64)[keep]
    # read on the taus with enough independent differences, like the fit (the last
    # octaves scatter and would otherwise set the "flat minimum")
    classic = classic_readout(
        result.tau[enough], np.sqrt(np.asarray(result.var, dtype=np.float64)[enough])
    )
    subsets: list[dict[str, Any]] = []
    ambiguity: Ambiguity | None = None
    if auto:
        usable = [s for s in specs if _n_params([s]) < int(keep.sum())]
        slope = _slope_start(classic, data, units)
        starts = [None] if slope is None else [None, slope]
        sol, ambiguity, selection, subsets = select_with_filters(
            usable, filters, force_filters, data, edf, penalty, misfit_level, starts
        )
    else:
        sol, selection = solve(specs, data, edf, misfit_level=misfit_level), ()
    model = sol.model(units)
    coefficients = _coefficients(sol, model)
    selected = dict(coefficients)  # conditional on the selection, before any widening
    alternatives, exchangeable = _ambiguous(ambiguity, coefficients, data, units)
    undetected = _undetected(ambiguity, exchangeable, units)
    dof = int(keep.sum()) - _n_params(sol.specs)
    p_value = float(stats.chi2.sf(sol.chi2, dof)) if dof > 0 else math.nan
    # standardised under the terms alone, so that a misfit shows where it is
    residuals = (data.y - sol.fitted) / np.sqrt(np.diag(sol.model_cov))
    return FitResult(
        model=model,
        coefficients=coefficients,
        chi2=sol.chi2,
        dof=dof,
        p_value=p_value,
        tau=data.tau,
        var=data.y,
        fitted=sol.fitted,
        residuals=residuals,
        cov=sol.cov,
        method="gls",
        # read on the taus with enough independent differences, like the fit (the last
        # octaves scatter and would otherwise set the "flat minimum")
        classic=classic,
        selection=selection,
        meta={
            "iterations": sol.iterations,
            "n_samples": result.n_samples,
            "fs": result.fs,
            "subsets": subsets,
            # the coefficients with the intervals conditional on the selection alone
            "selected_coefficients": selected,
        },
        discrepancy=sol.discrepancy,
        misfit_level=misfit_level,
        alternatives=alternatives,
        exchangeable=exchangeable,
        undetected=undetected,
    )


#: the label of each automatic candidate's amplitude (its IEEE symbol: Q, N, B, K, R), in
#: the candidates' order
_SYMBOL = {c.type: c.symbol for c in AUTO_CANDIDATES}

#: share of the fitted Allan variance above which a swapped-in term is said to explain a tau
_SHARE = 0.2


def _hull(own: Coefficient, union: Coefficient) -> Coefficient:
    """``own`` with the interval widened to the hull of its own and the union fit's."""

    def interval(level: float) -> tuple[float, float]:
        (a, b), (c, d) = own.ci(level), union.ci(level)
        return min(a, c), max(b, d)

    return Coefficient(own.name, own.value, max(own.stderr, union.stderr), own.unit, interval)


def _ambiguous(
    ambiguity: Ambiguity | None,
    coefficients: dict[str, Coefficient],
    data: GLSData,
    units: str,
) -> tuple[tuple[dict[str, Any], ...], dict[str, Coefficient]]:
    """Widen the exchangeable terms' intervals in place; describe the alternatives.

    The chosen terms (:func:`allanite.fit.select._exchangeable`) get the hull of their own
    interval and the one of the union fit (chosen plus swapped-in or added terms: its lower
    bounds reach what the data allow, often 0), so the estimate stays inside; an addition
    the record shows some of (chi-square drop at least
    :data:`~allanite.fit.result.NO_EVIDENCE_CHI2`, printed AMBIGUOUS) widens every chosen
    term to the hull with the fit with that addition (the terms it moves); the
    alternative terms are returned with their union-fit value and interval. Each alternative
    gains ``symbol_in``/``symbol_out`` and ``taus``, the first and last fitted tau at which
    the alternative term carries more than a fifth of the alternative's fitted variance
    (where it carries most, when nowhere).
    """
    if ambiguity is None or not ambiguity.alternatives:
        return (), {}
    union = ambiguity.union
    union_coefs = {} if union is None else _coefficients(union, union.model(units))
    for name in ambiguity.exchangeable:
        label = _SYMBOL.get(name)
        if label in coefficients and label in union_coefs:
            coefficients[label] = _hull(coefficients[label], union_coefs[label])
    # an addition the record shows some of (chi2 drop >= 1, printed AMBIGUOUS with
    # "intervals from the fit with it"): the chosen terms widened to the hull with the fit
    # with it. Without it a velocity quantum carrying 3.5 % of the first tau's Allan
    # variance, left out (drop 6), moved N by 4.4 of its conditional standard errors: N
    # covered in 0 of 47 such seeds; 43 of 47 with the hull, 31 of 47 when only drops above
    # 3.84 widen (benchmarks/audit_default_fit.py, record 50)
    for alt in ambiguity.alternatives:
        drop = alt.get("delta_chi2")
        if alt["swap_out"] is not None or drop is None or drop < NO_EVIDENCE_CHI2:
            continue
        with_it = ambiguity.with_term.get(alt["swap_in"])
        if with_it is None:
            continue
        added = _coefficients(with_it, with_it.model(units))
        for label in list(coefficients):
            if label in added:
                coefficients[label] = _hull(coefficients[label], added[label])
    exchangeable: dict[str, Coefficient] = {}
    described = []
    for alt in ambiguity.alternatives:
        symbol = _SYMBOL.get(alt["swap_in"], alt["swap_in"])
        if symbol in union_coefs:
            exchangeable[symbol] = union_coefs[symbol]
        else:  # no union fit: the term's value and interval in the fit with it
            own = ambiguity.with_term[alt["swap_in"]]
            exchangeable[symbol] = _coefficients(own, own.model(units))[symbol]
        sol = ambiguity.alternative_fits[alt["swap_in"]]
        j = [s.cls.type for s in sol.specs].index(alt["swap_in"])
        share = max(float(sol.theta[j]), 0.0) * sol.design[:, j] / np.maximum(sol.fitted, 1e-300)
        over = np.flatnonzero(share > _SHARE)
        if not over.size:
            over = np.array([int(np.argmax(share))])
        described.append(
            {
                **alt,
                "symbol_in": symbol,
                "symbol_out": None
                if alt["swap_out"] is None
                else _SYMBOL.get(alt["swap_out"], alt["swap_out"]),
                "taus": [float(data.tau[over[0]]), float(data.tau[over[-1]])],
            }
        )
    return tuple(described), exchangeable


def _undetected(
    ambiguity: Ambiguity | None, exchangeable: dict[str, Coefficient], units: str
) -> dict[str, Coefficient]:
    """The candidates left out and not alternatives, each from the fit with it.

    Their intervals (from 0, or near it) bound what the record allows of a term it does
    not show: "not detected" is not "absent".
    """
    if ambiguity is None:
        return {}
    out: dict[str, Coefficient] = {}
    for name, sol in ambiguity.with_term.items():
        symbol = _SYMBOL.get(name, name)
        if symbol not in exchangeable:
            out[symbol] = _coefficients(sol, sol.model(units))[symbol]
    order = list(_SYMBOL.values())
    return dict(sorted(out.items(), key=lambda kv: order.index(kv[0]) if kv[0] in order else -1))


def _fit_seed(result: AllanResult, units: str) -> FitResult:
    keep = _points(result, "seed", 1.0)
    _check_count(int(keep.sum()), 5, "method='seed'")
    tau = result.tau[keep]
    var = np.asarray(result.var, dtype=np.float64)[keep]
    sf = seed_fit(tau, var)
    raw_of = {"R": "r", "K": "k", "B": "b", "N": "n", "Q": "q"}
    coefs: dict[str, Coefficient] = {}
    for name, raw in raw_of.items():
        scale = SCALE[name]

        def interval(
            level: float, p: float = sf.raw[raw], s: float = sf.raw_stderr[raw], c: float = scale
        ) -> tuple[float, float]:
            tq = float(stats.t.ppf(0.5 + level / 2.0, sf.dof))
            return coefficient_bounds(p - tq * s, p + tq * s, c)

        value = abs(sf.raw[raw]) * scale
        coefs[name] = Coefficient(
            name,
            value,
            sf.raw_stderr[raw] * scale,
            coefficient_unit(units, *SYMBOL_POWERS[name]).text,
            interval,
        )
    model = NoiseModel(
        (
            Quantization(Q=coefs["Q"].value),
            White(N=coefs["N"].value),
            Flicker(B=coefs["B"].value),
            RateRandomWalk(K=coefs["K"].value),
            RateRamp(R=coefs["R"].value),
        ),
        {"rate": units, "time": "s"},
    )
    fitted = sf.fitted
    return FitResult(
        model=model,
        coefficients={k: coefs[k] for k in ("Q", "N", "B", "K", "R")},
        chi2=sf.sse,
        dof=sf.dof,
        p_value=math.nan,
        tau=tau,
        var=var,
        fitted=fitted,
        residuals=(var - fitted) / math.sqrt(sf.sse / sf.dof),
        cov=np.diag(np.full(tau.size, sf.sse / sf.dof)),
        method="seed",
        classic=classic_readout(result.tau, np.sqrt(np.asarray(result.var, dtype=np.float64))),
        meta={"raw": sf.raw, "raw_bounds_95": sf.raw_bounds},
    )


def _check_tau_range(tau_range: Any) -> tuple[float, float] | None:
    if tau_range is None:
        return None
    try:
        lo, hi = (float(v) for v in tau_range)
    except (TypeError, ValueError):
        raise ValueError(
            f"tau_range must be two numbers (lo, hi) in seconds, got {tau_range!r}"
        ) from None
    if not (0.0 <= lo < hi):
        raise ValueError(f"tau_range needs 0 <= lo < hi seconds, got ({lo:g}, {hi:g})")
    return lo, hi


def _restrict(result: AllanResult, window: tuple[float, float]) -> AllanResult:
    """The curve at the taus inside ``window`` (a clear error when too few remain)."""
    inside = (result.tau >= window[0]) & (result.tau <= window[1])
    if not inside.any():
        raise ValueError(
            f"no tau of the curve lies in tau_range {window[0]:g}..{window[1]:g} s (the curve "
            f"spans {result.tau[0]:g}..{result.tau[-1]:g} s)"
        )
    return dataclasses.replace(
        result,
        tau=result.tau[inside],
        m=result.m[inside],
        var=result.var[inside],
        n_terms=result.n_terms[inside],
        edf=result.edf[inside],
        alpha=result.alpha[inside],
    )


@keyword_only_fs
def fit(
    result_or_record: AllanResult | Record | ArrayLike,
    terms: str | Sequence[Any] = "auto",
    *,
    fs: float | None = None,
    input: str | None = None,
    method: Method = "gls",
    units: str | None = None,
    penalty: float = 9.0,
    max_fraction: float = 0.125,
    misfit_level: float = 0.001,
    min_ratio: float = 2.0,
    tau_range: tuple[float, float] | None = None,
) -> FitResult:
    r"""Fit noise terms to an Allan curve with honest uncertainty.

    The overlapping Allan variance estimates :math:`y_i` at :math:`\tau_i` are fitted by
    generalized least squares, :math:`\min (y - G\theta)^\top C^{-1} (y - G\theta)` with
    :math:`\theta \ge 0` the squared coefficients and :math:`C` the covariance of the estimates
    under the fitted model (Whittle approximation, iterated; see
    :mod:`allanite.fit.covariance` and :mod:`allanite.fit.gls`). Each term's exact sampled
    Allan variance is used, not only its asymptote.

    Parameters
    ----------
    result_or_record : AllanResult, Record or array_like
        An overlapping Allan variance (one channel), a one-channel
        :class:`~allanite.io.Record` (its ``fs``, input and unit are used) or a 1-D record
        (then ``fs`` is needed); records are analysed on the octave grid.
    terms : "auto" or list
        ``"auto"``: Q, N, B, K, R chosen by an exhaustive search over their 31 subsets
        (:mod:`allanite.fit.select`): every subset with a noise term is fitted from several
        starts (diagonal EDF weights, the slope-method readouts, a better subset's fit);
        among the subsets the goodness-of-fit test does not reject, the lowest penalized
        Gaussian -2 log-likelihood ``chi2 + log det C + penalty * parameters`` wins (so absent
        terms are not invented); only when every subset is rejected is the best one with a
        model discrepancy returned, and ``FitResult.rejected`` says so. A chosen ramp must
        also lower the chi-square by ``penalty`` against the rate random walk under the
        no-ramp covariance, else K is kept (the ramp, without variance of its own, wins the
        likelihood where the two cannot be told apart); symmetrically, a left-out term that
        lowers the chi-square by ``penalty`` under the chosen model's covariance is added
        (a noise term's ``log det C`` made the score ask more of it). Every evaluated
        subset is in ``FitResult.meta["subsets"]``, the per-term gains in
        ``FitResult.selection``.
        Or a list of names (``"white"``/``"N"``, ``"quantization"``/``"Q"``, ``"flicker"``/
        ``"B"``, ``"rrw"``/``"K"``, ``"ramp"``/``"R"``, ``"markov"``, ``"sine"``), Term classes,
        or Term instances (starting values; a Flicker's ``f0`` is kept); a string with
        commas is a list (``"N,B,K"``). The sensor's output filter
        (:class:`~allanite.terms.LowPassWhite`, in place of white noise: it carries the
        unfiltered sensor's ``N``) by its kind: ``"lowpass"``/``"rc"``, ``"one_pole"``,
        ``"butterworth"``/``"butterworth4"``, ``"moving_average"``, ``"bartlett"``.
        Plain ``"auto"`` tries the one-pole and moving-average filters in place of white
        noise when the curve starts flatter than white noise and falls under the power-law
        fit at its shortest taus, as a sensor filter's roll-off does, and keeps the first the
        test accepts (:mod:`allanite.fit.filters`); ``"auto+filter"`` tries these and
        Butterworth 2 and 4 on every curve; ``"auto+markov"``, ``"auto+sine"``,
        ``"auto+<filter kind>"`` add candidates.
    fs : float, optional
        Sampling frequency in Hz (records only).
    input : {"rate", "increment", "angle"}, optional
        What a record holds (default ``"rate"``, or the Record's own).
    method : {"gls", "seed"}
        ``"gls"`` (default) or ``"seed"``, the original program's unweighted nonlinear least
        squares on sigma^2 with five squared coefficients and 95 % bounds (always the five
        power-law terms).
    units : str, optional
        Rate unit of the data, an angular rate or an acceleration (default: the result's
        units, else the record unit ``"unit"``: coefficients in the record's own unknown
        unit, which converts to no physical unit).
    penalty : float
        Penalty per parameter of ``"auto"`` (9: a term must lower the chi-square by about
        three standard errors squared).
    max_fraction : float
        Points with ``m > max_fraction * N`` are left out of the GLS fit: with fewer than about
        two independent differences their spread is not captured by the approximation.

    misfit_level : float
        When the terms alone are rejected at this level (generalized chi-square p-value), the
        model is misspecified for this curve (e.g. a sensor's digital filter at short tau):
        a relative model discrepancy ``delta`` per tau is then added to the covariance by
        the Paule-Mandel rule (chi-square = dof), so the coefficients follow the whole curve
        instead of the most precise points and their intervals carry the model error.
        ``FitResult.discrepancy`` reports ``delta``, ``chi2``/``p_value`` stay those of the
        terms' own best fit (the test that rejected them) and ``FitResult.misfit`` flags the
        taus the model misses. 0 switches the discrepancy off.
    min_ratio : float
        The GLS fit uses, from the shortest tau up, only taus at least this factor above the
        previous one used (2: octave spacing; a 100-point log grid is fitted on its
        octave-like subset, in seconds, with the same result as the octave grid; the same
        terms and a covariance with condition number below 1e6 for 10 to 1000 points). 1 uses
        every tau: then neighbouring estimates correlate almost perfectly, the covariance is
        nearly singular and the fit leans on the differences between neighbours, which the
        approximation of the covariance does not capture (on a 1e6-sample Q + N + K record
        with 85 log points it chose B + R instead of K); values below about 1.5 are not
        recommended.

    Returns
    -------
    FitResult
        Model, coefficients with ``value``, ``stderr`` and ``ci(level)``, goodness of fit,
        residuals, the IEEE slope-method readouts (``classic``).

    Warns
    -----
    ImplausibleInputWarning
        Coefficients outside any real sensor's range, e.g. a deg/h record given as deg/s
        (:func:`allanite.plausibility.check_coefficients`, the check ``allanite fit`` prints).

    Raises
    ------
    ValueError
        Unknown term names, too few taus for the terms, all-NaN or negative variances, a
        multi-channel result, a non-overlapping result with ``method="gls"``.

    References
    ----------
    IEEE Std 952-1997 Annex C; IEEE Std 1431-2004; C. A. Greenhall and W. J. Riley,
    "Uncertainty of stability variances based on finite differences" (2003); N. El-Sheimy,
    H. Hou and X. Niu, "Analysis and modeling of inertial sensors using Allan variance",
    IEEE Trans. Instrum. Meas. 57 (2008).
    """
    if method not in ("gls", "seed"):
        raise ValueError(f"unknown method {method!r}; use 'gls' or 'seed'")
    if not (isinstance(penalty, (int, float)) and penalty >= 0):
        raise ValueError(f"penalty must be a non-negative number, got {penalty!r}")
    if not (isinstance(misfit_level, (int, float)) and 0.0 <= misfit_level < 1.0):
        raise ValueError(f"misfit_level must lie in [0, 1), got {misfit_level!r}")
    if not (isinstance(min_ratio, (int, float)) and min_ratio >= 1.0):
        raise ValueError(f"min_ratio must be a number >= 1 (2: octave spacing), got {min_ratio!r}")
    if not 0.0 < max_fraction <= 0.5:
        raise ValueError(f"max_fraction must lie in (0, 0.5], got {max_fraction!r}")
    resolved = resolve_terms(terms)
    window = _check_tau_range(tau_range)
    result = _curve(result_or_record, fs, input, units, method)
    # no silent deg/s: a curve without a unit is fitted in the record's own unit
    rate = rate_unit(units or result.units or RECORD_UNIT).text
    if method == "seed":
        fitted = _fit_seed(result, rate)
    else:
        fitted = _fit_gls(
            result if window is None else _restrict(result, window),
            resolved,
            rate,
            float(penalty),
            float(max_fraction),
            float(misfit_level),
            float(min_ratio),
        )
    # the wrong-units check the CLI prints, one implementation
    names = result.meta.get("channels") or ["ch0"]
    warn_coefficients(
        fitted.model.coefficients(), rate, input="rate", channel=str(names[0]), stacklevel=3
    )
    return fitted
