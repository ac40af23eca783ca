"""Units of angles, rates and noise coefficients: parse, convert and display.

A unit is parsed into a scale factor to SI (radians, seconds) and its dimension as powers of
angle and time. The coefficients of a :class:`~allanite.terms.base.Term` are stored in the
model's rate unit and seconds; a :class:`~allanite.terms.base.ParamSpec` gives their powers
(``N`` is ``rate^1 s^0.5``), so any coefficient can be shown in any unit of the same dimension::

    >>> convert(6.153e-3, "deg/sqrt(s)", "deg/sqrt(h)")   # N: 1 deg/sqrt(s) = 60 deg/sqrt(h)
    0.36918
    >>> convert(8.1e-4, "deg/s/sqrt(s)", "deg/h/sqrt(h)") # K: factor 3600 * 60
    174.96

Grammar: products and quotients of atoms, ``^`` powers, ``sqrt(...)``, parentheses, e.g.
``deg/h``, ``deg/sqrt(h)``, ``deg/h/sqrt(h)``, ``deg/h^1.5``, ``rad/s^2``, ``(rad/s)*sqrt(Hz)``,
``deg/s/sqrt(Hz)``, ``°/√h``. Angle atoms: rad, mrad, urad, deg, mdeg, arcmin, arcsec, rev;
time atoms: s, ms, us, min, h (hr), day; ``Hz`` is 1/s; ``dph`` is deg/h.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = [
    "ANGLE_UNITS",
    "TIME_UNITS",
    "Unit",
    "coefficient_unit",
    "convert",
    "display_unit",
    "parse_unit",
    "rate_unit",
]

#: angle atoms in radians
ANGLE_UNITS: dict[str, float] = {
    "rad": 1.0,
    "mrad": 1e-3,
    "urad": 1e-6,
    "µrad": 1e-6,
    "deg": math.pi / 180.0,
    "°": math.pi / 180.0,
    "mdeg": math.pi / 180.0e3,
    "arcmin": math.pi / 180.0 / 60.0,
    "arcsec": math.pi / 180.0 / 3600.0,
    "rev": 2.0 * math.pi,
}
#: time atoms in seconds
TIME_UNITS: dict[str, float] = {
    "s": 1.0,
    "sec": 1.0,
    "ms": 1e-3,
    "us": 1e-6,
    "min": 60.0,
    "h": 3600.0,
    "hr": 3600.0,
    "day": 86400.0,
}
_ALIASES = {"dph": "(deg/h)", "√": "sqrt", "rpm": "(rev/min)", "dps": "(deg/s)"}
_TOKEN = re.compile(r"\s*(sqrt|[A-Za-zµ°]+|\d+(?:\.\d*)?|[()*/^])")


@dataclass(frozen=True)
class Unit:
    """A parsed unit: ``value_SI = value * scale``; dimension ``angle^angle * s^time``."""

    text: str
    scale: float
    angle: float
    time: float

    def same_dimension(self, other: Unit) -> bool:
        """Whether values can be converted between the two units."""
        return math.isclose(self.angle, other.angle, abs_tol=1e-12) and math.isclose(
            self.time, other.time, abs_tol=1e-12
        )


def _dimension_text(angle: float, time: float) -> str:
    return f"angle^{angle:g} * time^{time:g}"


class _Parser:
    def __init__(self, text: str) -> None:
        self.text = text
        src = text.strip()
        for alias, repl in _ALIASES.items():
            src = src.replace(alias, repl)
        pos, tokens = 0, []
        while pos < len(src):
            match = _TOKEN.match(src, pos)
            if match is None or match.end() == pos:
                raise ValueError(f"cannot read unit {text!r} at {src[pos:]!r}; write e.g. deg/h")
            tokens.append(match.group(1))
            pos = match.end()
        self.tokens = tokens
        self.i = 0

    def error(self, what: str) -> ValueError:
        return ValueError(
            f"cannot read unit {self.text!r}: {what}. Write e.g. 'deg/s', 'deg/sqrt(h)', "
            "'deg/h/sqrt(h)', 'rad/s^2'"
        )

    def peek(self) -> str | None:
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def take(self) -> str:
        token = self.peek()
        if token is None:
            raise self.error("unexpected end")
        self.i += 1
        return token

    def parse(self) -> tuple[float, float, float]:
        result = self.expr()
        if self.peek() is not None:
            raise self.error(f"unexpected {self.peek()!r}")
        return result

    def expr(self) -> tuple[float, float, float]:
        scale, angle, time = self.power()
        while self.peek() in ("*", "/", "("):
            op = "*" if self.peek() == "(" else self.take()
            s, a, t = self.power()
            if op == "*":
                scale, angle, time = scale * s, angle + a, time + t
            else:
                scale, angle, time = scale / s, angle - a, time - t
        return scale, angle, time

    def power(self) -> tuple[float, float, float]:
        scale, angle, time = self.factor()
        if self.peek() == "^":
            self.take()
            token = self.take()
            try:
                p = float(token)
            except ValueError:
                raise self.error(f"power {token!r} is not a number") from None
            scale, angle, time = scale**p, angle * p, time * p
        return scale, angle, time

    def factor(self) -> tuple[float, float, float]:
        token = self.take()
        if token == "sqrt":
            s, a, t = self.factor()  # sqrt(...) or, as in "√h", a single atom
            return math.sqrt(s), a / 2.0, t / 2.0
        if token == "(":
            value = self.expr()
            if self.take() != ")":
                raise self.error("missing ')'")
            return value
        if token in ANGLE_UNITS:
            return ANGLE_UNITS[token], 1.0, 0.0
        if token in TIME_UNITS:
            return TIME_UNITS[token], 0.0, 1.0
        if token == "Hz":
            return 1.0, 0.0, -1.0
        if re.fullmatch(r"\d+(?:\.\d*)?", token):
            return float(token), 0.0, 0.0
        raise self.error(
            f"unknown unit {token!r} (angles: {', '.join(ANGLE_UNITS)}; times: "
            f"{', '.join(TIME_UNITS)}; Hz)"
        )


def parse_unit(text: str) -> Unit:
    """Parse a unit string such as ``"deg/h/sqrt(h)"``.

    Raises
    ------
    TypeError
        If ``text`` is not a string.
    ValueError
        If the string cannot be read (the message names the bad part).
    """
    if not isinstance(text, str):
        raise TypeError(f"a unit must be a string such as 'deg/s', got {text!r}")
    scale, angle, time = _Parser(text).parse()
    return Unit(text=text, scale=scale, angle=angle, time=time)


def rate_unit(text: str) -> Unit:
    """Parse a rate unit (angle per time, e.g. ``deg/s``, ``deg/h``, ``rad/s``)."""
    unit = parse_unit(text)
    if not (math.isclose(unit.angle, 1.0) and math.isclose(unit.time, -1.0)):
        raise ValueError(
            f"{text!r} is not a rate unit (angle/time) but {_dimension_text(unit.angle, unit.time)}"
            "; use e.g. 'deg/s', 'deg/h' or 'rad/s'"
        )
    return unit


def coefficient_unit(rate: str, rate_power: float, time_power: float) -> Unit:
    """Return the unit ``rate^rate_power * s^time_power`` of a coefficient (model rate ``rate``)."""
    base = rate_unit(rate)
    return Unit(
        text=f"({rate})^{rate_power:g}*s^{time_power:g}",
        scale=base.scale**rate_power,
        angle=rate_power,
        time=-rate_power + time_power,
    )


def convert(value: float, from_unit: str | Unit, to_unit: str | Unit) -> float:
    """Convert ``value`` between two units of the same dimension.

    Raises
    ------
    ValueError
        If the dimensions differ (the message gives both).
    """
    src = parse_unit(from_unit) if isinstance(from_unit, str) else from_unit
    dst = parse_unit(to_unit) if isinstance(to_unit, str) else to_unit
    if not src.same_dimension(dst):
        raise ValueError(
            f"cannot convert {src.text!r} ({_dimension_text(src.angle, src.time)}) to "
            f"{dst.text!r} ({_dimension_text(dst.angle, dst.time)}); pick a unit of the same kind"
        )
    return float(value) * src.scale / dst.scale


def display_unit(rate: str, name: str) -> str:
    """Customary unit of coefficient ``name`` for a rate unit ``angle/time``.

    ``deg/h`` gives N in ``deg/sqrt(h)``, B in ``deg/h``, K in ``deg/h/sqrt(h)``, Q in ``deg``,
    R in ``deg/h^2``; Gauss-Markov sigma and sinusoid amplitude in the rate unit, ``tau_c`` in
    ``s`` and ``frequency`` in ``Hz``.

    Raises
    ------
    ValueError
        If ``rate`` is not a rate unit of the form ``angle/time``.
    """
    rate_unit(rate)
    base = name.split("_")[0] if name.startswith(("sigma_", "amplitude_")) else name
    if base in ("tau",) or name.startswith("tau_c"):
        return "s"
    if name.startswith("frequency"):
        return "Hz"
    parts = rate.replace(" ", "").split("/")
    if len(parts) != 2:
        raise ValueError(f"give the rate unit as angle/time (e.g. deg/h), got {rate!r}")
    angle, time = parts
    table = {
        "N": f"{angle}/sqrt({time})",
        "B": rate,
        "K": f"{angle}/{time}/sqrt({time})",
        "Q": angle,
        "R": f"{angle}/{time}^2",
        "sigma": rate,
        "amplitude": rate,
    }
    if base not in table:
        raise ValueError(f"no customary unit for coefficient {name!r}")
    return table[base]
