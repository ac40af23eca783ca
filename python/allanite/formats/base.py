"""What every simulator/estimator config format shares: the IMU model and the write report.

A config is read into an :class:`ImuConfig`: a gyro :class:`~allanite.model.NoiseModel` in
rad/s and an accelerometer model in m/s^2 (either may be absent), each built from the
simulator's own discrete law (see the format modules), plus the update rate and the constant
offsets the format carries. Writing returns a :class:`Written`: the text and, never silently,
what the format could not hold and the projections made instead.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Collection, Iterable
from dataclasses import dataclass, field
from typing import Any

from allanite.model import NoiseModel
from allanite.terms import Term
from allanite.units import coefficient_text, customary_value

__all__ = [
    "ACCEL_UNIT",
    "GYRO_UNIT",
    "SENSORS",
    "ImuConfig",
    "Written",
    "closest_key",
    "describe_term",
    "key_notes",
    "merge_same",
    "need_rate",
    "notes_of_others",
    "number",
    "sensor_model",
    "shown",
    "single",
]

GYRO_UNIT = "rad/s"
ACCEL_UNIT = "m/s^2"
#: sensor name -> SI unit of its model
SENSORS: dict[str, str] = {"gyro": GYRO_UNIT, "accel": ACCEL_UNIT}


def sensor_model(terms: list[Term] | tuple[Term, ...], sensor: str) -> NoiseModel:
    """A NoiseModel of ``terms`` in the SI unit of ``sensor`` (rad/s gyro, m/s^2 accel)."""
    return NoiseModel(tuple(terms), {"rate": SENSORS[sensor], "time": "s"})


@dataclass(frozen=True)
class ImuConfig:
    """An IMU noise configuration read from (or to be written to) a simulator format.

    Attributes
    ----------
    gyro, accel : NoiseModel or None
        Noise models in rad/s and m/s^2 (SI), per axis (the formats give one value for all
        axes unless ``notes`` says otherwise).
    rate : float or None
        Update rate in Hz when the config states it (or it was given).
    offsets : dict
        Constant, deterministic offsets the format carries (``"gyro"``/``"accel"`` -> value in
        SI); a constant has no Allan variance and is not a noise Term.
    source_format : str
        Name of the format it was read from (``""`` when built in code).
    notes : tuple of str
        What the reader noticed (axes that differ, simulator defaults used, ...).
    topic : str
        The IMU topic the config names (an SDF's ``<topic>``, Kalibr's ``rostopic``), ``""``
        when it names none; written into formats that name one.
    axes : tuple of str
        The axes (``"x"``, ``"y"``, ``"z"``) the models describe, for formats that hold each
        axis apart (an SDF): a write sets only these and keeps the others as the template has
        them. Empty: every axis.
    """

    gyro: NoiseModel | None = None
    accel: NoiseModel | None = None
    rate: float | None = None
    offsets: dict[str, float] = field(default_factory=dict)
    source_format: str = ""
    notes: tuple[str, ...] = ()
    topic: str = ""
    axes: tuple[str, ...] = ()

    @property
    def sensors(self) -> tuple[str, ...]:
        """The sensors the config holds a model of (``("gyro", "accel")``, ``("gyro",)``, ...)."""
        return tuple(s for s in SENSORS if getattr(self, s) is not None)

    def model(self, sensor: str = "gyro", *, option: str = "--sim-sensor") -> NoiseModel:
        """The model of one sensor, with a clear error when the config has none.

        ``option`` is the command-line option the error names to choose the other sensor.
        """
        if sensor not in SENSORS:
            raise ValueError(f"sensor must be 'gyro' or 'accel', got {sensor!r}")
        found: NoiseModel | None = getattr(self, sensor)
        if found is None:
            other = "accel" if sensor == "gyro" else "gyro"
            hint = (
                f"; it holds {'an' if other == 'accel' else 'a'} {other} model: choose it with "
                f"sensor={other!r} (CLI: {option} {other})"
                if getattr(self, other) is not None
                else ""
            )
            raise ValueError(
                f"the {self.source_format or 'given'} config holds no {sensor} noise model{hint}"
            )
        return found

    def with_model(self, sensor: str, model: NoiseModel) -> ImuConfig:
        """A copy with one sensor's model replaced (converted to SI)."""
        si = model if model.units["rate"] == SENSORS[sensor] else model.in_units(SENSORS[sensor])
        return ImuConfig(
            gyro=si if sensor == "gyro" else self.gyro,
            accel=si if sensor == "accel" else self.accel,
            rate=self.rate,
            offsets=dict(self.offsets),
            source_format=self.source_format,
            notes=self.notes,
            topic=self.topic,
            axes=self.axes,
        )

    def filled_from(self, template: ImuConfig) -> ImuConfig:
        """A copy that takes the sensors it has no model of from ``template``.

        For formats rewritten whole (a MATLAB script, a gnss-ins-sim dict): writing the
        accelerometer model into a template that holds the gyro's must keep the gyro's
        entries, as the formats edited in place do. A template sensor without any term (the
        zero entries a format needs) is not taken. The rate is this config's, else the
        template's.
        """
        models: dict[str, NoiseModel | None] = {}
        offsets = dict(self.offsets)
        for sensor in SENSORS:
            own: NoiseModel | None = getattr(self, sensor)
            other: NoiseModel | None = getattr(template, sensor)
            if own is None and other is not None and other.terms:
                models[sensor] = other
                if sensor in template.offsets:
                    offsets[sensor] = template.offsets[sensor]
            else:
                models[sensor] = own
        return ImuConfig(
            gyro=models["gyro"],
            accel=models["accel"],
            rate=self.rate if self.rate is not None else template.rate,
            offsets=offsets,
            source_format=self.source_format,
            notes=self.notes,
            topic=self.topic,
        )


