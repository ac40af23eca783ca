"""Kalibr ``imu.yaml``: continuous-time noise and bias random-walk densities (SI).

==========================  ====================  ==========================================
key                         unit                  model term
==========================  ====================  ==========================================
gyroscope_noise_density     rad/s/sqrt(Hz)        White N (gyro)
gyroscope_random_walk       rad/s^2/sqrt(Hz)      RateRandomWalk K (gyro)
accelerometer_noise_density m/s^2/sqrt(Hz)        White N (accel)
accelerometer_random_walk   m/s^3/sqrt(Hz)        RateRandomWalk K (accel)
update_rate                 Hz                    the rate
==========================  ====================  ==========================================

Kalibr's discrete law is std = density sqrt(rate) for the white noise and random-walk
increments of std ``random_walk / sqrt(rate)``, exactly allanite's White and RateRandomWalk.
Flicker and Gauss-Markov terms are projected onto the random walk over a stated tau range.
Kalibr's own reader needs all four densities: a file with one sensor's pair is read for that
sensor with a note saying Kalibr would refuse it, and a one-sensor model is written with a
comment saying the same; a sensor with one of its two keys is refused, naming a misspelling.

References
----------
ETH ASL, Kalibr wiki "IMU Noise Model"; ``kalibr_common/ConfigReader.py``.
"""

from __future__ import annotations

import dataclasses

from allanite.formats._densities import HOLDS as HOLDS  # the format protocol: what it holds
from allanite.formats._densities import density_entries, from_densities
from allanite.formats._text import load_yaml, number_text, update_keys, with_notes
from allanite.formats.base import ImuConfig, Written, number

NAME = "kalibr"
TITLE = "Kalibr imu.yaml"
SUFFIXES = (".yaml", ".yml")
KEYS = {
    "gyro": ("gyroscope_noise_density", "gyroscope_random_walk"),
    "accel": ("accelerometer_noise_density", "accelerometer_random_walk"),
}
UNITS = {
    "gyroscope_noise_density": "rad/s/sqrt(Hz)",
    "gyroscope_random_walk": "rad/s^2/sqrt(Hz)",
    "accelerometer_noise_density": "m/s^2/sqrt(Hz)",
    "accelerometer_random_walk": "m/s^3/sqrt(Hz)",
    "update_rate": "Hz",
}

#: the keys of a Kalibr imu.yaml besides the densities (``kalibr_common/ConfigReader.py``)
OTHER_KEYS = ("update_rate", "rostopic", "time_offset")


def has_keys(text: str) -> bool:
    """Whether ``text`` names any of the four density keys (a one-sensor file holds two)."""
    return any(key in text for pair in KEYS.values() for key in pair)


def sniff(text: str) -> bool:
    """Top-level Kalibr keys (OpenVINS nests them under ``imu0:``)."""
    return has_keys(text) and "imu0:" not in text


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read the densities (``update_rate`` gives the rate unless ``rate`` is given)."""
    data = load_yaml(text, "Kalibr imu.yaml")
    if rate is None and "update_rate" in data:
        rate = number(data["update_rate"], "Kalibr imu.yaml: update_rate") or None
    config = from_densities(
        data, KEYS, fmt=NAME, rate=rate, what="Kalibr imu.yaml", other_keys=OTHER_KEYS
    )
    absent = tuple(incomplete_note(s) for s in KEYS if getattr(config, s) is None)
    config = dataclasses.replace(config, notes=(*config.notes, *absent))
    topic = data.get("rostopic")
    return dataclasses.replace(config, topic=topic) if isinstance(topic, str) else config


def incomplete_note(sensor: str) -> str:
    """The note on a file without one sensor's densities: Kalibr itself would not read it."""
    n_key, w_key = KEYS[sensor]
    return (
        f"Kalibr imu.yaml: no {n_key} / {w_key}: Kalibr's own reader needs all four densities "
        f"and would refuse this file; add the {sensor} densities before using it with Kalibr"
    )


def ros_topic(config: ImuConfig) -> str:
    """The ``rostopic`` of a config: the topic it names (made absolute), else ``/imu0``."""
    topic = config.topic.strip()
    return "/" + topic.lstrip("/") if topic else "/imu0"


def entries(
    config: ImuConfig, rate: float | None, tau_range: tuple[float, float] | None
) -> tuple[dict[str, float], list[str], list[str]]:
    """``(values by key, dropped, projections)`` of the config (shared by OpenVINS)."""
    return density_entries(config, KEYS, rate, tau_range)


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
    rostopic: str | None = None,
) -> Written:
    """Kalibr ``imu.yaml`` text (into ``template`` when given, keeping its other lines).

    ``rostopic`` defaults to the config's topic (an SDF's ``<topic>``), else ``/imu0``.
    """
    rate = rate or config.rate
    values, dropped, projections = entries(config, rate, tau_range)
    if template is not None:
        text = update_keys(template, {k: number_text(v) for k, v in values.items()})
        if rate:
            text = update_keys(text, {"update_rate": number_text(rate)})
        return Written(with_notes(text, dropped, projections, config.sensors), dropped, projections)
    lines = ["# IMU noise model exported by allanite (continuous-time densities, SI units)"]
    for key in sorted(values):
        lines.append(f"{key}: {number_text(values[key])}  # {UNITS[key]}")
    lines.append(f"rostopic: {rostopic or ros_topic(config)}")
    if rate:
        lines.append(f"update_rate: {number_text(rate)}  # Hz")
    lines.extend(f"# {incomplete_note(s)}" for s in KEYS if KEYS[s][0] not in values)
    lines.extend(f"# not representable in imu.yaml, dropped: {d}" for d in dropped)
    lines.extend(f"# projected: {p}" for p in projections)
    return Written("\n".join(lines) + "\n", dropped, projections)
