r"""Datasheet limits and the one pass/fail check of a measured device against them.

Used by ``allanite report``, ``allanite fit`` and :func:`allanite.batch` alike. A limits file
is JSON (or YAML, ``.yaml``/``.yml``, with the ``yaml`` extra) in either of two forms.

The full form, with units::

    {"device": "Gyro XYZ datasheet, grade A",
     "limits": [
        {"quantity": "N", "max": 0.3, "unit": "deg/sqrt(h)"},
        {"quantity": "B", "max": 10, "unit": "deg/h"},
        {"quantity": "adev", "tau": 1.0, "max": 0.01, "unit": "deg/s"}
     ]}

``quantity`` is a coefficient label of a fitted term (N, B, K, Q, R, sigma, ...) or ``adev``
(the measured Allan deviation at ``tau`` seconds, interpolated log-log). Each limit has ``max``
and/or ``min``.

The compact form, in the record's units: ``{"N": 0.01, "B": {"max": 0.003}, "K": {"min": 0,
"max": 1e-4}}`` (a number is an upper limit; values in the record's rate unit times seconds
to the term's power, e.g. N in deg/s*sqrt(s) for a record in deg/s).

Status of a check at confidence level :math:`1-\alpha` with estimate :math:`\hat x` and
interval :math:`[x_-, x_+]` (the fit's profile interval, or the Allan deviation's chi-square
interval from its EDF):

* *fail*: the estimate itself lies outside the limits (:math:`\hat x > \max` or
  :math:`\hat x < \min`);
* *marginal*: the estimate lies within but the interval crosses a limit (the data cannot
  decide at that level);
* *pass*: the whole interval lies within the limits;
* *undetermined* or *pass* for a term the fit did not select but bounds from above
  (:attr:`allanite.fit.FitResult.undetected`, the upper end :math:`u` of the interval of the
  fit with the term): *pass* when :math:`u \le \max` (whatever the term is, it meets the
  limit), *undetermined* when :math:`u > \max` (the record neither shows the term nor rules
  out a value above the limit: a longer record decides). Against a positive ``min`` it
  *fails* when :math:`u < \min` and is *undetermined* otherwise. Shown as ``NOT DETERMINED
  (<= u)``; the check's ``high`` and ``upper`` hold :math:`u`, ``value`` and ``low`` are None;
* *missing*: the quantity was not measured and has no upper limit either (an explicit term
  list without it, or ``tau`` outside the measured range). A coefficient whose term the fit
  did not select shows no sign of that term, so it *fails* a positive ``min``; otherwise
  *missing* does not fail.

Exit codes (``allanite fit``, ``report``, ``batch``): only *fail* fails (exit 1). *marginal*
and *undetermined* are undecided, not failed: exit 0, but :func:`verdict` ranks them above
*pass* (``fail`` > ``marginal`` > ``undetermined`` > ``pass``), the tables show them in
capitals and the JSON/CSV carry the status, so a production gate that wants proof of
conformity requires ``status == "pass"``.

References: IEEE Std 952-1997 annex C (reading noise coefficients off an Allan plot);
ISO/IEC Guide 98-4:2012 (JCGM 106), conformity decisions with measurement uncertainty.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from allanite.errors import InputError, parse_json
from allanite.extras import require
from allanite.units import convert, parse_unit, sensor_kind

__all__ = [
    "STATUSES",
    "Check",
    "Datasheet",
    "Limit",
    "Measured",
    "adev_at",
    "check_limits",
    "check_quantity",
    "quantities",
    "undetected_measured",
    "verdict",
]

STATUSES: tuple[str, ...] = ("pass", "marginal", "fail", "undetermined", "missing")


@dataclass(frozen=True)
class Limit:
    """One datasheet line: a quantity, its unit and a lower and/or upper bound."""

    quantity: str
    unit: str
    max: float | None = None
    min: float | None = None
    tau: float | None = None

    @property
    def sensor(self) -> str | None:
        """The sensor the limit is for, from its unit's dimension (None: any sensor).

        A limit in an angle-based unit (``deg/sqrt(h)``, ``deg/h``) is a gyro limit, one in a
        length-based unit (``m/s/sqrt(h)``, ``ug``, ``m/s^2``) an accelerometer limit; a
        datasheet of a six-axis IMU lists both and each channel is checked against its own.
        """
        if not self.unit:
            return None
        unit = parse_unit(self.unit)
        if unit.angle:
            return "gyro"
        if unit.length:
            return "accelerometer"
        return None

    @property
    def label(self) -> str:
        """Human-readable name, e.g. ``adev(1 s)`` or ``N``."""
        return f"adev(τ = {self.tau:g} s)" if self.quantity == "adev" else self.quantity

    def bounds_text(self) -> str:
        """``≤ 0.3 deg/sqrt(h)``, ``≥ 1 s`` or ``0.1 … 0.3 unit``."""
        if not self.unit:
            return f"{self._bounds()} (record units)"
        return f"{self._bounds()} {self.unit}"

    def _bounds(self) -> str:
        if self.min is not None and self.max is not None:
            return f"{self.min:.4g} … {self.max:.4g}"
        if self.max is not None:
            return f"≤ {self.max:.4g}"
        return f"≥ {self.min:.4g}"


def quantities() -> list[str]:
    """The quantities a limit can name: ``adev`` and every noise-term parameter."""
    from allanite.terms import TERM_TYPES

    names = {spec.name for cls in TERM_TYPES.values() for spec in cls.params}
    return ["adev", *sorted(names)]


#: datasheet names of the IEEE coefficients -> their symbol (for the hint of a refusal)
_ALIASES = {
    "arw": "N",
    "vrw": "N",
    "angle_random_walk": "N",
    "velocity_random_walk": "N",
    "bi": "B",
    "bias": "B",
    "bias_instability": "B",
    "bias_stability": "B",
    "rrw": "K",
    "rate_random_walk": "K",
    "rate_ramp": "R",
    "quantization": "Q",
    "allan_deviation": "adev",
}


def check_quantity(quantity: str, where: str, source: str) -> None:
    """Refuse a quantity no term has (a typo would otherwise be reported as never measured).

    A parameter of a type that occurs more than once in a model carries a suffix (``sigma_1``,
    ``sigma_2``, see :meth:`allanite.model.NoiseModel.labelled_parameters`).
    """
    import difflib
    import re

    known = quantities()
    base = re.sub(r"_\d+$", "", quantity)
    if quantity in known or base in known:
        return
    key = quantity.lower().replace(" ", "_")
    close = [_ALIASES[key]] if key in _ALIASES else [k for k in known if k.lower() == key]
    if not close:
        close = difflib.get_close_matches(quantity, known, n=1, cutoff=0.6)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    raise InputError(
        f"{where}: unknown quantity {quantity!r}{hint}; use adev or a noise coefficient: "
        f"{', '.join(k for k in known if k != 'adev')} (with _1, _2, ... when a term type "
        "occurs more than once)",
        path=source,
    )


@dataclass(frozen=True)
class Datasheet:
    """A named set of limits."""

    device: str
    limits: tuple[Limit, ...]

    @classmethod
    def from_compact(cls, data: dict[str, Any], *, source: str = "datasheet") -> Datasheet:
        """Build from the compact ``{"N": 0.01, "B": {"max": 0.003}}`` form (record units)."""
        limits = []
        for name, spec in data.items():
            if name == "device":
                continue
            if name == "adev":
                raise InputError(
                    "an 'adev' limit needs tau and a unit: use the full form "
                    '{"limits": [{"quantity": "adev", "tau": 1, "max": 0.01, "unit": "deg/s"}]}',
                    path=source,
                )
            check_quantity(str(name), f"entry {name!r}", source)
            if isinstance(spec, (int, float)) and not isinstance(spec, bool):
                limits.append(Limit(quantity=str(name), unit="", max=float(spec)))
                continue
            if (
                not isinstance(spec, dict)
                or set(spec) - {"min", "max"}
                or (spec.get("min") is None and spec.get("max") is None)
            ):
                raise InputError(
                    f'entry {name!r} must be a number (upper limit) or {{"min": ..., '
                    '"max": ...}} with at least one bound',
                    path=source,
                )
            try:
                limits.append(
                    Limit(
                        quantity=str(name),
                        unit="",
                        max=None if spec.get("max") is None else float(spec["max"]),
                        min=None if spec.get("min") is None else float(spec["min"]),
                    )
                )
            except (TypeError, ValueError) as exc:
                raise InputError(f"entry {name!r}: {exc}", path=source) from exc
        if not limits:
            raise InputError("no limits given", path=source)
        return cls(device=str(data.get("device", Path(source).stem)), limits=tuple(limits))

    @classmethod
    def from_dict(cls, data: Any, *, source: str = "datasheet") -> Datasheet:
        """Validate and build from the JSON structure described in the module docstring."""
        if isinstance(data, dict) and "limits" not in data:
            return cls.from_compact(data, source=source)
        if not isinstance(data, dict) or not isinstance(data.get("limits"), list):
            raise InputError(
                'expected an object with a \'limits\' list, e.g. {"device": "...", "limits": '
                '[{"quantity": "N", "max": 0.3, "unit": "deg/sqrt(h)"}]}',
                path=source,
            )
        limits = []
        for k, item in enumerate(data["limits"]):
            where = f"limits[{k}]"
            if not isinstance(item, dict) or "quantity" not in item or "unit" not in item:
                raise InputError(f"{where} needs 'quantity' and 'unit' fields", path=source)
            unknown = set(item) - {"quantity", "unit", "max", "min", "tau"}
            if unknown:
                raise InputError(
                    f"{where} has unknown field(s) {sorted(unknown)}; use quantity, unit, max, "
                    "min, tau",
                    path=source,
                )
            if item.get("max") is None and item.get("min") is None:
                raise InputError(f"{where} needs a 'max' and/or a 'min'", path=source)
            check_quantity(str(item["quantity"]), where, source)
            if item["quantity"] == "adev" and not isinstance(item.get("tau"), (int, float)):
                raise InputError(f"{where}: an 'adev' limit needs 'tau' in seconds", path=source)
            try:
                limits.append(
                    Limit(
                        quantity=str(item["quantity"]),
                        unit=str(item["unit"]),
                        max=None if item.get("max") is None else float(item["max"]),
                        min=None if item.get("min") is None else float(item["min"]),
                        tau=None if item.get("tau") is None else float(item["tau"]),
                    )
                )
                _ = limits[-1].sensor  # the unit must be readable
            except (TypeError, ValueError) as exc:
                raise InputError(f"{where}: {exc}", path=source) from exc
        return cls(device=str(data.get("device", Path(source).stem)), limits=tuple(limits))

    @classmethod
    def load(cls, path: str | Path) -> Datasheet:
        """Read a limits file: JSON, or YAML for ``.yaml``/``.yml`` (the ``yaml`` extra)."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError as exc:
            raise InputError("no such file; check the path", path=str(path)) from exc
        if path.suffix.lower() in (".yaml", ".yml"):
            yaml = require(
                "yaml", extra="yaml", purpose="reading YAML datasheets", package="pyyaml"
            )
            try:
                data = yaml.safe_load(text)
            except yaml.YAMLError as exc:
                mark = getattr(exc, "problem_mark", None)
                raise InputError(
                    f"not valid YAML ({getattr(exc, 'problem', exc)}); fix the syntax",
                    path=str(path),
                    line=None if mark is None else mark.line + 1,
                ) from exc
        else:
            try:
                data = parse_json(text, "the datasheet")
            except json.JSONDecodeError as exc:
                raise InputError(
                    f"not valid JSON ({exc.msg}, column {exc.colno}); fix the syntax",
                    path=str(path),
                    line=exc.lineno,
                ) from exc
        return cls.from_dict(data, source=str(path))

    @classmethod
    def coerce(cls, sheet: Datasheet | dict[str, Any] | str | Path | None) -> Datasheet | None:
        """A :class:`Datasheet` from a datasheet, a mapping of either form, or a file path."""
        if sheet is None or isinstance(sheet, Datasheet):
            return sheet
        if isinstance(sheet, (str, Path)):
            return cls.load(sheet)
        if isinstance(sheet, dict):
            return cls.from_dict(sheet)
        raise TypeError(
            f"datasheet must be a Datasheet, a mapping or a file path, got {type(sheet).__name__}"
        )

    @property
    def quantities(self) -> tuple[str, ...]:
        """The quantities limited, in order, without repeats (``adev`` once)."""
        return tuple(dict.fromkeys(limit.quantity for limit in self.limits))


