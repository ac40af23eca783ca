"""The downstream cost of a model change: how much a navigation error moves.

The diagnosis and the report call :func:`error_change` with a noise model before and after an
added (or removed) effect, e.g. a Gauss-Markov term that the simulation lacks, and get the
change of one chosen error at one time, e.g. "the missing Gauss-Markov term changes the 1-hour
heading error from 0.21 deg to 0.35 deg".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

from allanite.impact.budget import error_budget, resolve_quantity
from allanite.impact.earth import Earth

__all__ = ["ErrorChange", "error_change"]

_DISPLAY = {
    "vertical": ("tilt error", "deg", math.degrees(1.0)),
    "azimuth": ("heading error", "deg", math.degrees(1.0)),
    "velocity": ("velocity error", "m/s", 1.0),
    "position": ("position error", "m", 1.0),
    "latitude": ("latitude error", "m", 1.0),
}


@dataclass(frozen=True)
class ErrorChange:
    """One navigation error (1 sigma, SI units) for two noise models.

    Attributes
    ----------
    quantity : str
        ``vertical``, ``azimuth``, ``velocity``, ``position`` or ``latitude``.
    t : float
        Time since alignment in seconds.
    before, after : float
        Sigma in SI units (rad, m/s, m) without and with the change.
    unit : str
        SI unit of ``before``/``after``.
    """

    quantity: str
    t: float
    before: float
    after: float
    unit: str

    @property
    def ratio(self) -> float:
        """``after / before`` (inf when before is 0)."""
        return self.after / self.before if self.before > 0 else math.inf

    @property
    def difference(self) -> float:
        """``after - before`` in SI units."""
        return self.after - self.before

    def describe(self, effect: str = "the change") -> str:
        """One sentence in customary units, e.g. for the diagnosis report.

        ``"the missing Gauss-Markov term changes the 1-hour heading error from 0.21 deg to
        0.35 deg (x1.67)"``.
        """
        name, unit, scale = _DISPLAY[self.quantity]
        return (
            f"{effect} changes the {_duration(self.t)} {name} from {self.before * scale:.3g} "
            f"{unit} to {self.after * scale:.3g} {unit} (x{self.ratio:.3g})"
        )


def _duration(t: float) -> str:
    for size, unit in ((3600.0, "hour"), (60.0, "minute")):
        if t >= size and math.isclose(t / size, round(t / size), rel_tol=1e-9):
            return f"{round(t / size):d}-{unit}"
    return f"{t:.4g}-s"


def error_change(
    before: Any,
    after: Any,
    *,
    quantity: str = "heading",
    t: float = 3600.0,
    sensor: Literal["gyro", "accel"] = "gyro",
    accel: Any = None,
    latitude: float | None = None,
    earth: Earth | None = None,
    markov_start: Literal["zero", "stationary"] = "zero",
    accel_scale: float = 1.0,
) -> ErrorChange:
    """Sigma of one navigation error at time ``t`` for two noise models of the same sensor.

    The total (root-sum-square over the noise components) exact sigma of the single-channel
    error model of :func:`allanite.impact.error_budget` is computed for ``before`` and
    ``after``.

    Parameters
    ----------
    before, after : SensorNoise or NoiseModel
        The sensor's noise without and with the effect.
    quantity : str
        ``heading``/``azimuth``, ``tilt``/``vertical``, ``velocity``, ``position`` or
        ``latitude``.
    t : float
        Time since alignment in seconds (default 1 hour).
    sensor : {"gyro", "accel"}
        Which sensor ``before``/``after`` describe.
    accel : SensorNoise or NoiseModel, optional
        Accelerometer noise held fixed when ``sensor="gyro"`` (adds to velocity/position).
    latitude, earth, markov_start, accel_scale
        As in :func:`allanite.impact.error_budget`.

    Returns
    -------
    ErrorChange
    """
    name = resolve_quantity(quantity)
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not (t > 0 and math.isfinite(t)):
        raise ValueError(f"t must be a positive number of seconds, got {t!r}")
    if sensor not in ("gyro", "accel"):
        raise ValueError(f"sensor must be 'gyro' or 'accel', got {sensor!r}")
    if sensor == "accel" and accel is not None:
        raise ValueError("accel= is the fixed accelerometer for sensor='gyro'; omit it here")

    def sigma(model: Any) -> float:
        gyro, acc = (model, accel) if sensor == "gyro" else (None, model)
        if gyro is None:
            from allanite.impact.sensor import SensorNoise

            gyro = SensorNoise()
        budget = _budget_or_zero(gyro, acc, t, latitude, earth, markov_start, accel_scale)
        if budget is None:
            return 0.0
        value = float(budget.total_at(name)[0])
        if not math.isfinite(value):
            raise ValueError(f"the {sensor} does not drive the {name} error in these models")
        return value

    from allanite.impact.ins_errors import UNITS

    return ErrorChange(name, float(t), sigma(before), sigma(after), UNITS[name])


def _budget_or_zero(
    gyro: Any,
    accel: Any,
    t: float,
    latitude: float | None,
    earth: Earth | None,
    markov_start: Literal["zero", "stationary"],
    accel_scale: float,
) -> Any:
    from allanite.impact.model_adapter import as_sensor_noise

    g = as_sensor_noise(gyro, name="gyro")
    a = as_sensor_noise(accel, name="accel", accel_scale=accel_scale) if accel is not None else None
    if not g.components() and (a is None or not a.components()):
        return None
    return error_budget(
        g,
        a,
        t=[t],
        times=[t],
        latitude=latitude,
        earth=earth,
        markov_start=markov_start,
    )
