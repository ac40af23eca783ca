"""VINS-Mono / VINS-Fusion config: ``gyr_n``, ``gyr_w``, ``acc_n``, ``acc_w``.

Read as continuous densities (``vins_estimator/src/parameters.cpp``; the units are
undocumented there): White N = gyr_n (rad/s/sqrt(Hz)), RateRandomWalk K = gyr_w
(rad/s^2/sqrt(Hz)); the config holds no IMU rate.
"""

from __future__ import annotations

from allanite.formats._densities import HOLDS as HOLDS  # the format protocol: what it holds
from allanite.formats._densities import density_entries, from_densities
from allanite.formats._text import load_yaml, number_text, update_keys, with_notes
from allanite.formats.base import ImuConfig, Written

NAME = "vins"
TITLE = "VINS-Mono / VINS-Fusion config (gyr_n, ...)"
SUFFIXES = (".yaml", ".yml")
KEYS = {"gyro": ("gyr_n", "gyr_w"), "accel": ("acc_n", "acc_w")}
#: unit of each key (continuous-time densities, SI, as Kalibr's)
UNITS = {
    KEYS["gyro"][0]: "rad/s/sqrt(Hz)",
    KEYS["gyro"][1]: "rad/s^2/sqrt(Hz)",
    KEYS["accel"][0]: "m/s^2/sqrt(Hz)",
    KEYS["accel"][1]: "m/s^3/sqrt(Hz)",
}


def sniff(text: str) -> bool:
    """``gyr_n`` or ``acc_n`` keys."""
    return "gyr_n" in text or "acc_n" in text


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read the densities."""
    data = load_yaml(text, "VINS config")
    return from_densities(data, KEYS, fmt=NAME, rate=rate, what="VINS config")


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
) -> Written:
    """VINS IMU lines (into ``template`` when given)."""
    rate = rate or config.rate
    densities, dropped, projections = density_entries(config, KEYS, rate, tau_range)
    values = {key: number_text(value) for key, value in densities.items()}
    if template is not None:
        text = with_notes(update_keys(template, values), dropped, projections, config.sensors)
        return Written(text, dropped, projections)
    lines = ["%YAML:1.0", "# IMU noise (continuous densities, SI units) written by allanite"]
    lines += [f"{k}: {v}" for k, v in values.items()]
    lines.extend(f"# dropped: {d}" for d in dropped)
    lines.extend(f"# projected: {p}" for p in projections)
    return Written("\n".join(lines) + "\n", dropped, projections)
