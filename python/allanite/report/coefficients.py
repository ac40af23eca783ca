"""Noise coefficients of a fit in customary units, with their intervals, for tables.

Gyro datasheets quote angle random walk in deg/√h, bias instability in deg/h, rate random
walk in deg/h/√h, quantization in the angle unit and rate ramp in deg/h² (IEEE Std 952);
accelerometer datasheets quote velocity random walk in m/s/√h, bias instability in µg,
acceleration random walk in m/s²/√s (= m/s³/√Hz, the simulators' bias random-walk density),
velocity quantization in m/s. The choice is
:func:`allanite.units.customary_unit`, the names come from each parameter's
:class:`~allanite.terms.base.ParamSpec` for the model's sensor; the values and intervals come
from :meth:`allanite.fit.FitResult.table` (or, for a bare :class:`~allanite.model.NoiseModel`,
from its coefficients, without intervals). A model in the record unit (a record without a
unit) keeps its coefficients in record units (``unit*sqrt(s)``, ...).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from allanite.confidence import DEFAULT_LEVEL
from allanite.datasheet import Measured
from allanite.units import (
    Unit,
    coefficient_unit,
    convert,
    customary_gyro_rate,
    customary_unit,
    parse_unit,
    sensor_kind,
)

__all__ = ["CoefficientRow", "ambiguous_rows", "coefficient_table", "customary_rate"]

_SLOPES = {"Q": "−1", "N": "−1/2", "B": "0", "K": "+1/2", "R": "+1"}


@dataclass(frozen=True)
class CoefficientRow:
    """One row of the report's coefficient table: a fitted parameter and interval, displayed.

    Not :class:`allanite.fit.Coefficient` (the fitted value with its standard error, in the
    model's units): this is that value converted to a display unit, with its name and level.

    ``quantity`` is its customary name for the model's sensor (``angle random walk`` for a
    gyro's N, ``velocity random walk`` for an accelerometer's) and ``sensor`` that sensor
    (``gyro``, ``accelerometer`` or ``unknown`` for a record without a unit).
    """

    term: str
    symbol: str
    value: float
    low: float
    high: float
    unit: str
    slope: str | None = None
    model_unit: Unit | None = None
    quantity: str = ""
    sensor: str = "gyro"

    def measured(self) -> Measured:
        """As a :class:`~allanite.datasheet.Measured` for limit checks."""
        return Measured(self.value, self.low, self.high, self.unit, self.model_unit)


def customary_rate(rate: str | None) -> str | None:
    """Gyro rate unit whose :func:`~allanite.units.display_unit` s are the customary ones.

    :func:`allanite.units.customary_gyro_rate`: ``deg/s`` and ``rad/s`` give ``deg/h`` (N in
    deg/√h, B in deg/h, K in deg/h/√h, R in deg/h²); None when ``rate`` is not an angular
    rate (accelerometers use :func:`allanite.units.customary_unit`).
    """
    return customary_gyro_rate(rate)


def _sensor(rate: str | None) -> str:
    if rate is None:
        return "unknown"
    try:
        return sensor_kind(rate)
    except ValueError:
        return "unknown"


def _customary(rate: str | None, label: str, unit: Unit | None, fallback: str) -> str:
    if rate is None or unit is None:
        return fallback
    try:
        return customary_unit(rate, label, unit)
    except ValueError:
        return fallback


def coefficient_table(
    fit: Any, rate: str | None, level: float = DEFAULT_LEVEL
) -> list[CoefficientRow]:
    """Rows of every coefficient of a fit (or model) in customary units.

    Parameters
    ----------
    fit : FitResult or NoiseModel
        A fit gives values with ``level`` intervals; a bare model gives values only.
    rate : str or None
        Rate unit of the data; the model's own ``units["rate"]`` wins when present.
    level : float
        Confidence level of the intervals.

    Returns
    -------
    list of CoefficientRow
    """
    model = getattr(fit, "model", fit)
    units = getattr(model, "units", None)
    model_rate = units.get("rate") if isinstance(units, dict) else rate
    sensor = _sensor(model_rate)
    labelled = {label: (term, spec) for label, term, spec in model.labelled_parameters()}
    rows: list[CoefficientRow] = []
    if hasattr(fit, "table") and hasattr(fit, "coefficients"):
        for row in fit.table(None, level):
            label = row["name"]
            term, spec = labelled.get(label, (None, None))
            own = _model_unit(model_rate, spec, row["unit"])
            unit = _customary(model_rate, label, own, row["unit"])
            values = [convert(row[k], row["unit"], unit) for k in ("value", "low", "high")]
            rows.append(
                CoefficientRow(
                    term=getattr(term, "type", label),
                    symbol=label,
                    value=values[0],
                    low=values[1],
                    high=values[2],
                    unit=unit,
                    slope=_SLOPES.get(label),
                    model_unit=own,
                    quantity=spec.describe(sensor) if spec is not None else label,
                    sensor=sensor,
                )
            )
        return rows
    for label, (term, spec) in labelled.items():
        base = _model_unit(model_rate, spec, None)
        value = float(getattr(term, spec.name))
        unit = _customary(model_rate, label, base, base.text if base is not None else "model units")
        if base is not None and unit != "model units":
            value = convert(value, base, unit)
        rows.append(
            CoefficientRow(
                term=term.type,
                symbol=label,
                value=value,
                low=math.nan,
                high=math.nan,
                unit=unit,
                slope=_SLOPES.get(label) if spec.name == term.symbol else None,
                model_unit=base,
                quantity=spec.describe(sensor),
                sensor=sensor,
            )
        )
    return rows


def _model_unit(rate: str | None, spec: Any, text: str | None) -> Unit | None:
    """Return the unit of a coefficient in the model: ``rate^r * s^t``."""
    if text is not None:
        try:
            return parse_unit(text)
        except ValueError:
            pass
    if rate is None or spec is None:
        return None
    return coefficient_unit(rate, spec.rate, spec.time)


def ambiguous_rows(
    fit: Any, rate: str | None, level: float = DEFAULT_LEVEL
) -> list[CoefficientRow]:
    """Rows of the terms a fit printed AMBIGUOUS, for the coefficient table (marked there).

    Each is the swapped-in coefficient of :meth:`allanite.fit.FitResult.ambiguous` with its
    interval, in customary units; its ``quantity`` starts with ``AMBIGUOUS:``. Not part of
    :func:`coefficient_table` (datasheet checks judge the chosen model only).
    """
    alternatives = getattr(fit, "ambiguous", None)
    if alternatives is None:
        return []
    model_rate = fit.model.units.get("rate") if isinstance(fit.model.units, dict) else rate
    sensor = _sensor(model_rate)
    rows = []
    for alt in alternatives():
        symbol = alt["symbol_in"]
        coef = fit.exchangeable[symbol]
        own = _model_unit(model_rate, None, coef.unit)
        unit = _customary(model_rate, symbol, own, coef.unit)
        low, high = coef.ci(level)
        values = [convert(v, coef.unit, unit) for v in (coef.value, low, high)]
        rows.append(
            CoefficientRow(
                term=str(alt["swap_in"]),
                symbol=symbol,
                value=values[0],
                low=values[1],
                high=values[2],
                unit=unit,
                slope=_SLOPES.get(symbol),
                model_unit=own,
                quantity=f"AMBIGUOUS: {alt['swap_in']}"
                + (f" (or {alt['symbol_out']})" if alt["symbol_out"] is not None else ""),
                sensor=sensor,
            )
        )
    return rows