@dataclass(frozen=True)
class Measured:
    """A measured value with its confidence interval, in ``unit``."""

    value: float
    low: float
    high: float
    unit: str
    model_unit: Any = None


@dataclass(frozen=True)
class Check:
    """The outcome of one limit for one channel."""

    limit: Limit
    channel: str
    value: float | None
    low: float | None
    high: float | None
    status: str
    upper: float | None = None

    @property
    def passed(self) -> bool:
        """True unless the check failed outright."""
        return self.status != "fail"

    def status_text(self) -> str:
        """The status for a table, with the upper limit of a term the fit left out.

        ``PASS``, ``MARGINAL``, ...; ``NOT DETERMINED (<= 12.3)`` or ``PASS (not detected,
        <= 0.05)`` for an undetected term.
        """
        return status_text(self.status, self.upper)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (``upper``: the upper limit of a term the fit left out)."""
        return {
            "quantity": self.limit.quantity,
            "tau": self.limit.tau,
            "unit": self.limit.unit,
            "min": self.limit.min,
            "max": self.limit.max,
            "channel": self.channel,
            "value": self.value,
            "low": self.low,
            "high": self.high,
            "status": self.status,
            "upper": self.upper,
        }


def status_text(status: str, upper: float | None = None) -> str:
    """A check's status for a table: ``NOT DETERMINED (<= u)`` for *undetermined*, ..."""
    if upper is None:
        return "NOT DETERMINED" if status == "undetermined" else status.upper()
    if status == "undetermined":
        return f"NOT DETERMINED (<= {upper:.3g})"
    return f"{status.upper()} (not detected, <= {upper:.3g})"


