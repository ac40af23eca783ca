r"""AirSim ``settings.json`` IMU sensor (``SensorType`` 2).

Keys and units as ``AirLib/include/sensors/imu/ImuSimpleParams.hpp`` reads them:
``AngularRandomWalk`` (deg/sqrt(h)), ``GyroBiasStability`` (deg/h), ``GyroBiasStabilityTau``
(s), ``VelocityRandomWalk`` (mg sqrt(s), i.e. mg/sqrt(Hz)), ``AccelBiasStability`` (ug),
``AccelBiasStabilityTau`` (s); missing keys take AirSim's defaults (MPU-6000 values), as the
simulator does. The discrete law (``ImuSimple.hpp``), with ``s = sqrt(max(dt, 1 ms))``: white
std ``arw / s``; bias a pure random walk (it never decays) of increments ``B / sqrt(tau) s``.
Hence White ``N = arw sqrt(dt) / s`` and RateRandomWalk ``K = B / sqrt(tau) s / sqrt(dt)``:
``N = arw`` and ``K = B / sqrt(tau)`` up to 1 kHz, less white and more walk above it.
"""

from __future__ import annotations

import json
import math
from typing import Any

from allanite.errors import parse_json
from allanite.formats._densities import HOLDS
from allanite.formats.base import ImuConfig, Written, notes_of_others, number, sensor_model
from allanite.formats.projection import project_config
from allanite.terms import RateRandomWalk, Term, White
from allanite.units import STANDARD_GRAVITY

NAME = "airsim"
TITLE = "AirSim settings.json IMU"
SUFFIXES = (".json",)
G = STANDARD_GRAVITY  # AirSim's EarthUtils::Gravity and its literal 9.80665f
D2R = math.pi / 180.0
MIN_SAMPLE_TIME = 1e-3
#: key -> (factor to SI, default in the key's unit)
KEYS = {
    "AngularRandomWalk": (D2R / 60.0, 0.30),
    "GyroBiasStability": (D2R / 3600.0, 4.6),
    "GyroBiasStabilityTau": (1.0, 500.0),
    "VelocityRandomWalk": (G * 1e-3, 0.24),
    "AccelBiasStability": (G * 1e-6, 36.0),
    "AccelBiasStabilityTau": (1.0, 800.0),
}
#: unit of each key, as AirSim reads it
UNITS = {
    "AngularRandomWalk": "deg/sqrt(h)",
    "GyroBiasStabilityTau": "s",
    "GyroBiasStability": "deg/h",
    "VelocityRandomWalk": "mg*sqrt(s)",
    "AccelBiasStabilityTau": "s",
    "AccelBiasStability": "ug",
}
SENSOR_KEYS = {
    "gyro": ("AngularRandomWalk", "GyroBiasStability", "GyroBiasStabilityTau"),
    "accel": ("VelocityRandomWalk", "AccelBiasStability", "AccelBiasStabilityTau"),
}


def sniff(text: str) -> bool:
    """AirSim IMU keys or an AirSim settings file."""
    return any(k in text for k in KEYS) or ('"SettingsVersion"' in text and '"Imu"' in text)


def _find_block(data: Any) -> dict[str, Any] | None:
    if isinstance(data, dict):
        if data.get("SensorType") == 2 or any(k in data for k in KEYS):
            return data
        for value in data.values():
            found = _find_block(value)
            if found is not None:
                return found
    elif isinstance(data, list):
        for value in data:
            found = _find_block(value)
            if found is not None:
                return found
    return None


def _step(rate: float | None) -> tuple[float, float]:
    """``(dt, s)`` of the law; without a rate, rates up to 1 kHz (where the law is rate-free)."""
    dt = 1.0 / rate if rate else MIN_SAMPLE_TIME
    return dt, math.sqrt(max(dt, MIN_SAMPLE_TIME))


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read the IMU block (missing keys take AirSim's defaults, noted)."""
    try:
        data = parse_json(text, "the AirSim settings")
    except json.JSONDecodeError as exc:
        raise ValueError(f"AirSim settings are not valid JSON: {exc}") from None
    block = _find_block(data)
    if block is None:
        raise ValueError("AirSim settings: no IMU sensor (SensorType 2) found")
    values = {}
    defaulted = []
    for key, (factor, default) in KEYS.items():
        if key in block:
            values[key] = number(block[key], f"AirSim Imu {key}") * factor
        else:
            values[key] = default * factor
            defaulted.append(key)
    dt, s = _step(rate)
    models = {}
    for sensor, (white_key, bias_key, tau_key) in SENSOR_KEYS.items():
        terms: list[Term] = []
        if values[white_key] > 0:
            terms.append(White(N=values[white_key] * math.sqrt(dt) / s))
        if values[bias_key] > 0:
            k = values[bias_key] / math.sqrt(values[tau_key]) * s / math.sqrt(dt)
            terms.append(RateRandomWalk(K=k))
        models[sensor] = sensor_model(terms, sensor)
    notes = [f"AirSim defaults used for {', '.join(defaulted)}"] if defaulted else []
    if rate is None:
        notes.append("no rate given: the law assumed at most 1 kHz (rate-free there)")
    return ImuConfig(
        gyro=models["gyro"],
        accel=models["accel"],
        rate=rate,
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
    """``settings.json`` text (into ``template``'s IMU block when given)."""
    rate = rate or config.rate
    models, dropped, projections = project_config(config, HOLDS, rate=rate, tau_range=tau_range)
    if template is not None:
        try:
            data = parse_json(template, "the AirSim template")
        except json.JSONDecodeError as exc:
            raise ValueError(f"the AirSim template is not valid JSON: {exc}") from None
        block = _find_block(data)
        if block is None:
            raise ValueError("the AirSim template has no IMU sensor (SensorType 2) to write into")
    else:
        block = {"SensorType": 2, "Enabled": True}
        data = {"SettingsVersion": 1.2, "DefaultSensors": {"Imu": block}}
    dt, s = _step(rate)
    for sensor, model in models.items():
        white_key, bias_key, tau_key = SENSOR_KEYS[sensor]
        tau = float(block.get(tau_key, KEYS[tau_key][1]))
        white = model.terms_of_type("white")
        walk = model.terms_of_type("rrw")
        n = white[0].values()["N"] if white else 0.0
        k = walk[0].values()["K"] if walk else 0.0
        block[white_key] = n * s / math.sqrt(dt) / KEYS[white_key][0]
        block[bias_key] = k * math.sqrt(tau) * math.sqrt(dt) / s / KEYS[bias_key][0]
        block[tau_key] = tau
    earlier = data.get("_allanite_notes", [])
    kept = notes_of_others(earlier if isinstance(earlier, list) else [], config.sensors)
    if dropped or projections or kept:
        data["_allanite_notes"] = (
            [f"dropped: {d}" for d in dropped] + [f"projected: {p}" for p in projections] + kept
        )
    else:
        data.pop("_allanite_notes", None)
    return Written(json.dumps(data, indent=2) + "\n", dropped, projections)
