"""One unit algebra for the whole library: parse, convert and display units of inertial sensors.

A unit is parsed into a scale factor to SI and its *dimension*, the powers of four base
quantities: angle (rad), length (m), time (s) and the *record unit* ``unit`` (the unknown
unit of a record whose unit was not given; it converts to nothing but itself). Conversion is
always done on the full dimension, so a value can only be converted to a unit of the same kind
and the error names both units otherwise::

    >>> convert(6.153e-3, "deg/sqrt(s)", "deg/sqrt(h)")   # N: 1 deg/sqrt(s) = 60 deg/sqrt(h)
    0.36918
    >>> round(convert(8.1e-4, "deg/s/sqrt(s)", "deg/h/sqrt(h)"), 9)  # K: factor 3600 * 60
    174.96
    >>> convert(1.0, "m/s^2", "ug")                        # 1 m/s^2 = 101972 ug
    101971.62129779284

The output quantity of a sensor (the model's ``rate``) is an angular rate (gyroscope,
angle/time) or an acceleration (accelerometer, length/time²). The coefficients of a
:class:`~allanite.terms.base.Term` are stored in that unit and seconds; a
:class:`~allanite.terms.base.ParamSpec` gives their powers (``N`` is ``rate^1 s^0.5``), so the
dimension of every coefficient follows from the term (:func:`coefficient_unit`) and it can be
shown in any unit of that dimension (:func:`display_unit`, :func:`customary_unit`).

Grammar: products and quotients of atoms, ``^`` powers, ``sqrt(...)``, parentheses, e.g.
``deg/h``, ``deg/sqrt(h)``, ``deg/h/sqrt(h)``, ``deg/h^1.5``, ``rad/s^2``, ``(rad/s)*sqrt(Hz)``,
``deg/s/sqrt(Hz)``, ``°/√h``, ``m/s²``, ``µg/√Hz``, ``m/s/h^1.5``.

Atoms
-----
angle
    rad, mrad, urad (µrad), deg (°), mdeg, arcmin, arcsec, rev
length
    m, cm, mm, um (µm), km, ft, in
time
    s (sec), ms, us (µs), min, h (hr), day; ``Hz`` is 1/s
acceleration
    ``g`` is standard gravity, **g = 9.80665 m/s² exactly** (:data:`STANDARD_GRAVITY`, the
    one definition in the library; CGPM 1901), mg = 1e-3 g, ug (µg) = 1e-6 g; gal (Gal) =
    1 cm/s², mgal (mGal) = 1e-3 gal. In this library ``mg`` is the milli-g, never the
    milligram.
shorthands
    ``dph`` = deg/h, ``dps`` = deg/s, ``rpm`` = rev/min
record unit
    ``unit``: the record's own, unknown unit (a model fitted to a record without a unit
    has the rate ``unit``; its N is in ``unit*sqrt(s)``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

__all__ = [
    "ACCELERATION_UNITS",
    "ACCELEROMETER_CUSTOMARY",
    "ANGLE_UNITS",
    "LENGTH_UNITS",
    "RATE_UNITS",
    "RECORD_UNIT",
    "STANDARD_GRAVITY",
    "SYMBOL_POWERS",
    "TIME_UNITS",
    "Unit",
    "coefficient_text",
    "coefficient_unit",
    "convert",
    "customary_gyro_rate",
    "customary_unit",
    "customary_value",
    "display_angle",
    "display_unit",
    "integral_unit",
    "integrated_unit",
    "parse_unit",
    "quantity",
    "rate_unit",
    "record_rate_unit",
    "sensor_kind",
]

#: standard gravity in m/s^2 (exact by definition, 3rd CGPM 1901): the library's one ``g``
STANDARD_GRAVITY: float = 9.80665

#: the unit of a record whose unit was not given (dimension of its own)
RECORD_UNIT = "unit"

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
#: length atoms in metres
LENGTH_UNITS: dict[str, float] = {
    "m": 1.0,
    "km": 1e3,
    "cm": 1e-2,
    "mm": 1e-3,
    "um": 1e-6,
    "µm": 1e-6,
    "ft": 0.3048,
    "in": 0.0254,
}
#: time atoms in seconds
TIME_UNITS: dict[str, float] = {
    "s": 1.0,
    "sec": 1.0,
    "ms": 1e-3,
    "us": 1e-6,
    "µs": 1e-6,
    "min": 60.0,
    "h": 3600.0,
    "hr": 3600.0,
    "day": 86400.0,
}
#: acceleration atoms in m/s^2 (``g`` is standard gravity)
ACCELERATION_UNITS: dict[str, float] = {
    "g": STANDARD_GRAVITY,
    "mg": 1e-3 * STANDARD_GRAVITY,
    "ug": 1e-6 * STANDARD_GRAVITY,
    "µg": 1e-6 * STANDARD_GRAVITY,
    "gal": 1e-2,
    "Gal": 1e-2,
    "mgal": 1e-5,
    "mGal": 1e-5,
}
#: rate units a record may be given in (gyroscopes and accelerometers); all are accepted
#: wherever a rate unit is (the property tests run over these)
RATE_UNITS: tuple[str, ...] = (
    "deg/s",
    "deg/h",
    "deg/min",
    "rad/s",
    "mrad/s",
    "mdeg/s",
    "dph",
    "dps",
    "arcsec/s",
    "rev/min",
    "rpm",
    "m/s^2",
    "g",
    "mg",
    "ug",
    "µg",
    "ft/s^2",
    "cm/s^2",
    "gal",
)

# base dimensions, in this order, of every Unit
_BASES = ("angle", "length", "time", "record")
_ANGLE = (1.0, 0.0, 0.0, 0.0)
_LENGTH = (0.0, 1.0, 0.0, 0.0)
_TIME = (0.0, 0.0, 1.0, 0.0)
_ACCEL = (0.0, 1.0, -2.0, 0.0)
_NONE = (0.0, 0.0, 0.0, 0.0)
_ALIASES = {
    "dph": "(deg/h)",
    "dps": "(deg/s)",
    "rpm": "(rev/min)",
    "√": "sqrt",
    "²": "^2",
    "³": "^3",
    "·": "*",
    "μ": "µ",  # Greek mu, as typed, for the micro sign
}
_TOKEN = re.compile(r"\s*(sqrt|[A-Za-zµ°]+|-?\d+(?:\.\d*)?|[()*/^])")

Dim = tuple[float, float, float, float]


@dataclass(frozen=True)
class Unit:
    """A parsed unit: ``value_SI = value * scale``.

    The dimension is ``rad^angle * m^length * s^time * unit^record`` (``unit`` is the record
    unit, see the module docstring).
    """

    text: str
    scale: float
    angle: float
    time: float
    length: float = 0.0
    record: float = 0.0

    @property
    def dimension(self) -> Dim:
        """Powers of (angle, length, time, record unit)."""
        return (self.angle, self.length, self.time, self.record)

    def same_dimension(self, other: Unit) -> bool:
        """Whether values can be converted between the two units."""
        return _same(self.dimension, other.dimension)

    @property
    def quantity(self) -> str:
        """Name of the quantity (``angular rate``, ``acceleration``, ...; see :func:`quantity`)."""
        return _quantity_name(self.dimension)


def _same(a: Dim, b: Dim) -> bool:
    return all(math.isclose(x, y, rel_tol=0.0, abs_tol=1e-9) for x, y in zip(a, b, strict=True))


_QUANTITIES: tuple[tuple[Dim, str], ...] = (
    ((1.0, 0.0, -1.0, 0.0), "angular rate"),
    (_ACCEL, "acceleration"),
    (_ANGLE, "angle"),
    ((0.0, 1.0, -1.0, 0.0), "velocity"),
    (_LENGTH, "length"),
    (_TIME, "time"),
    ((0.0, 0.0, -1.0, 0.0), "frequency"),
    ((0.0, 0.0, 0.0, 1.0), "record unit"),
    ((0.0, 0.0, -1.0, 1.0), "record unit per second"),
    (_NONE, "dimensionless"),
)


def _dimension_text(dim: Dim) -> str:
    parts = [
        f"{name}^{p:g}" if p != 1 else name
        for name, p in zip(_BASES, dim, strict=True)
        if abs(p) > 1e-12
    ]
    return " * ".join(parts) if parts else "dimensionless"


def _quantity_name(dim: Dim) -> str:
    for known, name in _QUANTITIES:
        if _same(dim, known):
            return name
    return _dimension_text(dim)


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
                if not src[pos:].strip():
                    break
                raise ValueError(f"cannot read unit {text!r} at {src[pos:]!r}; write e.g. deg/h")
            tokens.append(match.group(1))
            pos = match.end()
        self.tokens = tokens
        self.i = 0

    def error(self, what: str) -> ValueError:
        return ValueError(
            f"cannot read unit {self.text!r}: {what}. Write e.g. 'deg/s', 'deg/sqrt(h)', "
            "'deg/h/sqrt(h)', 'rad/s^2', 'm/s^2', 'ug/sqrt(Hz)'"
        )

    def peek(self) -> str | None:
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def take(self) -> str:
        token = self.peek()
        if token is None:
            raise self.error("unexpected end")
        self.i += 1
        return token

    def parse(self) -> tuple[float, Dim]:
        if not self.tokens:
            raise self.error("it is empty")
        result = self.expr()
        if self.peek() is not None:
            raise self.error(f"unexpected {self.peek()!r}")
        return result

    def expr(self) -> tuple[float, Dim]:
        scale, dim = self.power()
        while self.peek() in ("*", "/", "(", "sqrt"):
            op = "*" if self.peek() in ("(", "sqrt") else self.take()
            s, d = self.power()
            if op == "*":
                scale, dim = scale * s, _add(dim, d, 1.0)
            else:
                scale, dim = scale / s, _add(dim, d, -1.0)
        return scale, dim

    def power(self) -> tuple[float, Dim]:
        scale, dim = self.factor()
        if self.peek() == "^":
            self.take()
            token = self.take()
            if token == "(":  # ^(-0.5) or ^(3/2)
                num = self._number(self.take())
                if self.peek() == "/":
                    self.take()
                    num /= self._number(self.take())
                if self.take() != ")":
                    raise self.error("missing ')' after the power")
                p = num
            else:
                p = self._number(token)
            scale, dim = scale**p, tuple(x * p for x in dim)  # type: ignore[assignment]
        return scale, dim

    def _number(self, token: str) -> float:
        try:
            return float(token)
        except ValueError:
            raise self.error(f"power {token!r} is not a number") from None

    def factor(self) -> tuple[float, Dim]:
        token = self.take()
        if token == "sqrt":
            s, d = self.factor()  # sqrt(...) or, as in "√h", a single atom
            return math.sqrt(s), tuple(x / 2.0 for x in d)  # type: ignore[return-value]
        if token == "(":
            value = self.expr()
            if self.take() != ")":
                raise self.error("missing ')'")
            return value
        if token in ANGLE_UNITS:
            return ANGLE_UNITS[token], _ANGLE
        if token in TIME_UNITS:
            return TIME_UNITS[token], _TIME
        if token in LENGTH_UNITS:
            return LENGTH_UNITS[token], _LENGTH
        if token in ACCELERATION_UNITS:
            return ACCELERATION_UNITS[token], _ACCEL
        if token == "Hz":
            return 1.0, (0.0, 0.0, -1.0, 0.0)
        if token == RECORD_UNIT:
            return 1.0, (0.0, 0.0, 0.0, 1.0)
        if re.fullmatch(r"-?\d+(?:\.\d*)?", token):
            return float(token), _NONE
        raise self.error(
            f"unknown unit {token!r} (angles: {', '.join(ANGLE_UNITS)}; lengths: "
            f"{', '.join(LENGTH_UNITS)}; times: {', '.join(TIME_UNITS)}, Hz; accelerations: "
            f"{', '.join(ACCELERATION_UNITS)}; the record's own unit: {RECORD_UNIT})"
        )


def _add(a: Dim, b: Dim, sign: float) -> Dim:
    return (a[0] + sign * b[0], a[1] + sign * b[1], a[2] + sign * b[2], a[3] + sign * b[3])


def parse_unit(text: str | Unit) -> Unit:
    """Parse a unit string such as ``"deg/h/sqrt(h)"`` or ``"ug/sqrt(Hz)"`` (a Unit is returned).

    Raises
    ------
    TypeError
        If ``text`` is not a string.
    ValueError
        If the string cannot be read (the message names the bad part).
    """
    if isinstance(text, Unit):
        return text
    if not isinstance(text, str):
        raise TypeError(f"a unit must be a string such as 'deg/s', got {text!r}")
    scale, dim = _Parser(text).parse()
    return Unit(text=text, scale=scale, angle=dim[0], time=dim[2], length=dim[1], record=dim[3])


def quantity(unit: str | Unit) -> str:
    """Name of the quantity a unit measures: ``angular rate``, ``acceleration``, ``angle``, ...

    ``deg/h`` is an angular rate, ``mg`` an acceleration, ``m/s`` a velocity; other
    dimensions are named by their powers (``angle * time^-0.5``).
    """
    return parse_unit(unit).quantity


#: sensor of each output quantity
_SENSORS = {"angular rate": "gyro", "acceleration": "accelerometer", "record unit": "unknown"}


def rate_unit(text: str | Unit) -> Unit:
    """Parse the output unit of a sensor: an angular rate or an acceleration.

    ``deg/s``, ``deg/h``, ``dph``, ``rad/s``, ``rpm`` (gyroscopes); ``m/s^2``, ``g``, ``mg``,
    ``ug``, ``ft/s^2``, ``gal`` (accelerometers); or the record unit ``unit`` when the record's
    unit is not known.

    Raises
    ------
    ValueError
        If the unit is not one of these kinds (the message names the quantity it is).
    """
    unit = parse_unit(text)
    if unit.quantity not in _SENSORS:
        raise ValueError(
            f"{unit.text!r} is not a rate unit: it is {_article(unit.quantity)}; give the "
            "unit of the sensor's output, an angular rate (e.g. 'deg/s', 'deg/h', 'rad/s') or "
            "an acceleration (e.g. 'm/s^2', 'g', 'mg')"
        )
    return unit


def _article(name: str) -> str:
    if "^" in name or "*" in name:
        return f"of dimension {name}"
    return f"an {name}" if name[0] in "aeiou" else f"a {name}"


def sensor_kind(rate: str | Unit) -> str:
    """``"gyro"`` for an angular rate, ``"accelerometer"`` for an acceleration, else ``"unknown"``.

    Raises
    ------
    ValueError
        If ``rate`` is not a rate unit (see :func:`rate_unit`).
    """
    return _SENSORS[rate_unit(rate).quantity]


def integral_unit(text: str | Unit) -> str:
    """Rate unit of a record of angles or increments in ``text`` (per second).

    The samples of an ``angle``/``increment`` record are an angle (gyro, e.g. ``deg``) or a
    velocity (accelerometer, e.g. ``m/s``); their rate is that unit per second.

    Raises
    ------
    ValueError
        If ``text`` is not an angle or a velocity (the message names what it is).
    """
    unit = parse_unit(text)
    if unit.quantity not in ("angle", "velocity", "record unit"):
        raise ValueError(
            f"the unit of an angle or increment record is an angle (e.g. 'deg', 'rad', "
            f"'arcsec') or, for an accelerometer, a velocity ('m/s'), but {unit.text!r} is "
            f"{_article(unit.quantity)}; give e.g. --units deg, or --input rate"
        )
    text = unit.text.replace(" ", "")
    if re.fullmatch(r"[A-Za-zµ°]+", text):
        return f"{text}/s"
    match = re.fullmatch(r"([A-Za-zµ]+)/s", text)
    if match is not None and match.group(1) in LENGTH_UNITS:
        return f"{match.group(1)}/s^2"  # m/s -> m/s^2
    return f"({text})/s"


def integrated_unit(rate: str) -> tuple[str, str]:
    """Unit of angle (or velocity) samples integrated from a rate: :func:`integral_unit` inverted.

    Returns ``(seconds_rate, sample_unit)``: the rate unit per second to integrate in, and
    the unit of its integral over seconds. ``deg/s`` gives ``("deg/s", "deg")``, ``deg/h``
    and ``dph`` give ``("deg/s", "deg")`` too (a rate per hour integrated over seconds is
    no named angle: convert it first), ``m/s^2`` and ``g`` give ``("m/s^2", "m/s")``, the
    record unit gives ``("unit", "unit*s")``.

    Raises
    ------
    ValueError
        If ``rate`` is not a rate unit (see :func:`rate_unit`).
    """
    kind = sensor_kind(rate)
    split = _split_rate(rate)
    if kind == "gyro":
        angle = split[0] if split is not None and split[0] in ANGLE_UNITS else "rad"
        return f"{angle}/s", angle
    if kind == "accelerometer":
        length = split[0] if split is not None and split[0] in LENGTH_UNITS else "m"
        return f"{length}/s^2", f"{length}/s"
    return rate, f"{rate}*s"


def record_rate_unit(units: str | None, input: str = "rate", *, strict: bool = False) -> str | None:
    """Rate unit of a record whose samples are in ``units`` (None stays None).

    Rate samples (``input="rate"``) must be in a rate unit (:func:`rate_unit`). Angle or
    increment samples are in an angle or a velocity, whose rate is that unit per second
    (:func:`integral_unit`); unless ``strict``, a rate unit is accepted for them too (the
    unit of the rate they describe).

    Raises
    ------
    ValueError
        If the unit cannot be read or measures the wrong quantity (the message says which).
    """
    if units is None:
        return None
    if input == "rate":
        return rate_unit(units).text
    if strict or parse_unit(units).quantity not in _SENSORS:
        return integral_unit(units)
    return rate_unit(units).text


def _pow_text(atom: str, p: float) -> str:
    """``atom^p`` for p > 0 in the customary spelling (sqrt(h), h, h^1.5, h^2)."""
    if math.isclose(p, 0.5):
        return f"sqrt({atom})"
    if math.isclose(p, 1.0):
        return atom
    return f"{atom}^{p:g}"


def _times(base: str, atom: str, q: float) -> str:
    """``base * atom^q`` spelled customarily (``deg/h * h^0.5`` is written by the caller)."""
    if abs(q) < 1e-12:
        return base
    if q > 0:
        return f"{base}*{_pow_text(atom, q)}"
    return f"{base}/{_pow_text(atom, -q)}"


def coefficient_unit(rate: str | Unit, rate_power: float, time_power: float) -> Unit:
    """Unit ``rate^rate_power * s^time_power`` of a coefficient of a model in ``rate``.

    The text is exact and readable: ``deg/s`` gives N (1, 0.5) in ``deg/sqrt(s)``; ``deg/h``
    gives N in ``(deg/h)*sqrt(s)`` (a model in deg/h stores N in deg/h times sqrt(s), which
    is 1/60 of a deg/sqrt(h)); ``m/s^2`` gives N in ``m/s^2*sqrt(s)``.
    """
    base = rate_unit(rate)
    scale = base.scale**rate_power
    dim = tuple(x * rate_power for x in base.dimension)
    dim = (dim[0], dim[1], dim[2] + time_power, dim[3])
    text = _coefficient_text(base.text, rate_power, time_power, "s")
    return Unit(text=text, scale=scale, angle=dim[0], time=dim[2], length=dim[1], record=dim[3])


def _split_rate(rate: str) -> tuple[str, str, float] | None:
    """``(numerator, time atom, time power)`` of a rate written ``X/T`` or ``X/T^2``."""
    text = rate.replace(" ", "").replace("²", "^2").replace("³", "^3")
    for alias in ("dph", "dps", "rpm"):
        if text == alias:
            text = _ALIASES[alias][1:-1]
    match = re.fullmatch(r"([A-Za-zµ°]+)/([A-Za-zµ]+)(?:\^(\d+(?:\.\d*)?))?", text)
    if match is None or match.group(2) not in TIME_UNITS:
        return None
    return match.group(1), match.group(2), float(match.group(3) or 1.0)


def _coefficient_text(rate: str, p: float, q: float, atom: str) -> str:
    """Readable text of ``rate^p * atom^q`` (p in {0, 1} spelled customarily)."""
    if abs(p) < 1e-12:
        if math.isclose(q, -1.0) and atom == "s":
            return "Hz"
        if abs(q) < 1e-12:
            return "1"
        return _pow_text(atom, q) if q > 0 else f"1/{_pow_text(atom, -q)}"
    if not math.isclose(p, 1.0):
        return _times(f"({rate})^{p:g}", atom, q)
    split = _split_rate(rate)
    if split is not None and split[1] == atom:
        num, t, k = split  # rate = num / t^k; rate * t^q = num / t^(k - q)
        if abs(k - q) < 1e-12:
            return num
        if k - q < 0:
            return f"{num}*{_pow_text(t, q - k)}"
        if math.isclose(k - q, 1.5) or math.isclose(k - q, 2.5):
            return f"{num}/{t}^{k - q - 0.5:g}/sqrt({t})" if k - q > 2 else f"{num}/{t}/sqrt({t})"
        return f"{num}/{_pow_text(t, k - q)}"
    if re.fullmatch(r"[A-Za-zµ°]+", rate) or split is not None:
        return _times(rate, atom, q)
    return _times(f"({rate})", atom, q)


def convert(value: float, from_unit: str | Unit, to_unit: str | Unit) -> float:
    """Convert ``value`` between two units of the same dimension.

    Raises
    ------
    ValueError
        If the dimensions differ (the message names both units and their quantities).
    """
    src = parse_unit(from_unit)
    dst = parse_unit(to_unit)
    if not src.same_dimension(dst):
        raise ValueError(
            f"cannot convert {src.text!r} ({src.quantity}) to {dst.text!r} ({dst.quantity}); "
            f"pick a unit of the same kind as {src.text!r}"
        )
    return float(value) * src.scale / dst.scale


#: powers (of rate, of time) of the coefficients with a customary unit, by symbol
SYMBOL_POWERS: dict[str, tuple[float, float]] = {
    "Q": (1.0, 1.0),
    "N": (1.0, 0.5),
    "B": (1.0, 0.0),
    "K": (1.0, -0.5),
    "R": (1.0, -1.0),
    "sigma": (1.0, 0.0),
    "amplitude": (1.0, 0.0),
    "tau_c": (0.0, 1.0),
    "tau": (0.0, 1.0),
    "frequency": (0.0, -1.0),
}


def _powers_of(rate: Unit, coefficient: str | Unit | tuple[float, float]) -> tuple[float, float]:
    """(rate power, time power) of a coefficient given by symbol, powers or its unit."""
    if isinstance(coefficient, tuple):
        return float(coefficient[0]), float(coefficient[1])
    if isinstance(coefficient, str):
        base = coefficient.rsplit("_", 1)[0] if coefficient[-1:].isdigit() else coefficient
        if base not in SYMBOL_POWERS:
            raise ValueError(f"no customary unit for coefficient {coefficient!r}")
        return SYMBOL_POWERS[base]
    # a unit: rate^p * s^q has the rate's non-time dimension times p
    dim, rdim = coefficient.dimension, rate.dimension
    key = next((i for i in (0, 1, 3) if abs(rdim[i]) > 1e-12), None)
    if key is None:
        raise ValueError(f"{rate.text!r} is not a rate unit")
    p = dim[key] / rdim[key]
    q = dim[2] - p * rdim[2]
    expect = tuple(x * p for x in rdim)
    if not all(math.isclose(dim[i], expect[i], abs_tol=1e-9) for i in (0, 1, 3)):
        raise ValueError(
            f"a coefficient in {coefficient.text!r} ({coefficient.quantity}) cannot be shown "
            f"in units of {rate.text!r} ({rate.quantity}); pick a unit of the same sensor"
        )
    return p, q


def display_unit(rate: str, name: str | Unit | tuple[float, float]) -> str:
    """Unit of a coefficient for the display rate unit ``rate``: ``rate^p * T^q``.

    The coefficient ``rate^p * s^q`` (given by its symbol, by ``(p, q)`` or by its unit) is
    shown with the time unit ``T`` of ``rate``: ``deg/h`` gives N in ``deg/sqrt(h)``, B in
    ``deg/h``, K in ``deg/h/sqrt(h)``, Q in ``deg``, R in ``deg/h^2``; ``ug`` (or g, mg,
    gal: time unit s) gives N in ``ug/sqrt(Hz)``, B in ``ug``, K in ``ug/sqrt(s)``;
    ``m/s^2`` gives N in ``m/s/sqrt(s)`` (= m/s²/√Hz), K in ``m/s^2/sqrt(s)``, Q in
    ``m/s``. Gauss-Markov sigma and sinusoid amplitude are in ``rate``, ``tau_c`` in ``s``
    and ``frequency`` in ``Hz``.

    Raises
    ------
    ValueError
        If ``rate`` is not a rate unit, or a coefficient unit of another sensor is given
        (the message names both).
    """
    base = rate_unit(rate)
    p, q = _powers_of(base, name)
    split = _split_rate(rate)
    atom = split[1] if split is not None else "s"
    if abs(p) < 1e-12:
        return _coefficient_text(rate, 0.0, q, "s")
    # rate^p * s^q = rate^p * T^q * (s/T)^q: same dimension, shown with T
    text = _coefficient_text(rate, p, q, atom)
    if split is None and base.quantity == "acceleration" and math.isclose(q, 0.5):
        text = f"{rate}/sqrt(Hz)"  # ug/sqrt(Hz), the datasheet spelling of ug*sqrt(s)
    return text


#: customary display units of accelerometer coefficients (datasheets and IEEE Std 1293)
ACCELEROMETER_CUSTOMARY: dict[str, str] = {
    "N": "m/s/sqrt(h)",  # velocity random walk
    "B": "ug",  # bias instability
    # acceleration random walk: m/s^2/sqrt(s) is m/s^3/sqrt(Hz), Kalibr's
    # accelerometer_random_walk and the simulators' bias random-walk density
    "K": "m/s^2/sqrt(s)",
    "Q": "m/s",  # velocity quantization
    "R": "m/s^2/h",  # acceleration ramp
    "sigma": "ug",
    "amplitude": "mg",
}


#: angles whose gyros datasheets quote in degrees: a rad/s (ROS, PX4), rev/min or arcsec
#: (ring-laser increments) gyro's coefficients are shown in deg/sqrt(h), deg/h, ... (another
#: angle on request: :func:`display_angle`, the CLI's ``--display-units``)
CUSTOMARY_GYRO_ANGLE: dict[str, str] = {
    "rad": "deg",
    "mrad": "deg",
    "urad": "deg",
    "µrad": "deg",
    "rev": "deg",
    "arcsec": "deg",
    "arcmin": "deg",
    "mdeg": "deg",
}
#: the angle gyro coefficients are shown in, when the user chose one (None: customary)
_DISPLAY_ANGLE: ContextVar[str | None] = ContextVar("display_angle", default=None)


@contextmanager
def display_angle(angle: str | None) -> Iterator[None]:
    """Show gyro coefficients in ``angle`` (N in angle/sqrt(h), B in angle/h) inside the block.

    None keeps the customary choice (:data:`CUSTOMARY_GYRO_ANGLE`). The CLI's
    ``--display-units`` sets it for a whole command (analyze, fit, report, diagnose).

    Raises
    ------
    ValueError
        If ``angle`` is not an angle unit (the message names what it is).
    """
    if angle is not None:
        unit = parse_unit(angle)
        if unit.quantity != "angle":
            raise ValueError(
                f"--display-units takes an angle unit (deg, rad, arcsec, ...), but {angle!r} is "
                f"{_article(unit.quantity)}"
            )
    token = _DISPLAY_ANGLE.set(angle)
    try:
        yield
    finally:
        _DISPLAY_ANGLE.reset(token)


def customary_gyro_rate(rate: str | None) -> str | None:
    """The rate unit whose :func:`display_unit` s are a gyro's customary ones, or None.

    The angle of ``rate`` per hour, radians and revolutions shown as degrees
    (:data:`CUSTOMARY_GYRO_ANGLE`): ``deg/s``, ``rad/s`` and ``arcsec/s`` give ``deg/h`` (N in
    deg/√h, B in deg/h, K in deg/h/√h, R in deg/h²); inside :func:`display_angle` the angle
    chosen there. None when ``rate`` is not an angle per time unit.

    Parameters
    ----------
    rate : str or None
        A rate unit (``deg/s``, ``rad/s``, ``dph``, ...).
    """
    split = None if rate is None else _split_rate(rate)
    if split is None or split[0] not in ANGLE_UNITS:
        return None
    chosen = _DISPLAY_ANGLE.get()
    return f"{chosen or CUSTOMARY_GYRO_ANGLE.get(split[0], split[0])}/h"


def customary_unit(rate: str, name: str | tuple[float, float], unit: str | Unit) -> str:
    """The customary unit of a coefficient of a model in ``rate`` (as datasheets quote it).

    Gyroscopes: the angle of ``rate`` per hour, radians shown as degrees
    (:func:`customary_gyro_rate`: N in deg/√h, B in deg/h, K in deg/h/√h, R in deg/h² for
    deg/s and rad/s alike; the model keeps its own unit, e.g. rad/s/√Hz in the JSON).
    Accelerometers: velocity random walk in m/s/√h, bias instability and Gauss-Markov sigma
    in µg, acceleration random walk in m/s²/√s (= m/s³/√Hz, as Kalibr and the simulators take
    it), velocity quantization in m/s, ramp in
    m/s²/h (:data:`ACCELEROMETER_CUSTOMARY`).
    Anything else (the record unit, a parameter without a customary unit) keeps ``unit``.

    Parameters
    ----------
    rate : str
        The model's rate unit.
    name : str or (float, float)
        The coefficient's symbol (``N``, ``sigma_2``) or its powers of rate and time.
    unit : str or Unit
        The coefficient's unit in the model (returned when there is no customary one).
    """
    own = parse_unit(unit)
    try:
        kind = sensor_kind(rate)
    except ValueError:
        return own.text
    symbol = name.rsplit("_", 1)[0] if isinstance(name, str) and name[-1:].isdigit() else name
    candidate: str | None = None
    if kind == "gyro":
        customary = customary_gyro_rate(rate)
        if customary is not None:
            try:
                candidate = display_unit(customary, own)
            except ValueError:
                candidate = None
    elif kind == "accelerometer" and isinstance(symbol, str):
        candidate = ACCELEROMETER_CUSTOMARY.get(symbol)
    if candidate is None or not parse_unit(candidate).same_dimension(own):
        if own.quantity in ("time", "frequency"):
            return "s" if own.quantity == "time" else "Hz"
        return own.text
    return candidate


def coefficient_text(rate: str | None, rate_power: float, time_power: float) -> str:
    """Text of the unit ``rate^rate_power * s^time_power`` of a coefficient in a model's units.

    The unit a model JSON (and the diagnosis JSON's ``params``) holds a value in: ``N`` of a
    ``deg/s`` model in ``deg/sqrt(s)``, of a ``rad/s`` model in ``rad/sqrt(s)``
    (:func:`coefficient_unit`). Parameters without a rate power are times (``s``),
    frequencies (``Hz``) or dimensionless (``""``). Without a rate unit (or one that is not a
    rate), a symbolic ``rate*s^0.5``-style text.

    Parameters
    ----------
    rate : str or None
        The model's rate unit, or None when it is not known.
    rate_power, time_power : float
        The coefficient's powers of the rate and of seconds
        (:class:`~allanite.terms.base.ParamSpec` ``rate`` and ``time``).
    """
    if rate_power == 0:
        return {1.0: "s", -1.0: "Hz", 0.0: ""}.get(float(time_power), f"s^{time_power:g}")
    if rate is not None:
        try:
            return coefficient_unit(rate, rate_power, time_power).text
        except ValueError:
            pass
    text = (rate or "rate") if rate_power == 1 else f"({rate or 'rate'})^{rate_power:g}"
    return text if time_power == 0 else f"{text}*s^{time_power:g}"


def customary_value(name: str, value: float, unit: str, rate: str | None) -> tuple[float, str]:
    """``(value, unit)`` of a coefficient in the customary unit ``allanite fit`` shows.

    The one conversion of a term's coefficient for display, shared by the diagnosis text
    (:func:`allanite.diagnosis.verdict.format_params`) and the export notes of the simulator
    formats (:func:`allanite.formats.base.describe_term`): :func:`customary_unit` of
    the model's rate unit ``rate`` (a gyro's N in deg/sqrt(h), B and sigma in deg/h, K in
    deg/h/sqrt(h), deg/s and rad/s alike; an accelerometer's N in m/s/sqrt(h), B in ug, ...),
    the value converted to it. Times stay in s, frequencies in Hz; without ``rate``, without
    a ``unit`` or when the unit cannot be converted, the value and unit are returned as given.

    Parameters
    ----------
    name : str
        The coefficient's symbol (``N``, ``sigma``, ``tau_c``, ``sigma_2``).
    value : float
        Its value in ``unit``.
    unit : str
        Its unit in the model (:func:`coefficient_text`).
    rate : str or None
        The model's rate unit.
    """
    if rate is None or not unit or unit in ("s", "Hz"):
        return value, unit
    try:
        shown = customary_unit(rate, name, unit)
        return convert(value, unit, shown), shown
    except ValueError:
        return value, unit