def undetected_measured(fit: Any, level: float) -> dict[str, Measured]:
    """The upper limits of the terms a fit left out, as :class:`Measured` (model units).

    From :attr:`allanite.fit.FitResult.undetected` and, for a term the record may show a
    little of (an AMBIGUOUS addition), :attr:`~allanite.fit.FitResult.exchangeable`: the
    upper end of its ``level`` interval in the fit with the term. Value 0, interval
    ``[0, upper]``; empty for anything without these (a bare model, explicit terms).
    """
    fitted = getattr(fit, "coefficients", {})
    out = {}
    left_out = {**getattr(fit, "exchangeable", {}), **getattr(fit, "undetected", {})}
    for symbol, coef in left_out.items():
        if symbol in fitted:
            continue
        high = float(coef.ci(level)[1])
        if math.isfinite(high):
            out[symbol] = Measured(0.0, 0.0, high, coef.unit, coef.unit)
    return out


def _status(limit: Limit, m: Measured) -> str:
    lo, mid, hi = m.low, m.value, m.high
    if (limit.max is not None and mid > limit.max) or (limit.min is not None and mid < limit.min):
        return "fail"
    if (limit.max is not None and hi > limit.max) or (limit.min is not None and lo < limit.min):
        return "marginal"
    return "pass"


