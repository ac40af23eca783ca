"""allanite's own NoiseModel JSON (one sensor) as a config format.

The model is read in its own units and converted to SI (rad/s for a gyro, m/s^2 for an
accelerometer, from the dimension of its unit); writing gives the gyro model (or the
accelerometer model when there is no gyro) with every term, nothing dropped.
"""

from __future__ import annotations

from allanite.formats.base import ACCEL_UNIT, GYRO_UNIT, ImuConfig, Written
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

NAME = "allanite"
TITLE = "allanite NoiseModel JSON"
SUFFIXES = (".json",)
#: every term type: the model JSON holds them all
HOLDS = frozenset(TERM_TYPES)


def sniff(text: str) -> bool:
    """A JSON object with ``terms``.

    A model JSON without ``units`` is still one: reading it says which field is missing,
    instead of "cannot tell which config this is".
    """
    return '"terms"' in text


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read the model JSON (gyro or accelerometer from the dimension of its unit)."""
    model = NoiseModel.from_json(text)
    if model.sensor == "accelerometer":
        return ImuConfig(accel=model.in_units(ACCEL_UNIT), rate=rate, source_format=NAME)
    return ImuConfig(gyro=model.in_units(GYRO_UNIT), rate=rate, source_format=NAME)


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
) -> Written:
    """The model JSON of the gyro (or, without one, the accelerometer)."""
    model = config.gyro if config.gyro is not None else config.accel
    if model is None:
        raise ValueError("the config holds no noise model to write")
    dropped = []
    if config.gyro is not None and config.accel is not None:
        dropped.append(
            "accel: the model JSON holds one sensor; the accelerometer model (write it with "
            "--sensor accel, library: config.with_model or ImuConfig(accel=...))"
        )
    if template is not None:
        old = NoiseModel.from_json(template)
        if old.units["rate"] != model.units["rate"]:
            model = model.in_units(old.units["rate"])
    return Written(model.to_json() + "\n", dropped, [])
