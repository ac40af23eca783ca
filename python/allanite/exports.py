"""Export a gyro noise model to what simulators and calibration tools read.

MATLAB ``gyroparams`` (Sensor Fusion and Tracking / Navigation Toolbox), SI units:

=================  ===================  ==========================================
field              unit                 from the model
=================  ===================  ==========================================
NoiseDensity       (rad/s)/sqrt(Hz)     N, angle random walk (rad/sqrt(s))
BiasInstability    rad/s                B, bias instability (ADEV floor / 0.664)
RandomWalk         (rad/s)*sqrt(Hz)     K, rate random walk (rad/s/sqrt(s))
=================  ===================  ==========================================

MathWorks' Allan-variance example sets these fields to exactly N, B and K read off the Allan
deviation, which is the convention followed here.

Kalibr ``imu.yaml`` (continuous-time densities), SI units:

==========================  ====================  ======================================
key                         unit                  from the model
==========================  ====================  ======================================
gyroscope_noise_density     rad/s/sqrt(Hz)        N
gyroscope_random_walk       rad/s^2/sqrt(Hz)      K
accelerometer_noise_density m/s^2/sqrt(Hz)        given by the caller (no gyro model)
accelerometer_random_walk   m/s^3/sqrt(Hz)        given by the caller
update_rate                 Hz                    sampling rate
==========================  ====================  ======================================

Terms the formats cannot hold (quantization, ramp, Gauss-Markov, sinusoids) are not exported;
:func:`matlab_gyroparams` and :func:`kalibr_imu` list them under ``"not_exported"`` so nothing
is dropped silently.

References
----------
MathWorks, "gyroparams" and "Inertial Sensor Noise Analysis Using Allan Variance";
ETH ASL, Kalibr wiki "IMU Noise Model".
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from allanite.io.atomic import atomic_output
from allanite.model import NoiseModel
from allanite.terms import Flicker, RateRandomWalk, Term, White

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

MATLAB_UNITS = {
    "NoiseDensity": "(rad/s)/sqrt(Hz)",
    "BiasInstability": "rad/s",
    "RandomWalk": "(rad/s)*sqrt(Hz)",
}
KALIBR_UNITS = {
    "gyroscope_noise_density": "rad/s/sqrt(Hz)",
    "gyroscope_random_walk": "rad/s^2/sqrt(Hz)",
    "accelerometer_noise_density": "m/s^2/sqrt(Hz)",
    "accelerometer_random_walk": "m/s^3/sqrt(Hz)",
    "update_rate": "Hz",
}


def _one(model: NoiseModel, cls: type[Term], field: str) -> float:
    found = model.terms_of_type(cls)
    if len(found) > 1:
        raise ValueError(
            f"the model has {len(found)} {cls.type!r} terms; merge them before exporting"
        )
    return float(getattr(found[0], field)) if found else 0.0


def _not_exported(model: NoiseModel) -> list[str]:
    return [t.type for t in model.terms if not isinstance(t, (White, Flicker, RateRandomWalk))]


def _si(model: NoiseModel) -> NoiseModel:
    if not isinstance(model, NoiseModel):
        raise TypeError(f"export a NoiseModel (e.g. fit(...).model), got {type(model).__name__}")
    return model.in_units("rad/s")


def matlab_gyroparams(model: NoiseModel) -> dict[str, Any]:
    """MATLAB ``gyroparams`` fields of ``model`` in SI units (see the module docstring).

    Returns
    -------
    dict
        ``{"NoiseDensity": N, "BiasInstability": B, "RandomWalk": K, "units": {...},
        "not_exported": [term types left out]}``, values in rad-based SI units.
    """
    si = _si(model)
    return {
        "NoiseDensity": _one(si, White, "N"),
        "BiasInstability": _one(si, Flicker, "B"),
        "RandomWalk": _one(si, RateRandomWalk, "K"),
        "units": dict(MATLAB_UNITS),
        "not_exported": _not_exported(si),
    }


def matlab_gyroparams_script(model: NoiseModel, name: str = "gyro") -> str:
    """MATLAB code that builds the ``gyroparams`` object, with the units in comments."""
    if not name.isidentifier():
        raise ValueError(f"name must be a MATLAB identifier, got {name!r}")
    p = matlab_gyroparams(model)
    fields = ("NoiseDensity", "BiasInstability", "RandomWalk")
    lines = ["% gyro noise parameters exported by allanite (SI units)", f"{name} = gyroparams( ..."]
    for i, key in enumerate(fields):
        end = ");" if i == len(fields) - 1 else ", ..."
        lines.append(f"    '{key}', {p[key]:.10g}{end}  % {MATLAB_UNITS[key]}")
    if p["not_exported"]:
        lines.append(f"% not representable in gyroparams: {', '.join(p['not_exported'])}")
    return "\n".join(lines) + "\n"


def kalibr_imu(
    model: NoiseModel,
    update_rate: float,
    *,
    accelerometer_noise_density: float | None = None,
    accelerometer_random_walk: float | None = None,
    rostopic: str = "/imu0",
) -> dict[str, Any]:
    """Kalibr ``imu.yaml`` entries for the gyro ``model`` (SI units, see the module docstring).

    Parameters
    ----------
    model : NoiseModel
        Gyro noise model.
    update_rate : float
        IMU sampling rate in Hz.
    accelerometer_noise_density, accelerometer_random_walk : float, optional
        Accelerometer densities in m/s^2/sqrt(Hz) and m/s^3/sqrt(Hz); Kalibr needs them, a gyro
        model does not have them.
    rostopic : str
        ROS topic of the IMU.
    """
    if not update_rate > 0:
        raise ValueError(f"update_rate must be a positive rate in Hz, got {update_rate!r}")
    si = _si(model)
    out: dict[str, Any] = {"rostopic": rostopic, "update_rate": float(update_rate)}
    if accelerometer_noise_density is not None:
        out["accelerometer_noise_density"] = float(accelerometer_noise_density)
    if accelerometer_random_walk is not None:
        out["accelerometer_random_walk"] = float(accelerometer_random_walk)
    out["gyroscope_noise_density"] = _one(si, White, "N")
    out["gyroscope_random_walk"] = _one(si, RateRandomWalk, "K")
    out["not_exported"] = _not_exported(si)
    return out


def kalibr_imu_yaml(model: NoiseModel, update_rate: float, **kwargs: Any) -> str:
    """Text of a Kalibr ``imu.yaml`` (see :func:`kalibr_imu`), units in comments."""
    entries = kalibr_imu(model, update_rate, **kwargs)
    skipped = entries.pop("not_exported")
    lines = ["# IMU noise model exported by allanite (continuous-time densities, SI units)"]
    for key, value in entries.items():
        if key == "rostopic":
            lines.append(f"rostopic: {value}")
            continue
        lines.append(f"{key}: {value:.10g}  # {KALIBR_UNITS[key]}")
    if skipped:
        lines.append(f"# not representable in imu.yaml: {', '.join(skipped)}")
    return "\n".join(lines) + "\n"


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