def adev_at(
    tau: np.ndarray, dev: np.ndarray, low: np.ndarray, high: np.ndarray, at: float
) -> tuple[float, float, float] | None:
    """Log-log interpolation of a deviation and its limits at ``at`` seconds (None outside)."""
    if not tau[0] <= at <= tau[-1]:
        return None
    lt = np.log(tau)
    x = math.log(at)
    return tuple(float(np.exp(np.interp(x, lt, np.log(v)))) for v in (dev, low, high))  # type: ignore[return-value]


def check_limits(
    sheet: Datasheet,
    channel: str,
    coefficients: dict[str, Measured],
    adev: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str | None],
    undetected: dict[str, Measured] | None = None,
) -> list[Check]:
    """Check one channel against every limit of ``sheet``.

    Parameters
    ----------
    sheet : Datasheet
        The limits.
    channel : str
        Channel name (for the table).
    coefficients : dict
        Fitted coefficients by symbol (``N``, ``B``, ...), with intervals and units.
    adev : tuple
        ``(tau, dev, low, high, rate_unit)`` of the measured deviation. The rate unit says
        which sensor the channel is: limits in units of another sensor (an accelerometer
        limit in m/s/sqrt(h) for a gyro channel) do not apply to it and are left out.
    undetected : dict, optional
        Upper limits of the terms the fit left out (:func:`undetected_measured`): a limit on
        one of them is judged by its upper limit (*pass* or *undetermined*, see the module
        docstring) instead of *missing*.

    Returns
    -------
    list of Check
        One per applicable limit; ``pass``/``undetermined`` (or ``fail`` against a positive
        minimum) by the upper limit of a term in ``undetected``; ``missing`` when the
        quantity was not measured (no such fitted term, or ``tau`` outside the measured
        range), ``fail`` for a term the fit did not find when the limit asks for a positive
        minimum.

    Raises
    ------
    ValueError
        If a limit in a physical unit meets a channel whose unit is not known, or a limit's
        unit cannot be converted to the coefficient's (the message names both units).
    """
    checks = []
    tau, dev, low, high, rate = adev
    sensor = _sensor(rate)
    for limit in sheet.limits:
        if sensor is not None and limit.sensor not in (None, sensor):
            continue  # e.g. an accelerometer limit and a gyro channel
        measured: Measured | None = None
        bound = (undetected or {}).get(limit.quantity)
        if limit.quantity not in coefficients and bound is not None:
            checks.append(_bounded(limit, channel, bound))
            continue
        if limit.quantity == "adev":
            at = adev_at(tau, dev, low, high, float(limit.tau or 0.0))
            if at is not None and (rate is not None or not limit.unit):
                value, lo, hi = (
                    v if not limit.unit else convert(v, str(rate), limit.unit) for v in at
                )
                measured = Measured(value, lo, hi, limit.unit)
        elif limit.quantity in coefficients:
            measured = Measured(*_converted(limit, coefficients[limit.quantity]), limit.unit)
        if measured is None:
            absent = limit.quantity != "adev" and limit.min is not None and limit.min > 0
            checks.append(Check(limit, channel, None, None, None, "fail" if absent else "missing"))
        else:
            checks.append(
                Check(
                    limit,
                    channel,
                    measured.value,
                    measured.low,
                    measured.high,
                    _status(limit, measured),
                )
            )
    return checks


