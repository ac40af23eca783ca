"""Gazebo classic SDF ``<imu>`` noise: the gz-sensors names without the dynamic bias.

``gazebo/sensors/GaussianNoiseModel.cc`` implements white noise (``stddev`` per sample), the
static bias (``bias_mean``, ``bias_stddev``, random sign) and ``precision``; it ignores
``dynamic_bias_*``. Reading therefore maps exactly as :mod:`allanite.formats.gz_sdf` without
the Gauss-Markov term (present elements are noted as ignored); writing holds white noise and
the turn-on bias, and projects or drops the rest. Never detected from content (the files are
the same SDF): choose it with ``--sim-format gazebo-classic`` / ``--to gazebo-classic``.
"""

from __future__ import annotations

import dataclasses

from allanite.formats import gz_sdf
from allanite.formats.base import ImuConfig, Written, sensor_model

NAME = "gazebo-classic"
TITLE = "Gazebo classic SDF <imu> noise (no dynamic bias)"
SUFFIXES = gz_sdf.SUFFIXES
HOLDS = frozenset({"white", "turn_on_bias"})
UNITS = gz_sdf.UNITS


def sniff(text: str) -> bool:
    """Never chosen from content: the SDF is the same as gz-sensors'."""
    return False


def read(text: str, *, rate: float | None = None, axis: str = "x") -> ImuConfig:
    """Read like gz-sensors, then remove the dynamic bias Gazebo classic does not simulate."""
    config = gz_sdf.read(text, rate=rate, axis=axis)
    notes = list(config.notes)
    models = {}
    for sensor in ("gyro", "accel"):
        model = getattr(config, sensor)
        if model is None:
            continue
        if model.terms_of_type("markov"):
            notes.append(f"{sensor}: dynamic_bias_* ignored (not implemented by Gazebo classic)")
        models[sensor] = sensor_model([t for t in model.terms if t.type != "markov"], sensor)
    return dataclasses.replace(
        config,
        gyro=models.get("gyro"),
        accel=models.get("accel"),
        source_format=NAME,
        notes=tuple(notes),
    )


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
) -> Written:
    """The ``<sensor type="imu">`` element without dynamic bias (see :func:`gz_sdf.write`)."""
    return gz_sdf.write(config, rate=rate, template=template, tau_range=tau_range, holds=HOLDS)
