"""OpenVINS ``kalibr_imu_chain.yaml``: the Kalibr keys under ``imu0``.

OpenVINS' simulator (``ov_msckf/src/sim/Simulator.cpp``) adds white noise of std
``sigma / sqrt(dt)`` and a bias random walk of increments ``sigma_b sqrt(dt)``: exactly White
N = noise density and RateRandomWalk K = random walk, as in :mod:`allanite.formats.kalibr`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from allanite.formats import kalibr
from allanite.formats._densities import HOLDS, from_densities
from allanite.formats._text import load_yaml, number_text, update_keys, with_notes
from allanite.formats.base import ImuConfig, Written, number

NAME = "openvins"
TITLE = "OpenVINS kalibr_imu_chain.yaml (imu0)"
SUFFIXES = (".yaml", ".yml")
__all__ = ["HOLDS", "read", "sniff", "write"]


def sniff(text: str) -> bool:
    """Kalibr keys nested under ``imu0:``."""
    return "imu0:" in text and kalibr.has_keys(text)


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read ``imu0``'s densities (``update_rate`` gives the rate unless ``rate`` is given)."""
    data = load_yaml(text, "OpenVINS config")
    block: Any = data.get("imu0")
    if not isinstance(block, dict):
        raise ValueError("OpenVINS config: no 'imu0:' mapping with the IMU noise keys")
    if rate is None and "update_rate" in block:
        rate = number(block["update_rate"], "OpenVINS imu0: update_rate") or None
    config = from_densities(block, kalibr.KEYS, fmt=NAME, rate=rate, what="OpenVINS imu0")
    topic = block.get("rostopic")
    return dataclasses.replace(config, topic=topic) if isinstance(topic, str) else config


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
) -> Written:
    """``kalibr_imu_chain.yaml`` text (into ``template`` when given)."""
    rate = rate or config.rate
    values, dropped, projections = kalibr.entries(config, rate, tau_range)
    text_values = {k: number_text(v) for k, v in values.items()}
    if rate:
        text_values["update_rate"] = number_text(rate)
    if template is not None:
        text = update_keys(template, text_values, indent="  ")
        return Written(with_notes(text, dropped, projections, config.sensors), dropped, projections)
    lines = ["%YAML:1.0 # need to specify the file type at the top!", "", "imu0:"]
    lines += [f"  {k}: {v}  # {kalibr.UNITS[k]}" for k, v in sorted(text_values.items())]
    lines += [f"  rostopic: {kalibr.ros_topic(config)}", "  time_offset: 0.0"]
    lines.extend(f"# dropped: {d}" for d in dropped)
    lines.extend(f"# projected: {p}" for p in projections)
    return Written("\n".join(lines) + "\n", dropped, projections)