#: the sensor an export note is about: ``projected: gyro: ...``, ``dropped: accel/x: ...``
_NOTE_SENSOR = re.compile(r"^\s*(?:projected|dropped)\s*:\s*(gyro|accel)\b")


def notes_of_others(notes: Iterable[str], sensors: Collection[str]) -> list[str]:
    """The notes of an earlier write (``"projected: gyro: ..."``) about sensors not in ``sensors``.

    A write that sets one sensor (``model convert accel.json imu.m --template imu.m``) keeps
    what the template's notes said of the other sensor, whose entries it keeps too.
    """
    out = []
    for note in notes:
        match = _NOTE_SENSOR.match(note)
        if match is not None and match.group(1) not in sensors:
            out.append(note.strip())
    return out


@dataclass(frozen=True)
class Written:
    """Text of a config and what the format could not hold.

    Attributes
    ----------
    text : str
        The file content.
    dropped : list of str
        Terms (``"gyro: quantization Q=..."``) the format cannot hold, left out.
    projections : list of str
        Terms replaced by the closest term the format holds, with the tau range and the
        largest Allan-deviation error of the replacement.
    """

    text: str
    dropped: list[str] = field(default_factory=list)
    projections: list[str] = field(default_factory=list)

    def report(self) -> list[str]:
        """One line per dropped term and per projection (empty when the format held all)."""
        return [f"dropped {d}" for d in self.dropped] + [f"projected {p}" for p in self.projections]

    def lost(self, sensor: str, term: Term) -> list[str]:
        """The :meth:`report` lines in which the format dropped ``term`` or projected it away.

        A term the format cannot hold as it is (a second Gauss-Markov process where the format
        has one, a sensor filter) is named on the left of a projection (``... -> ...``) or in
        a dropped line, as :func:`describe_term` spells it; empty when the file holds it.

        Parameters
        ----------
        sensor : {"gyro", "accel"}
            The sensor the term belongs to.
        term : Term
            The term, in the units the config is written in (SI).
        """
        named = describe_term(term, sensor)
        return [
            line
            for line in self.report()
            if line.split(" ", 1)[1].startswith(f"{sensor}: ") and named in line.split(" -> ")[0]
        ]


