"""Result objects of a fit: coefficients with intervals, goodness of fit, tables, comparisons."""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from allanite.confidence import DEFAULT_LEVEL
from allanite.fit.classic import ClassicReadout
from allanite.model import NoiseModel
from allanite.notebook import fit_html
from allanite.terms import LowPassWhite
from allanite.units import convert, customary_unit, display_unit, parse_unit

__all__ = ["NO_EVIDENCE_CHI2", "Coefficient", "Comparison", "ComparisonRow", "FitResult"]

#: an addition lowering the chi-square by less than this (one standard deviation of a
#: one-parameter improvement) is shown as "not detected", not AMBIGUOUS (display only)
NO_EVIDENCE_CHI2 = 1.0


@dataclass(frozen=True)
class Coefficient:
    """A fitted coefficient in the model's units.

    Attributes
    ----------
    name : str
        Label (``N``, ``B``, ``sigma``, ``tau_c_2``, ...).
    value : float
        Estimate (for amplitudes the square root of the non-negative squared amplitude).
    stderr : float
        Standard error (delta method; for an amplitude near zero, the square root of the
        squared amplitude's standard error).
    unit : str
        Unit of ``value`` (the model's rate unit raised to the parameter's powers).
    """

    name: str
    value: float
    stderr: float
    unit: str
    interval: Callable[[float], tuple[float, float]] = field(repr=False, compare=False)

    def ci(self, level: float = DEFAULT_LEVEL) -> tuple[float, float]:
        """Two-sided confidence interval ``(low, high)`` at ``level`` (e.g. 0.95)."""
        if not 0.0 < level < 1.0:
            raise ValueError(f"level must lie in (0, 1), got {level}")
        return self.interval(level)


@dataclass(frozen=True)
class ComparisonRow:
    """One coefficient compared with a datasheet limit or a reference value."""

    name: str
    unit: str
    value: float
    low: float
    high: float
    reference: float
    kind: str  # "limit" or "reference"
    passed: bool | None
    conclusive: bool


@dataclass(frozen=True)
class Comparison:
    """Per-coefficient comparison (see :meth:`FitResult.compare`)."""

    rows: tuple[ComparisonRow, ...]
    level: float

    @property
    def passed(self) -> bool:
        """True when every datasheet limit is met (reference rows do not count)."""
        return all(r.passed is not False for r in self.rows)

    def format(self) -> str:
        """Plain-text table."""
        head = f"{'coef':<8}{'value':>12}{'low':>12}{'high':>12}{'ref':>12}  {'unit':<16}verdict"
        lines = [head]
        for r in self.rows:
            if r.kind == "limit":
                verdict = "PASS" if r.passed else "FAIL"
                if not r.conclusive:
                    verdict += " (limit inside the interval)"
            else:
                verdict = "consistent" if r.conclusive is False else "differs"
            lines.append(
                f"{r.name:<8}{r.value:>12.4g}{r.low:>12.4g}{r.high:>12.4g}{r.reference:>12.4g}  "
                f"{r.unit:<16}{verdict}"
            )
        return "\n".join(lines)


