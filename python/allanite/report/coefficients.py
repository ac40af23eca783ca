"""Noise coefficients of a fit in customary units, with their intervals, for tables.

Gyro datasheets quote angle random walk in deg/√h, bias instability in deg/h, rate random
walk in deg/h/√h, quantization in the angle unit and rate ramp in deg/h² (IEEE Std 952). The
conversion is :func:`allanite.units.display_unit` with the rate unit ``<angle>/h``; the values
and intervals come from :meth:`allanite.fit.FitResult.table` (or, for a bare
:class:`~allanite.model.NoiseModel`, from its coefficients, without intervals).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from allanite.datasheet import Measured
from allanite.units import ANGLE_UNITS, Unit, coefficient_unit, convert, display_unit

__all__ = ["Coefficient", "coefficient_table", "customary_rate"]

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
        """As a :class:`~allanite.datasheet.Measured` for limit checks."""
        return Measured(self.value, self.low, self.high, self.unit, self.model_unit)


def customary_rate(rate: str | None) -> str | None:
    """Rate unit whose :func:`~allanite.units.display_unit` s are the customary ones.

    ``deg/s`` gives ``deg/h`` (N in deg/√h, B in deg/h, K in deg/h/√h, R in deg/h²); None when
    the angle unit of ``rate`` is not recognised (then the model's units are kept).
    """
    if rate is None:
        return None
    angle = rate.split("/")[0].strip()
    return f"{angle}/h" if angle in ANGLE_UNITS else None


def _unit(rate: str | None, label: str, fallback: str) -> str:
    if rate is None:
        return fallback
    try:
        return display_unit(rate, label)
    except ValueError:
        return fallback


def coefficient_table(fit: Any, rate: str | None, level: float = 0.683) -> list[Coefficient]:
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
    list of Coefficient
    """
    model = getattr(fit, "model", fit)
    units = getattr(model, "units", None)
    model_rate = units.get("rate") if isinstance(units, dict) else rate
    show = customary_rate(model_rate)
    labelled = {label: (term, spec) for label, term, spec in model.labelled_parameters()}
    rows: list[Coefficient] = []
    if hasattr(fit, "table") and hasattr(fit, "coefficients"):
        for row in fit.table(None, level):
            label = row["name"]
            term, spec = labelled.get(label, (None, None))
            unit = _unit(show, label, row["unit"])
            values = [convert(row[k], row["unit"], unit) for k in ("value", "low", "high")]
            rows.append(
                Coefficient(
                    term=getattr(term, "type", label),
                    symbol=label,
                    value=values[0],
                    low=values[1],
                    high=values[2],
                    unit=unit,
                    slope=_SLOPES.get(label),
                    model_unit=_model_unit(model_rate, spec, row["unit"]),
                )
            )
        return rows
    for label, (term, spec) in labelled.items():
        base = _model_unit(model_rate, spec, None)
        value = float(getattr(term, spec.name))
        unit = _unit(show, label, str(base.text) if base is not None else "model units")
        if base is not None and unit != "model units":
            value = convert(value, base, unit)
        rows.append(
            Coefficient(
                term=term.type,
                symbol=label,
                value=value,
                low=math.nan,
                high=math.nan,
                unit=unit,
                slope=_SLOPES.get(label) if spec.name == term.symbol else None,
                model_unit=base,
            )
        )
    return rows


def _model_unit(rate: str | None, spec: Any, text: str | None) -> Unit | None:
    """Return the unit of a coefficient in the model: ``rate^r * s^t``."""
    if text is not None:
        from allanite.units import parse_unit

        try:
            return parse_unit(text)
        except ValueError:
            pass
    if rate is None or spec is None:
        return None
    return coefficient_unit(rate, spec.rate, spec.time)
