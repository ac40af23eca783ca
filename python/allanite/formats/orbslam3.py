"""ORB-SLAM3 settings: ``IMU.NoiseGyro``, ``IMU.GyroWalk``, ``IMU.NoiseAcc``, ``IMU.AccWalk``.

Continuous densities (``src/Tracking.cc`` converts them to discrete as ``Ng sqrt(f)`` and
``Ngw / sqrt(f)``, ``f = IMU.Frequency``): White N = NoiseGyro, RateRandomWalk K = GyroWalk.
"""

from __future__ import annotations

from allanite.formats._densities import HOLDS as HOLDS  # the format protocol: what it holds
from allanite.formats._densities import density_entries, from_densities
from allanite.formats._text import load_yaml, number_text, update_keys, with_notes
from allanite.formats.base import ImuConfig, Written, number

NAME = "orbslam3"
TITLE = "ORB-SLAM3 settings (IMU.*)"
SUFFIXES = (".yaml", ".yml")
KEYS = {"gyro": ("IMU.NoiseGyro", "IMU.GyroWalk"), "accel": ("IMU.NoiseAcc", "IMU.AccWalk")}
#: unit of each key (continuous-time densities, SI, as Kalibr's)
UNITS = {
    KEYS["gyro"][0]: "rad/s/sqrt(Hz)",
    KEYS["gyro"][1]: "rad/s^2/sqrt(Hz)",
    KEYS["accel"][0]: "m/s^2/sqrt(Hz)",
    KEYS["accel"][1]: "m/s^3/sqrt(Hz)",
}


def sniff(text: str) -> bool:
    """``IMU.NoiseGyro`` or ``IMU.NoiseAcc`` keys."""
    return "IMU.NoiseGyro" in text or "IMU.NoiseAcc" in text


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read the densities (``IMU.Frequency`` gives the rate unless ``rate`` is given)."""
    data = load_yaml(text, "ORB-SLAM3 settings")
    if rate is None and "IMU.Frequency" in data:
        rate = number(data["IMU.Frequency"], "ORB-SLAM3: IMU.Frequency") or None
    return from_densities(data, KEYS, fmt=NAME, rate=rate, what="ORB-SLAM3 settings")


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
) -> Written:
    """ORB-SLAM3 IMU lines (into ``template`` when given)."""
    rate = rate or config.rate
    densities, dropped, projections = density_entries(config, KEYS, rate, tau_range)
    values = {key: number_text(value) for key, value in densities.items()}
    if rate:
        values["IMU.Frequency"] = number_text(rate)
    if template is not None:
        text = with_notes(update_keys(template, values), dropped, projections, config.sensors)
        return Written(text, dropped, projections)
    lines = ["%YAML:1.0", "# IMU noise (continuous densities, SI units) written by allanite"]
    lines += [f"{k}: {v}" for k, v in values.items()]
    lines.extend(f"# dropped: {d}" for d in dropped)
    lines.extend(f"# projected: {p}" for p in projections)
    return Written("\n".join(lines) + "\n", dropped, projections)
