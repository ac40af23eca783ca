"""MATLAB ``gyroparams`` / ``accelparams`` (Sensor Fusion and Tracking / Navigation Toolbox).

SI fields read and written (the imuSensor algorithm is closed source; the convention is
MathWorks' Allan-variance example, which sets these to N, B and K read off the curve):

=================  ===============================  ============================
field              unit (gyro; accel alike in m/s)  model term
=================  ===============================  ============================
NoiseDensity       (rad/s)/sqrt(Hz)                 White N
BiasInstability    rad/s                            Flicker B
RandomWalk         (rad/s)*sqrt(Hz)                 RateRandomWalk K
ConstantBias       rad/s                            constant offset
=================  ===============================  ============================

Read from a script: ``name = gyroparams('Field', value, ...)`` (with ``...`` continuations)
and ``name.Field = value;`` assignments; vector values take the first element (noted).
"""

from __future__ import annotations

import re

from allanite.formats._text import number_text
from allanite.formats.base import ImuConfig, Written, number, sensor_model
from allanite.formats.projection import project_config
from allanite.terms import Flicker, RateRandomWalk, Term, White

NAME = "matlab"
TITLE = "MATLAB gyroparams/accelparams script"
SUFFIXES = (".m",)
HOLDS = frozenset({"white", "flicker", "rrw"})
FIELDS = {"NoiseDensity": "white", "BiasInstability": "flicker", "RandomWalk": "rrw"}
UNITS = {
    "gyro": {
        "NoiseDensity": "(rad/s)/sqrt(Hz)",
        "BiasInstability": "rad/s",
        "RandomWalk": "(rad/s)*sqrt(Hz)",
        "ConstantBias": "rad/s",
    },
    "accel": {
        "NoiseDensity": "(m/s^2)/sqrt(Hz)",
        "BiasInstability": "m/s^2",
        "RandomWalk": "(m/s^2)*sqrt(Hz)",
        "ConstantBias": "m/s^2",
    },
}
FUNCTION = {"gyro": "gyroparams", "accel": "accelparams"}
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_VALUE = rf"(\[[^\]]*\]|{_NUMBER})"


def sniff(text: str) -> bool:
    """A ``gyroparams``/``accelparams`` call."""
    return "gyroparams" in text or "accelparams" in text


def _scalar(text: str, where: str, notes: list[str]) -> float:
    text = text.strip()
    if text.startswith("["):
        parts = [p for p in re.split(r"[\s,;]+", text.strip("[]").strip()) if p]
        if not parts:
            raise ValueError(f"{where}: empty vector")
        if any(p != parts[0] for p in parts):
            notes.append(f"{where} differs between axes; the model is the first axis'")
        text = parts[0]
    if where.endswith("ConstantBias"):
        return float(text)
    return number(text, where)


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read every ``gyroparams``/``accelparams`` object of the script."""
    code = re.sub(r"%[^\n]*", "", text).replace("...\n", " ")
    notes: list[str] = []
    fields: dict[str, dict[str, str]] = {}
    variables: dict[str, str] = {}
    for sensor, func in FUNCTION.items():
        for match in re.finditer(rf"(\w+)\s*=\s*{func}\s*\(([^)]*)\)", code):
            variables[match.group(1)] = sensor
            pairs = re.findall(rf"'(\w+)'\s*,\s*{_VALUE}", match.group(2))
            fields.setdefault(sensor, {}).update(dict(pairs))
    for match in re.finditer(rf"(\w+)\.(\w+)\s*=\s*{_VALUE}", code):
        owner = variables.get(match.group(1))
        if owner is not None:
            fields.setdefault(owner, {})[match.group(2)] = match.group(3)
    if not fields:
        raise ValueError("MATLAB script: no gyroparams(...) or accelparams(...) object found")
    models = {}
    offsets = {}
    for sensor, values in fields.items():
        terms: list[Term] = []
        for name, kind in FIELDS.items():
            if name not in values:
                continue
            v = _scalar(values[name], f"{FUNCTION[sensor]} {name}", notes)
            if v > 0:
                terms.append({"white": White, "flicker": Flicker, "rrw": RateRandomWalk}[kind](v))
        if "ConstantBias" in values:
            where = f"{FUNCTION[sensor]} ConstantBias"
            offsets[sensor] = _scalar(values["ConstantBias"], where, notes)
        ignored = sorted(set(values) - set(FIELDS) - {"ConstantBias"})
        if ignored:
            notes.append(f"{FUNCTION[sensor]}: {', '.join(ignored)} not part of the noise model")
        models[sensor] = sensor_model(terms, sensor)
    return ImuConfig(
        gyro=models.get("gyro"),
        accel=models.get("accel"),
        rate=rate,
        offsets=offsets,
        source_format=NAME,
        notes=tuple(notes),
    )


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
    names: dict[str, str] | None = None,
) -> Written:
    """MATLAB code building the ``gyroparams``/``accelparams`` objects (``template`` unused)."""
    names = {"gyro": "gyro", "accel": "accel", **(names or {})}
    for name in names.values():
        if not name.isidentifier():
            raise ValueError(f"name must be a MATLAB identifier, got {name!r}")
    models, dropped, projections = project_config(
        config, HOLDS, rate=rate or config.rate, tau_range=tau_range
    )
    lines: list[str] = []
    for sensor, model in models.items():
        values = {}
        for field, kind in FIELDS.items():
            found = model.terms_of_type(kind)
            values[field] = found[0].values()[found[0].params[0].name] if found else 0.0
        if sensor in config.offsets:
            values["ConstantBias"] = config.offsets[sensor]
        kind_text = "gyro" if sensor == "gyro" else "accelerometer"
        lines.append(f"% {kind_text} noise parameters exported by allanite (SI units)")
        lines.append(f"{names[sensor]} = {FUNCTION[sensor]}( ...")
        keys = list(values)
        for i, key in enumerate(keys):
            end = ");" if i == len(keys) - 1 else ", ..."
            lines.append(f"    '{key}', {number_text(values[key])}{end}  % {UNITS[sensor][key]}")
    skipped = dropped + projections
    if skipped:
        lines.append(f"% not representable in gyroparams/accelparams: {'; '.join(skipped)}")
    return Written("\n".join(lines) + "\n", dropped, projections)