def describe_term(term: Term, sensor: str | None = None) -> str:
    """A term as the export notes spell it, each value with its unit.

    E.g. ``markov (sigma=388.6 deg/h, tau_c=0.0238 s)``: with ``sensor`` (``"gyro"`` or
    ``"accel"``: the term is in that sensor's SI unit, :data:`SENSORS`) the coefficients are
    shown in the customary units ``allanite fit`` prints (a gyro's N in deg/sqrt(h), K in
    deg/h/sqrt(h); an accelerometer's N in m/s/sqrt(h)); without it the rate unit is not
    known and only times (s) and frequencies (Hz) carry a unit.
    """
    rate = SENSORS.get(sensor) if sensor is not None else None
    specs = {p.name: p for p in type(term).params + type(term).optional}
    parts = []
    for name, value in term.to_dict().items():
        if name == "type":
            continue
        spec = specs.get(name)
        if spec is None or not isinstance(value, (int, float)):
            parts.append(f"{name}={value}")
            continue
        # without the sensor the rate unit is not known: only times and frequencies have one
        own = coefficient_text(rate, spec.rate, spec.time) if rate or spec.rate == 0 else ""
        shown, unit = customary_value(name, float(value), own, rate)
        parts.append(f"{name}={shown:.4g}" + (f" {unit}" if unit else ""))
    return f"{term.type} ({', '.join(parts)})"


def shown(value: Any, limit: int = 80) -> str:
    """A bounded repr of a config value for a message (nested and long values cut short)."""
    import reprlib

    short = reprlib.Repr()
    short.maxlevel, short.maxstring, short.maxother = 3, limit, limit
    short.maxlist = short.maxtuple = short.maxdict = short.maxset = 6
    text = short.repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def number(value: Any, where: str) -> float:
    """A finite, non-negative float from a config value, or a ValueError naming ``where``."""
    if isinstance(value, bool):
        raise ValueError(f"{where}: expected a number, got {shown(value)}")
    if isinstance(value, str) and len(value) > 1000:
        raise ValueError(f"{where}: expected a number, got {shown(value)} ({len(value)} chars)")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: expected a number, got {shown(value)}") from None
    if math.isnan(out) or out < 0:
        raise ValueError(f"{where}: expected a non-negative number, got {shown(value)}")
    return out


def closest_key(name: str, known: Iterable[str]) -> str | None:
    """The known key ``name`` is most likely a misspelling of (difflib ratio >= 0.8), or None."""
    found = difflib.get_close_matches(name, list(known), n=1, cutoff=0.8)
    return found[0] if found else None


def key_notes(
    found: Iterable[Any], known: Collection[str], what: str, *, strict: bool = False
) -> list[str]:
    """Warnings on the keys of a config that its reader does not know.

    A misspelled key (``gyroscope_noise_denisty``) is otherwise ignored silently and its value
    taken as absent. Each unknown key close to a known one is named with that key; with
    ``strict`` (a format whose every key the reader knows, e.g. Kalibr's imu.yaml) every
    unknown key is named, otherwise (a file that holds many other settings) only near misses.
    """
    out = []
    for key in found:
        if not isinstance(key, str) or key in known:
            continue
        near = closest_key(key, known)
        if near is not None:
            out.append(f"{what}: unknown key {key!r} ignored; did you mean {near!r}?")
        elif strict:
            out.append(f"{what}: unknown key {key!r} ignored")
    return out


def need_rate(rate: float | None, what: str) -> float:
    """The update rate, or a ValueError saying why the format needs it."""
    if rate is None:
        raise ValueError(
            f"{what} is a per-sample quantity, so the update rate is needed: give it with "
            "rate= (CLI: --rate HZ; diagnose: --sim-rate HZ)"
        )
    if not (math.isfinite(rate) and rate > 0):
        raise ValueError(f"the update rate must be a positive frequency in Hz, got {rate!r}")
    return float(rate)


def single(model: NoiseModel, kind: str) -> Term | None:
    """The one term of a type in ``model`` (None when absent); callers merge duplicates first."""
    found = model.terms_of_type(kind)
    return found[0] if found else None


def merge_same(model: NoiseModel) -> NoiseModel:
    """Merge repeated white, rrw, quantization and turn-on terms (their variances add)."""
    out: list[Term] = []
    merged: dict[str, Term] = {}
    for term in model.terms:
        if term.type in ("white", "rrw", "quantization", "turn_on_bias") and term.type in merged:
            old = merged[term.type]
            name = term.params[0].name
            value = math.hypot(getattr(old, name), getattr(term, name))
            new = old.with_values(**{name: value})
            out[out.index(old)] = new
            merged[term.type] = new
            continue
        if term.type in ("white", "rrw", "quantization", "turn_on_bias"):
            merged[term.type] = term
        out.append(term)
    if len(out) == len(model.terms):
        return model
    return sensor_model(out, "accel" if model.units["rate"] == ACCEL_UNIT else "gyro")
