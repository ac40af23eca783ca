"""Noise coefficients of a fit in customary units, with their intervals, for tables.

Gyro datasheets quote angle random walk in deg/√h, bias instability in deg/h, rate random
walk in deg/h/√h, quantization in the angle unit and rate ramp in deg/h² (IEEE Std 952).
A coefficient whose unit is ``rate^r * s^t`` (see :class:`allanite.terms.base.ParamSpec`) is
therefore shown as ``angle^r * h^(t - r)``; parameters without a rate power (correlation
times, frequencies) stay in seconds and hertz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from allanite.report.datasheet import Measured
from allanite.units import ANGLE_UNITS, Unit, coefficient_unit, convert

__all__ = ["Coefficient", "coefficient_table", "customary_unit"]

_HOUR_SUFFIX = {0.0: "", -0.5: "/sqrt(h)", -1.0: "/h", -1.5: "/h/sqrt(h)", -2.0: "/h^2"}
_SLOPES = {"Q": "−1", "N": "−1/2", "B": "0", "K": "+1/2", "R": "+1"}


@dataclass(frozen=True)
class Coefficient:
    """One fitted parameter with its interval, in a display unit."""

    term: str
    symbol: str
    value: float
    low: float
    high: float
    unit: str
    slope: str | None = None
    model_unit: Unit | None = None

    def measured(self) -> Measured:
        """As a :class:`~allanite.report.datasheet.Measured` for limit checks."""
        return Measured(self.value, self.low, self.high, self.unit, self.model_unit)


def _angle_of(rate: str) -> str | None:
    head = rate.split("/")[0].strip()
    return head if head in ANGLE_UNITS else None


def customary_unit(rate: str | None, rate_power: float, time_power: float) -> str | None:
    """Customary display unit of a coefficient, or None to keep the model's unit.

    Parameters
    ----------
    rate : str or None
        Rate unit of the model (``deg/s``, ``rad/s``, ...).
    rate_power, time_power : float
        Powers of the rate and of seconds in the coefficient's unit.
    """
    if rate_power == 0:
        return {1.0: "s", -1.0: "Hz", 0.0: ""}.get(time_power)
    angle = None if rate is None else _angle_of(rate)
    if angle is None or rate_power != 1:
        return None
    return angle + _HOUR_SUFFIX[time_power - 1.0] if time_power - 1.0 in _HOUR_SUFFIX else None


def _fit_parts(fit: Any) -> tuple[Any, dict[str, tuple[float, float]]]:
    """Split a fit result (or a bare model) into the model and {key: (low, high)}."""
    model = getattr(fit, "model", fit)
    intervals: dict[str, tuple[float, float]] = {}
    interval = getattr(fit, "intervals", None)
    if callable(interval):
        intervals = dict(interval())
    elif isinstance(interval, dict):
        intervals = dict(interval)
    return model, intervals


def coefficient_table(fit: Any, rate: str | None) -> list[Coefficient]:
    """Rows of every parameter of a fitted model in customary units.

    Parameters
    ----------
    fit : FitResult or NoiseModel
        Anything with ``model.terms`` or ``terms``; intervals come from the fit's ``intervals``
        (``{"<type>.<param>": (low, high)}`` in model units) when present.
    rate : str or None
        Rate unit of the data; the model's own ``units["rate"]`` wins when present.

    Returns
    -------
    list of Coefficient
    """
    model, intervals = _fit_parts(fit)
    units = getattr(model, "units", None)
    model_rate = units.get("rate") if isinstance(units, dict) else rate
    rows = []
    for term in model.terms:
        for spec in term.params:
            value = float(getattr(term, spec.name))
            low, high = intervals.get(f"{term.type}.{spec.name}", (math.nan, math.nan))
            target = customary_unit(model_rate, spec.rate, spec.time)
            base = (
                None if model_rate is None else coefficient_unit(model_rate, spec.rate, spec.time)
            )
            if model_rate is not None and target:
                source = coefficient_unit(model_rate, spec.rate, spec.time)
                value, low, high = (convert(v, source, target) for v in (value, low, high))
                unit = target
            else:
                unit = (
                    target
                    if target is not None
                    else (f"({model_rate or 'rate'})^{spec.rate:g}·s^{spec.time:g}")
                )
            rows.append(
                Coefficient(
                    term=term.type,
                    symbol=spec.name,
                    value=value,
                    low=low,
                    high=high,
                    unit=unit,
                    slope=_SLOPES.get(spec.name) if spec.name == term.symbol else None,
                    model_unit=base,
                )
            )
    return rows
