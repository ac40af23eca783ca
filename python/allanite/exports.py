"""Export a gyro noise model to MATLAB ``gyroparams`` and Kalibr ``imu.yaml``.

Kept for compatibility: these are thin wrappers over :mod:`allanite.formats` (the one place
where every simulator/estimator format is read and written, see
:mod:`allanite.formats.matlab` and :mod:`allanite.formats.kalibr` for the fields and units).
Terms a format cannot hold are projected or dropped there, and listed in ``not_exported``.

References
----------
MathWorks, "gyroparams" and "Inertial Sensor Noise Analysis Using Allan Variance";
ETH ASL, Kalibr wiki "IMU Noise Model".
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from allanite.formats import kalibr, matlab
from allanite.formats.base import ImuConfig, sensor_model
from allanite.io.atomic import atomic_output
from allanite.model import NoiseModel
from allanite.terms import RateRandomWalk, Term, White

__all__ = [
    "KALIBR_UNITS",
    "MATLAB_UNITS",
    "kalibr_imu",
    "kalibr_imu_yaml",
    "matlab_gyroparams",
    "matlab_gyroparams_script",
    "save_kalibr_imu_yaml",
    "save_matlab_gyroparams",
]

MATLAB_UNITS = {k: v for k, v in matlab.UNITS["gyro"].items() if k != "ConstantBias"}
KALIBR_UNITS = dict(kalibr.UNITS)


def _gyro_config(model: NoiseModel, rate: float | None = None) -> ImuConfig:
    if not isinstance(model, NoiseModel):
        raise TypeError(f"export a NoiseModel (e.g. fit(...).model), got {type(model).__name__}")
    for kind in ("white", "rrw", "flicker"):
        if len(model.terms_of_type(kind)) > 1:
            raise ValueError(
                f"the model has {len(model.terms_of_type(kind))} {kind!r} terms; merge them "
                "before exporting"
            )
    return ImuConfig(gyro=model.in_units("rad/s"), rate=rate)


def matlab_gyroparams(model: NoiseModel) -> dict[str, Any]:
    """MATLAB ``gyroparams`` fields of ``model`` in SI units (imuSensor at 100 Hz).

    Returns
    -------
    dict
        ``{"NoiseDensity": ..., "BiasInstability": ..., "RandomWalk": ..., "NoiseType":
        "single-sided", "BiasInstabilityCoefficients": MATLAB text, "units": {...},
        "not_exported": [what was dropped or projected]}``; the bias instability is the
        driving std of imuSensor's first-order filter (see :mod:`allanite.formats.matlab`).
    """
    table, dropped, projections = matlab.fields(_gyro_config(model))
    gyro = table["gyro"]
    return {
        **{key: float(gyro[key]) for key in matlab.FIELDS},
        "NoiseType": "single-sided",
        "BiasInstabilityCoefficients": gyro.get(matlab.COEFFICIENTS, ""),
        "units": dict(MATLAB_UNITS),
        "not_exported": dropped + projections,
    }


def matlab_gyroparams_script(model: NoiseModel, name: str = "gyro") -> str:
    """MATLAB code that builds the ``gyroparams`` object, with the units in comments."""
    return matlab.write(_gyro_config(model), names={"gyro": name}).text


def _accel(density: float | None, walk: float | None) -> NoiseModel | None:
    if density is None and walk is None:
        return None
    terms: list[Term] = []
    if density:
        terms.append(White(N=float(density)))
    if walk:
        terms.append(RateRandomWalk(K=float(walk)))
    return sensor_model(terms, "accel")


def kalibr_imu(
    model: NoiseModel,
    update_rate: float,
    *,
    accelerometer_noise_density: float | None = None,
    accelerometer_random_walk: float | None = None,
    rostopic: str = "/imu0",
) -> dict[str, Any]:
    """Kalibr ``imu.yaml`` entries for the gyro ``model`` (SI units).

    Parameters
    ----------
    model : NoiseModel
        Gyro noise model.
    update_rate : float
        IMU sampling rate in Hz.
    accelerometer_noise_density, accelerometer_random_walk : float, optional
        Accelerometer densities in SI units (the accelerometer model).
    rostopic : str
        IMU topic.

    Returns
    -------
    dict
        Keys of ``imu.yaml`` plus ``not_exported`` (what was dropped or projected).
    """
    if not update_rate > 0:
        raise ValueError(f"update_rate must be a positive rate in Hz, got {update_rate!r}")
    config = _gyro_config(model, update_rate)
    accel = _accel(accelerometer_noise_density, accelerometer_random_walk)
    if accel is not None:
        config = ImuConfig(gyro=config.gyro, accel=accel, rate=update_rate)
    values, dropped, projections = kalibr.entries(config, update_rate, None)
    out: dict[str, Any] = {"rostopic": rostopic, "update_rate": float(update_rate)}
    out.update(values)
    out["not_exported"] = dropped + projections
    return out


def kalibr_imu_yaml(model: NoiseModel, update_rate: float, **kwargs: Any) -> str:
    """Text of a Kalibr ``imu.yaml`` (see :func:`kalibr_imu`), units in comments."""
    rostopic = kwargs.pop("rostopic", "/imu0")
    config = _gyro_config(model, update_rate)
    accel = _accel(
        kwargs.pop("accelerometer_noise_density", None),
        kwargs.pop("accelerometer_random_walk", None),
    )
    if kwargs:
        raise TypeError(f"unexpected arguments {', '.join(kwargs)}")
    if accel is not None:
        config = ImuConfig(gyro=config.gyro, accel=accel, rate=update_rate)
    return kalibr.write(config, rate=update_rate, rostopic=rostopic).text


def save_kalibr_imu_yaml(
    path: str | Path, model: NoiseModel, update_rate: float, **kwargs: Any
) -> None:
    """Write :func:`kalibr_imu_yaml` to ``path`` atomically."""
    text = kalibr_imu_yaml(model, update_rate, **kwargs)
    with atomic_output(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")


def save_matlab_gyroparams(path: str | Path, model: NoiseModel, name: str = "gyro") -> None:
    """Write :func:`matlab_gyroparams_script` to ``path`` (a ``.m`` file) atomically."""
    text = matlab_gyroparams_script(model, name)
    with atomic_output(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