@dataclass(frozen=True, repr=False)
class FitResult:
    r"""A fitted noise model with honest uncertainty.

    Attributes
    ----------
    model : NoiseModel
        The fitted model (coefficients in ``model.units``).
    coefficients : dict of str to Coefficient
        By label: Q, N, B, K, R; sigma and tau_c of each Gauss-Markov term, amplitude and
        frequency of each sinusoid (suffixed ``_1``, ``_2`` when a type repeats).
    chi2, dof, p_value : float, int, float
        Generalized chi-square :math:`r^\top C^{-1} r` with the covariance :math:`C` of the
        AVAR estimates under the fitted model (so the correlation between taus is accounted
        for), its degrees of freedom (points - parameters) and upper-tail p-value. For
        ``method="seed"``: the unweighted sum of squares, no p-value (NaN).
    tau, var, fitted : numpy.ndarray
        The points used, the data and the fitted Allan variance there.
    residuals : numpy.ndarray
        Standardised residuals ``(var - fitted) / sqrt(diag C)`` with ``C`` the covariance
        under the fitted terms alone (without the discrepancy), so a misfit shows where it is.
    cov : numpy.ndarray
        Covariance of the AVAR estimates the fit used (``(T, T)``): under the fitted model,
        plus ``discrepancy**2 * diag(var**2)`` when the terms alone were rejected.
    method : str
        ``"gls"`` or ``"seed"``.
    classic : ClassicReadout
        The IEEE slope-method readouts of the same curve (labelled, no uncertainty).
    selection : tuple of dict
        For ``terms="auto"``: each candidate with ``score_gain``, how much the penalized
        -2 log-likelihood drops when the term is added to the chosen terms without it
        (positive for a kept term), and whether it was kept; when a ramp was chosen, its
        entry also holds ``ramp_test`` (``alternative``, ``delta_chi2``, ``kept``: the ramp's
        significance against the rate random walk); a term added by the mirror test (its
        chi-square drop under the chosen model's covariance reached the penalty although
        the score alone left it out) holds ``added`` (``delta_chi2``). ``meta["subsets"]``
        lists every subset evaluated by the search (:mod:`allanite.fit.select`) with its
        score, chi2, p-value and whether it is rejected.
    discrepancy : float
        Relative model discrepancy :math:`\delta` per tau (Paule-Mandel, see
        :func:`allanite.fit.gls.solve`): 0 when the terms fit the curve; otherwise the
        coefficients' intervals include this model error and ``p_value`` is below
        ``misfit_level``.
    misfit_level : float
        The significance level of the misfit test (``p_value``) and, Bonferroni-corrected
        over the taus, of the per-tau flags :attr:`misfit`.
    alternatives : tuple of dict
        For ``terms="auto"``: the subsets that swap one chosen term for another candidate
        at a score within the selection's penalty (the record cannot tell them apart;
        :func:`allanite.fit.select._exchangeable`), each with ``terms``, ``swap_out``,
        ``swap_in`` (term types), ``symbol_out``, ``symbol_in``, ``score_delta``,
        ``p_value``, ``delta_chi2`` for an addition (``swap_out`` None: a term left out
        that the data show some of, not enough to select it) and ``taus`` (the first and
        last tau where the alternative term carries more than a fifth of the alternative's
        variance). When there are any, the chosen
        exchangeable terms' intervals are the hull of their own and those of the fit with
        all the exchangeable terms (see :meth:`ambiguity_note`).
    exchangeable : dict of str to Coefficient
        The swapped-in terms' coefficients from that union fit (not part of :attr:`model`).
    undetected : dict of str to Coefficient
        For ``terms="auto"``: every other candidate left out, from the fit with it (not part
        of :attr:`model`): the upper end of its interval bounds what the record allows of a
        term it does not show (:meth:`undetected_line`).
    """

    model: NoiseModel
    coefficients: dict[str, Coefficient]
    chi2: float
    dof: int
    p_value: float
    tau: NDArray[np.float64]
    var: NDArray[np.float64]
    fitted: NDArray[np.float64]
    residuals: NDArray[np.float64]
    cov: NDArray[np.float64]
    method: str
    classic: ClassicReadout
    selection: tuple[dict[str, Any], ...] = ()
    meta: dict[str, Any] = field(default_factory=dict, compare=False)
    discrepancy: float = 0.0
    misfit_level: float = 0.001
    alternatives: tuple[dict[str, Any], ...] = ()
    exchangeable: dict[str, Coefficient] = field(default_factory=dict, compare=False)
    undetected: dict[str, Coefficient] = field(default_factory=dict, compare=False)
    _repr_html_ = fit_html  # Jupyter: a compact table and the plot (allanite.notebook)

    def __repr__(self) -> str:
        """Compact: the terms with values, intervals and units, and the goodness of fit.

        E.g. ``FitResult(gls, 24 taus 0.01-1.3e+03 s: N = 0.151 [0.148, 0.154] deg/sqrt(h),
        K = 0.52 [0.41, 0.63] deg/h/sqrt(h); chi2 = 21.3 for 22 dof, p = 0.5)`` (95 %
        intervals, customary units as :meth:`format_table`); the arrays are attributes.
        """
        taus = (
            f"{self.tau.size} taus {self.tau[0]:.3g}-{self.tau[-1]:.3g} s"
            if self.tau.size
            else "no taus"
        )
        try:
            rows = self.table("customary")
        except ValueError:  # a model unit without customary units
            rows = self.table(None)
        terms = ", ".join(
            f"{r['name']} = {r['value']:.3g} [{r['low']:.3g}, {r['high']:.3g}] {r['unit']}"
            for r in rows
        )
        fit = (
            f"; chi2 = {self.chi2:.3g} for {self.dof} dof, p = {self.p_value:.3g}"
            + (" (rejected)" if self.rejected else "")
            if self.method == "gls"
            else ""
        )
        return f"FitResult({self.method}, {taus}: {terms or 'no terms'}{fit})"

    @property
    def misspecified(self) -> bool:
        """True when the goodness-of-fit test rejects the model at ``misfit_level``."""
        return self.method == "gls" and bool(self.p_value < self.misfit_level)

    @property
    def rejected(self) -> bool:
        """True when the fitted model is rejected by its goodness-of-fit test.

        The generalized chi-square p-value is below ``misfit_level`` (0.001 by default):
        the model does not describe the Allan curve within the estimates' uncertainty, and
        the coefficients should not be used without looking at :attr:`missed_taus`. With
        ``terms="auto"`` this happens only when no subset of the candidate terms fits.
        """
        return self.misspecified

    @property
    def missed_taus(self) -> NDArray[np.float64]:
        """The taus (seconds) the model misses singly (see :attr:`misfit`)."""
        return np.asarray(self.tau[self.misfit], dtype=np.float64)

    def goodness_line(self, level: float = DEFAULT_LEVEL) -> str:
        """One line: interval level, generalized chi-square, p, and whether rejected.

        Empty for ``method="seed"`` (no goodness-of-fit test).
        """
        if self.method != "gls":
            return ""
        text = (
            f"brackets: {100 * level:g} % intervals; chi2 = {self.chi2:.3g} for {self.dof} dof "
            f"(correlated GLS), p = {self.p_value:.3g}"
        )
        lines = (self.filter_line(), self.ambiguity_note(level), self.undetected_line(level))
        note = "\n".join(x for x in lines if x)
        note = "\n" + note if note else ""
        if not self.rejected:
            return text + ": model not rejected" + note
        return text + "\n" + self.rejection_warning() + note

    def filter_line(self) -> str:
        """The sensor output filter the model holds, named with its bandwidth (else empty).

        E.g. ``sensor output filter: first-order (digital) low-pass, -3 dB at 2.01 Hz: ...``;
        the fit's coefficients are then the unfiltered sensor's, and the curve's roll-off at
        the short taus is the filter's, not a noise term.
        """
        fs = self.meta.get("fs")
        for term in self.model.terms:
            if isinstance(term, LowPassWhite):
                dt = 1.0 / fs if fs else None
                return (
                    f"sensor output filter: {term.describe_filter(dt)}: the coefficients are "
                    f"the unfiltered sensor's; the curve's roll-off below tau ~ "
                    f"{10.0 * term.tau_f:.3g} s is the filter's, not a noise term"
                )
        return ""

    def ambiguity_note(self, level: float = DEFAULT_LEVEL) -> str:
        """One line per alternative the record cannot tell from the chosen terms (else empty).

        E.g. ``AMBIGUOUS: flicker B = 0.0039 [0, 0.015] deg/h fits the excess at tau =
        328-1.31e+03 s as well as K ...: the record cannot tell them apart ...``. An addition
        the record shows no evidence of (zero estimate, or a chi-square drop below
        :data:`NO_EVIDENCE_CHI2`) is not ambiguous: it is listed
        with its upper limit by :meth:`undetected_line` instead, which keeps the text short
        (a six-axis file of white noise would otherwise print a dozen such lines); the JSON
        (:meth:`alternatives_dict`) keeps every alternative with its note.
        """
        return "\n".join(self._alternative_note(alt, level) for alt in self.ambiguous())

    def ambiguous(self) -> list[dict[str, Any]]:
        """The alternatives printed AMBIGUOUS (:meth:`ambiguity_note`), as in ``alternatives``.

        Those whose swapped-in coefficient was fitted (``exchangeable``) and that are not an
        addition the record shows no evidence of.
        """
        return [
            alt
            for alt in self.alternatives
            if alt["symbol_in"] in self.exchangeable and not self._shows_nothing(alt)
        ]

    def _shows_nothing(self, alt: dict[str, Any]) -> bool:
        """An alternative the record shows no evidence of.

        Its term's estimate is zero (swapped in, "B = 0 fits the excess as well as K" says
        nothing: the chosen term's own interval reaching 0 says it), or, an addition (no
        term swapped out), it lowers the chi-square by less than 1 (less than one standard
        deviation of a one-parameter improvement: noise).
        """
        coef = self.exchangeable.get(alt["symbol_in"])
        if coef is None:
            return False
        if not coef.value > 0:
            return True
        drop = alt.get("delta_chi2")
        addition = alt["symbol_out"] is None
        return addition and drop is not None and float(drop) < NO_EVIDENCE_CHI2

    def _alternative_note(self, alt: dict[str, Any], level: float) -> str:
        """The text line of one alternative (its swapped-in term in customary units)."""
        symbol, out = alt["symbol_in"], alt["symbol_out"]
        coef = self.exchangeable[symbol]
        unit = customary_unit(self.model.units["rate"], symbol, coef.unit)
        factor = _factor(coef, unit)
        lo, hi = coef.ci(level)
        t1, t2 = alt["taus"]
        where = f"{t1:.3g}" if t1 == t2 else f"{t1:.3g}-{t2:.3g}"
        head = (
            f"AMBIGUOUS: {alt['swap_in']} {symbol} = {coef.value * factor:.4g} "
            f"[{lo * factor:.4g}, {hi * factor:.4g}] {unit}"
        )
        if out is None:
            return (
                f"{head} may be present at tau = {where} s (chi2 drop "
                f"{alt['delta_chi2']:.3g}, too small to select it); intervals from the fit "
                "with it"
            )
        return (
            f"{head} fits the excess at tau = {where} s as well as {out} (score "
            f"{alt['score_delta']:+.3g}, within the penalty): the record cannot tell them "
            "apart; intervals from the fit with both"
        )

    def undetected_line(self, level: float = DEFAULT_LEVEL) -> str:
        """One line of upper limits of the candidates not detected (empty when none).

        The terms of :attr:`undetected` and the alternatives the record shows no evidence of
        (see :meth:`ambiguity_note`), in the order Q, N, B, K, R, customary units.
        """
        parts = [f"{s} <= {hi:.3g} {unit}" for s, (hi, unit) in self.upper_limits(level).items()]
        if not parts:
            return ""
        return f"not detected ({100 * level:g} % upper limits): " + ", ".join(parts)

    def upper_limits(self, level: float = DEFAULT_LEVEL) -> dict[str, tuple[float, str]]:
        """Upper limits of the candidates not detected, in customary units.

        The terms of :attr:`undetected` and the alternatives the record shows no evidence of
        (see :meth:`ambiguity_note`), in the order Q, N, B, K, R: symbol -> (upper end of the
        ``level`` interval of the fit with the term, its customary unit). What
        :meth:`undetected_line` prints and ``allanite fit --json`` gives as ``"undetected"``.
        """
        left_out = dict(self.undetected)
        for alt in self.alternatives:
            if alt["symbol_in"] in self.exchangeable and self._shows_nothing(alt):
                left_out[alt["symbol_in"]] = self.exchangeable[alt["symbol_in"]]
        order = {s: k for k, s in enumerate("QNBKR")}
        out: dict[str, tuple[float, str]] = {}
        for symbol in sorted(left_out, key=lambda s: (order.get(s, len(order)), s)):
            coef = left_out[symbol]
            unit = customary_unit(self.model.units["rate"], symbol, coef.unit)
            out[symbol] = (float(coef.ci(level)[1] * _factor(coef, unit)), unit)
        return out

    def rejection_warning(self) -> str:
        """The plain warning of a rejected fit (empty when the fit is not rejected)."""
        if not self.rejected:
            return ""
        missed = self.missed_taus
        where = ", ".join(f"{t:.3g}" for t in missed) if missed.size else "none singly"
        text = (
            f"WARNING: model REJECTED (p = {self.p_value:.3g} < {self.misfit_level:g}): the "
            f"terms do not describe the Allan curve; missed at tau [s] = {where}"
        )
        if self.discrepancy > 0:
            text += (
                f"; intervals include a model discrepancy of {100 * self.discrepancy:.3g} % per tau"
            )
        return text

    @property
    def misfit(self) -> NDArray[np.bool_]:
        r"""Per tau: the fitted model misses the estimate (simultaneous test over the taus).

        ``|residual| > z`` with :math:`z = \Phi^{-1}(1 - \alpha / (2T))`, :math:`\alpha` =
        ``misfit_level``, ``T`` the number of points (Bonferroni). The complement is the tau
        range where the fit may be read as good. All False for ``method="seed"``.
        """
        if self.method != "gls" or self.tau.size == 0:
            return np.zeros(self.tau.size, dtype=bool)
        z = float(stats.norm.isf(self.misfit_level / (2.0 * self.tau.size)))
        return np.asarray(np.abs(self.residuals) > z)

    @property
    def good_range(self) -> tuple[float, float] | None:
        """``(tau_low, tau_high)`` of the longest run of consecutive taus the model does not miss.

        The tau range over which the fitted model may be read as describing the curve (see
        :attr:`misfit`); ties go to the longer taus. None when every tau is missed.
        """
        best: tuple[int, int] | None = None
        start = None
        flags = [*self.misfit.tolist(), True]
        for i, bad in enumerate(flags):
            if not bad and start is None:
                start = i
            elif bad and start is not None:
                if best is None or i - start >= best[1] - best[0]:
                    best = (start, i)
                start = None
        if best is None:
            return None
        return float(self.tau[best[0]]), float(self.tau[best[1] - 1])

    def __getitem__(self, name: str) -> Coefficient:
        try:
            return self.coefficients[name]
        except KeyError:
            raise KeyError(
                f"no coefficient {name!r}; this fit has {', '.join(self.coefficients)}"
            ) from None

    # --- display ----------------------------------------------------------------------------
    def _unit_for(self, name: str, units: str | Mapping[str, str] | None) -> str:
        if units is None:
            return self.coefficients[name].unit
        if units == "customary":  # as datasheets quote it, the CLI's and the report's choice
            return customary_unit(self.model.units["rate"], name, self.coefficients[name].unit)
        if isinstance(units, str):  # the coefficient's dimension shown with that rate unit
            return display_unit(units, parse_unit(self.coefficients[name].unit))
        if name in units:
            return units[name]
        base = name.rsplit("_", 1)[0] if name[-1].isdigit() else name
        return units.get(base, self.coefficients[name].unit)

    def table(
        self, units: str | Mapping[str, str] | None = None, level: float = DEFAULT_LEVEL
    ) -> list[dict[str, Any]]:
        """Coefficients as rows ``{name, value, stderr, low, high, unit}``.

        Parameters
        ----------
        units : str or mapping, optional
            A rate unit (``"deg/h"``: N in deg/sqrt(h), K in deg/h/sqrt(h), ...), a unit per
            coefficient (``{"N": "deg/sqrt(h)", "B": "deg/h"}``), or ``"customary"``: the
            units datasheets quote (:func:`allanite.units.customary_unit`, as ``allanite fit``
            prints them); default: model units.
        level : float
            Confidence level of ``low``/``high``.
        """
        rows = []
        for name, coef in self.coefficients.items():
            unit = self._unit_for(name, units)
            lo, hi = coef.ci(level)
            factor = _factor(coef, unit)
            rows.append(
                {
                    "name": name,
                    "value": coef.value * factor,
                    "stderr": coef.stderr * factor,
                    "low": lo * factor,
                    "high": hi * factor,
                    "unit": unit,
                }
            )
        return rows

    def format_table(
        self, units: str | Mapping[str, str] | None = "customary", level: float = DEFAULT_LEVEL
    ) -> str:
        """Plain-text version of :meth:`table`, with the goodness of fit.

        By default in the customary units, as ``allanite fit`` prints them (a gyro's N in
        deg/sqrt(h), B in deg/h); ``units=None`` keeps the model's units.
        """
        pct = f"{100 * level:g}%"
        lines = [
            f"{'coef':<10}{'value':>12}{'stderr':>12}{pct + ' low':>12}{pct + ' high':>12}  unit"
        ]
        for row in self.table(units, level):
            lines.append(
                f"{row['name']:<10}{row['value']:>12.4g}{row['stderr']:>12.4g}{row['low']:>12.4g}"
                f"{row['high']:>12.4g}  {row['unit']}"
            )
        if self.method == "gls":
            lines.append(self.goodness_line(level))
        return "\n".join(lines)

    def to_dict(self, level: float = DEFAULT_LEVEL) -> dict[str, Any]:
        """JSON-ready dictionary: model, coefficients with intervals, goodness of fit."""
        return {
            "method": self.method,
            "model": self.model.to_dict(),
            "coefficients": self.table(None, level),
            "level": level,
            "chi2": self.chi2,
            "dof": self.dof,
            "p_value": None if math.isnan(self.p_value) else self.p_value,
            "tau": self.tau.tolist(),
            "var": self.var.tolist(),
            "fitted": self.fitted.tolist(),
            "residuals": self.residuals.tolist(),
            "misfit": self.misfit.tolist(),
            "rejected": self.rejected,
            "missed_taus": self.missed_taus.tolist(),
            "misfit_level": self.misfit_level,
            "discrepancy": self.discrepancy,
            "good_range": self.good_range,
            "classic": {"label": self.classic.label, **self.classic.values},
            "alternatives": self.alternatives_dict(level),
            "undetected": [
                {"name": k, "value": c.value, "low": lo, "high": hi, "unit": c.unit}
                for k, c in self.undetected.items()
                for lo, hi in [c.ci(level)]
            ],
        }

    def alternatives_dict(self, level: float = DEFAULT_LEVEL) -> list[dict[str, Any]]:
        """JSON-ready :attr:`alternatives`, each with the swapped-in term's value and interval.

        ``value``, ``low`` and ``high`` are in the model's units (``unit``) and come from the
        fit with all the exchangeable terms; ``note`` is its text line (:meth:`ambiguity_note`
        prints those of the alternatives the record shows some of).
        """
        out = []
        for alt in self.alternatives:
            if alt["symbol_in"] not in self.exchangeable:
                continue
            note = self._alternative_note(alt, level)
            coef = self.exchangeable[alt["symbol_in"]]
            lo, hi = coef.ci(level)
            out.append(
                {**alt, "value": coef.value, "low": lo, "high": hi, "unit": coef.unit, "note": note}
            )
        return out

    def to_json(self, level: float = DEFAULT_LEVEL, **kwargs: Any) -> str:
        """JSON text of :meth:`to_dict`."""
        return json.dumps(self.to_dict(level), **kwargs)

    # --- comparison -------------------------------------------------------------------------
    def compare(
        self,
        reference: Mapping[str, Any] | NoiseModel | FitResult,
        *,
        level: float = DEFAULT_LEVEL,
    ) -> Comparison:
        """Compare with a datasheet (limits) or a reference device (values).

        Parameters
        ----------
        reference : mapping, NoiseModel or FitResult
            A datasheet ``{"N": (0.15, "deg/sqrt(h)"), "B": (3.0, "deg/h")}`` of upper limits
            (a bare number is in the model's units): a coefficient passes when its estimate is
            at or below the limit, and the verdict is conclusive when the whole interval lies
            on one side. Or another device's model/fit: each common coefficient is compared
            with the reference value (``conclusive`` = the reference lies outside the interval,
            i.e. the devices differ at ``level``; for a FitResult the two uncertainties are
            combined).
        level : float
            Confidence level.
        """
        rows = []
        if isinstance(reference, (NoiseModel, FitResult)):
            other = reference.model if isinstance(reference, FitResult) else reference
            ref_values = other.in_units(self.model.units["rate"]).coefficients()
            for name, coef in self.coefficients.items():
                if name not in ref_values:
                    continue
                lo, hi = coef.ci(level)
                ref = ref_values[name]
                if isinstance(reference, FitResult) and name in reference.coefficients:
                    z = float(stats.norm.ppf(0.5 + level / 2))
                    other_coef = reference.coefficients[name]
                    factor = _factor(other_coef, coef.unit)
                    spread = math.hypot(coef.stderr, other_coef.stderr * factor)
                    differs = abs(coef.value - ref) > z * spread
                else:
                    differs = not lo <= ref <= hi
                rows.append(
                    ComparisonRow(
                        name, coef.unit, coef.value, lo, hi, ref, "reference", None, differs
                    )
                )
            return Comparison(tuple(rows), level)
        if not isinstance(reference, Mapping):
            raise TypeError(
                "reference must be a datasheet mapping {'N': (limit, unit)}, a NoiseModel or a "
                f"FitResult, got {type(reference).__name__}"
            )
        for name, spec in reference.items():
            if name not in self.coefficients:
                raise ValueError(
                    f"the datasheet names {name!r} but the fit has {', '.join(self.coefficients)}"
                )
            coef = self.coefficients[name]
            if isinstance(spec, tuple):
                limit, unit = float(spec[0]), str(spec[1])
            else:
                limit, unit = float(spec), coef.unit
            factor = _factor(coef, unit)
            lo, hi = (v * factor for v in coef.ci(level))
            value = coef.value * factor
            passed = value <= limit
            conclusive = hi <= limit or lo > limit
            rows.append(
                ComparisonRow(name, unit, value, lo, hi, limit, "limit", passed, conclusive)
            )
        return Comparison(tuple(rows), level)


def _factor(coef: Coefficient, unit: str) -> float:
    """Multiplier taking ``coef`` from its unit to ``unit``."""
    return convert(1.0, coef.unit, unit)