def _converted(limit: Limit, c: Measured) -> tuple[float, float, float]:
    """``(value, low, high)`` of ``c`` in the limit's unit (the model's for a compact limit)."""
    target = limit.unit or c.model_unit
    if target is None:
        raise ValueError(
            f"limit on {limit.quantity} has no unit and the record's units are unknown; "
            "give the limit's unit or the record's (--units)"
        )
    if limit.unit and _record_units(c.unit):
        raise ValueError(
            f"the limit on {limit.quantity} is in {limit.unit} but the record's "
            "unit is not known; give the record's unit (--units) or write the "
            "limit in record units (compact form)"
        )
    value, lo, hi = (convert(v, c.unit, target) for v in (c.value, c.low, c.high))
    return value, lo, hi


def _bounded(limit: Limit, channel: str, bound: Measured) -> Check:
    """The check of a term the fit left out, by its upper limit (module docstring)."""
    upper = _converted(limit, bound)[2]
    if limit.min is not None and limit.min > 0:
        status = "fail" if upper < limit.min else "undetermined"
    elif limit.max is not None and upper > limit.max:
        status = "undetermined"
    else:
        status = "pass"
    return Check(limit, channel, None, None, upper, status, upper)


def _sensor(rate: str | None) -> str | None:
    """Sensor of a channel's rate unit (None when unknown)."""
    if rate is None:
        return None
    try:
        kind = sensor_kind(rate)
    except ValueError:
        return None
    return None if kind == "unknown" else kind


def _record_units(unit: str) -> bool:
    try:
        return bool(parse_unit(unit).record)
    except ValueError:
        return False


def verdict(statuses: Iterable[str | None]) -> str:
    """The worst of ``statuses``: ``fail`` > ``marginal`` > ``undetermined`` > ``pass``.

    ``missing`` is neutral.

    ``pass`` when there are none or all are missing (pass ``[c.status for c in checks]``).
    """
    seen = set(statuses)
    for status in ("fail", "marginal", "undetermined"):
        if status in seen:
            return status
    return "pass"
