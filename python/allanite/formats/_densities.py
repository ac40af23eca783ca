"""Continuous-time white + bias random walk densities (Kalibr and the estimators).

Kalibr, OpenVINS, ORB-SLAM3 and VINS-Fusion describe each sensor by a noise density ``n``
(rate/sqrt(Hz)) and a bias random-walk density ``w`` (rate/s/sqrt(Hz)): the discrete white
std is ``n sqrt(rate)`` and the bias increment std ``w / sqrt(rate)``, which are exactly
allanite's ``White(N=n)`` and ``RateRandomWalk(K=w)`` at any rate.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

from allanite.formats.base import ImuConfig, closest_key, key_notes, number, sensor_model
from allanite.formats.projection import project_config
from allanite.model import NoiseModel
from allanite.terms import RateRandomWalk, Term, White

__all__ = ["HOLDS", "density_entries", "from_densities", "to_densities"]

HOLDS = frozenset({"white", "rrw"})


def from_densities(
    get: dict[str, Any],
    keys: dict[str, tuple[str, str]],
    *,
    fmt: str,
    rate: float | None = None,
    what: str,
    other_keys: Collection[str] | None = None,
) -> ImuConfig:
    """Build the config from ``{sensor: (density key, random-walk key)}`` found in ``get``.

    A sensor is read when both its keys are given; one of the two alone is refused (the
    other, often misspelled, would be taken as zero), naming the unknown key it is closest
    to. Unknown keys close to a known one are warned in the notes; with ``other_keys`` (the
    format's every other key, e.g. Kalibr's ``update_rate``, ``rostopic``) every unknown key is.
    """
    models: dict[str, NoiseModel] = {}
    known = {k for pair in keys.values() for k in pair} | set(other_keys or ())
    for sensor, (n_key, w_key) in keys.items():
        if n_key not in get and w_key not in get:
            continue
        for key in (n_key, w_key):
            if key not in get:
                typo = [
                    k
                    for k in get
                    if isinstance(k, str) and closest_key(k, [key]) and k not in known
                ]
                hint = f" (the file has {typo[0]!r}: a misspelling?)" if typo else ""
                raise ValueError(
                    f"{what}: {key} is missing{hint}; the {sensor} needs both {n_key} and "
                    f"{w_key}: give the missing one (0 if the {sensor} has none of that noise)"
                )
        terms: list[Term] = []
        n = number(get.get(n_key, 0.0), f"{what}: {n_key}")
        w = number(get.get(w_key, 0.0), f"{what}: {w_key}")
        if n > 0:
            terms.append(White(N=n))
        if w > 0:
            terms.append(RateRandomWalk(K=w))
        models[sensor] = sensor_model(terms, sensor)
    if not models:
        wanted = ", ".join(k for pair in keys.values() for k in pair)
        raise ValueError(f"{what}: none of the keys {wanted} found")
    notes = key_notes(get, known, what, strict=other_keys is not None)
    return ImuConfig(
        gyro=models.get("gyro"),
        accel=models.get("accel"),
        rate=rate,
        source_format=fmt,
        notes=tuple(notes),
    )


def to_densities(model: NoiseModel) -> tuple[float, float]:
    """``(noise density, random walk)`` of a model holding at most white and rrw terms."""
    n = sum(t.values()["N"] ** 2 for t in model.terms_of_type("white")) ** 0.5
    w = sum(t.values()["K"] ** 2 for t in model.terms_of_type("rrw")) ** 0.5
    return float(n), float(w)


def density_entries(
    config: ImuConfig,
    keys: dict[str, tuple[str, str]],
    rate: float | None,
    tau_range: tuple[float, float] | None,
) -> tuple[dict[str, float], list[str], list[str]]:
    """``(values by key, dropped, projections)``: the config projected onto white + rrw.

    ``keys`` is ``{sensor: (density key, random-walk key)}`` of the target format; what the
    format cannot hold is projected or dropped by
    :func:`allanite.formats.projection.project_config`, which says so.
    """
    models, dropped, projections = project_config(config, HOLDS, rate=rate, tau_range=tau_range)
    values: dict[str, float] = {}
    for sensor, (n_key, w_key) in keys.items():
        if sensor in models:
            values[n_key], values[w_key] = to_densities(models[sensor])
    return values, dropped, projections
