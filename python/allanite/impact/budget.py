"""Navigation error budget: what each sensor noise term costs in attitude, velocity and position.

:func:`error_budget` runs every noise component of a gyro (and optionally an accelerometer)
through the single-channel strapdown error models of :mod:`allanite.impact.ins_errors` and
returns, per component and quantity, the exact standard-deviation curve over a time span
(Schuler loop; the latitude error with the Earth-rate terms) together with the short-interval
(free-inertial) and long-interval (Schuler-bounded) closed forms, and a table at chosen times.
Components are independent, so totals add in quadrature.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.extras import require
from allanite.impact.earth import Earth, resolve_earth
from allanite.impact.ins_errors import (
    QUANTITIES,
    UNITS,
    error_model,
    long_interval_sigma,
    short_interval_sigma,
)
from allanite.impact.model_adapter import as_sensor_noise
from allanite.impact.sensor import Component, SensorNoise

__all__ = ["ALL_QUANTITIES", "BudgetComponent", "ErrorBudget", "error_budget"]

#: every quantity of a budget, in order
ALL_QUANTITIES: tuple[str, ...] = QUANTITIES["gyro"]
#: friendly names accepted wherever a quantity is named
ALIASES = {"heading": "azimuth", "yaw": "azimuth", "tilt": "vertical", "north": "latitude"}
Which = Literal["exact", "short", "long"]


def resolve_quantity(quantity: str) -> str:
    """Canonical quantity name (``heading`` -> ``azimuth``, ``tilt`` -> ``vertical``)."""
    name = ALIASES.get(quantity, quantity)
    if name not in ALL_QUANTITIES:
        raise ValueError(
            f"unknown quantity {quantity!r}; use one of {ALL_QUANTITIES} or {tuple(ALIASES)}"
        )
    return name


@dataclass(frozen=True)
class BudgetComponent:
    """One row of the budget: which sensor and which of its error sources."""

    sensor: str
    kind: str
    label: str
    value: float
    tau_c: float | None = None


@dataclass(frozen=True)
class ErrorBudget:
    """Standard deviation of navigation errors per sensor noise component, SI units.

    Attributes
    ----------
    t : numpy.ndarray
        Time since alignment in seconds, shape ``(T,)``.
    components : tuple of BudgetComponent
        The error sources, shape ``(C,)`` along the first axis of the curve arrays.
    quantities : tuple of str
        ``vertical`` and ``azimuth`` (rad), ``velocity`` (m/s), ``position`` and ``latitude``
        (m; latitude with the Earth-rate terms, driven by the gyro only).
    exact : numpy.ndarray
        Exact sigma of the single-channel model (Schuler loop), shape ``(C, Q, T)``; NaN where
        the component does not drive the quantity in the model.
    short, long : numpy.ndarray
        Free-inertial and Schuler-bounded closed forms, same shape (NaN where none exists).
    table_times : numpy.ndarray
        The times of the table in seconds, shape ``(K,)``.
    table : numpy.ndarray
        Exact sigma at ``table_times``, shape ``(C, Q, K)``.
    earth : Earth
        Gravity, radius and Earth rate used.
    markov_start : str
        Initial Gauss-Markov state (``zero`` as tabulated, or ``stationary``).
    ignored : tuple of str
        Model terms without an error law (``"gyro: quantization"``, ...).
    """

    t: NDArray[np.float64]
    components: tuple[BudgetComponent, ...]
    quantities: tuple[str, ...]
    exact: NDArray[np.float64]
    short: NDArray[np.float64]
    long: NDArray[np.float64]
    table_times: NDArray[np.float64]
    table: NDArray[np.float64]
    earth: Earth
    markov_start: str
    ignored: tuple[str, ...] = ()

    def _qi(self, quantity: str) -> int:
        return self.quantities.index(resolve_quantity(quantity))

    def curve(self, quantity: str, which: Which = "exact") -> NDArray[np.float64]:
        """Sigma of every component for one quantity, shape ``(C, T)``."""
        if which not in ("exact", "short", "long"):
            raise ValueError(f"which must be 'exact', 'short' or 'long', got {which!r}")
        arr: NDArray[np.float64] = getattr(self, which)
        return arr[:, self._qi(quantity), :]

    def total(self, quantity: str, which: Which = "exact") -> NDArray[np.float64]:
        """Root-sum-square over the components (independent errors), shape ``(T,)``."""
        return _rss(self.curve(quantity, which))

    def total_at(self, quantity: str) -> NDArray[np.float64]:
        """Root-sum-square of the exact table values, shape ``(K,)``."""
        return _rss(self.table[:, self._qi(quantity), :])

    def unit(self, quantity: str) -> str:
        """SI unit of a quantity."""
        return UNITS[resolve_quantity(quantity)]

    def rows(self) -> list[dict[str, Any]]:
        """Return the table as records: sensor, component, quantity, unit, t, sigma (and totals)."""
        out: list[dict[str, Any]] = []
        for qi, q in enumerate(self.quantities):
            for ci, comp in enumerate(self.components):
                for ki, tk in enumerate(self.table_times):
                    value = float(self.table[ci, qi, ki])
                    if np.isfinite(value):
                        out.append(_row(comp.sensor, comp.label, q, float(tk), value))
            for ki, tk in enumerate(self.table_times):
                out.append(_row("all", "total", q, float(tk), float(self.total_at(q)[ki])))
        return out

    def table_frame(self) -> Any:
        """Return the table as a pandas DataFrame (needs the ``pandas`` extra)."""
        return _pandas().DataFrame(self.rows())

    def to_frame(self) -> Any:
        """Return all curves as a long DataFrame (one row per component, quantity and t)."""
        records = []
        for ci, comp in enumerate(self.components):
            for qi, q in enumerate(self.quantities):
                if not np.any(np.isfinite(self.exact[ci, qi])):
                    continue
                for ti, tv in enumerate(self.t):
                    records.append(
                        {
                            "sensor": comp.sensor,
                            "component": comp.label,
                            "quantity": q,
                            "unit": UNITS[q],
                            "t": float(tv),
                            "exact": float(self.exact[ci, qi, ti]),
                            "short": float(self.short[ci, qi, ti]),
                            "long": float(self.long[ci, qi, ti]),
                        }
                    )
        return _pandas().DataFrame(records)

    def to_json(self, **kwargs: Any) -> str:
        """Serialise the table (not the curves) as JSON."""
        payload = {
            "earth": self.earth.__dict__,
            "ignored": list(self.ignored),
            "table": self.rows(),
        }
        return json.dumps(payload, **kwargs)


def _row(sensor: str, label: str, quantity: str, t: float, sigma: float) -> dict[str, Any]:
    return {
        "sensor": sensor,
        "component": label,
        "quantity": quantity,
        "unit": UNITS[quantity],
        "t": t,
        "sigma": sigma,
    }


def _pandas() -> Any:
    return require("pandas", extra="pandas", purpose="tables as DataFrames")


def _rss(arr: NDArray[np.float64]) -> NDArray[np.float64]:
    finite = np.isfinite(arr)
    sq = np.where(finite, arr, 0.0) ** 2
    out = np.sqrt(sq.sum(axis=0))
    return np.asarray(np.where(finite.any(axis=0), out, np.nan), dtype=np.float64)


def _check_grid(t: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = np.atleast_1d(np.asarray(t, dtype=np.float64))
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D array of seconds")
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0) or np.any(np.diff(arr) <= 0):
        raise ValueError(f"{name} must be positive, finite and strictly increasing seconds")
    return arr


def _sigma_all(
    sensor: str, comp: Component, t: NDArray[np.float64], earth: Earth, markov_start: str
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """(exact, short, long) sigma of one component, shape ``(Q, len(t))``."""
    shape = (len(ALL_QUANTITIES), t.size)
    exact, short, long_ = np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, np.nan)
    schuler = error_model(sensor, comp, earth, regime="schuler", markov_start=markov_start)  # type: ignore[arg-type]
    sig = schuler.sigma(t)
    if sensor == "gyro":
        lat = error_model("gyro", comp, earth, regime="earth_rate", markov_start=markov_start)  # type: ignore[arg-type]
        sig.update(lat.sigma(t))
    for q in QUANTITIES[sensor]:
        qi = ALL_QUANTITIES.index(q)
        exact[qi] = sig[q]
        short[qi] = short_interval_sigma(sensor, q, comp, t, earth, markov_start=markov_start)  # type: ignore[arg-type]
        long_[qi] = long_interval_sigma(sensor, q, comp, t, earth)  # type: ignore[arg-type]
    return exact, short, long_


def error_budget(
    gyro: Any,
    accel: Any = None,
    *,
    t: ArrayLike | None = None,
    times: ArrayLike = (60.0, 600.0, 3600.0),
    latitude: float | None = None,
    earth: Earth | None = None,
    markov_start: Literal["zero", "stationary"] = "zero",
    accel_scale: float = 1.0,
) -> ErrorBudget:
    """Navigation error budget of a gyro (and optionally an accelerometer) noise model.

    Every noise component (random constant, white, random walk, Gauss-Markov) drives the
    single-channel strapdown error model; the result holds, per component and quantity, the
    exact sigma (Schuler loop, and for the latitude the Schuler and Earth-rate terms) and the
    short- and long-interval closed forms of :mod:`allanite.impact.ins_errors`, e.g. for a gyro
    random constant ``dw`` the position error ``g dw t^3/6`` (short) and ``R dw t`` (long), for
    the ARW ``N`` ``g N t^2.5/sqrt(20)`` and ``R N sqrt(3t/2)``, and the attitude
    ``N sqrt(t/2)`` (vertical) and ``N sqrt(t)`` (azimuth) on the long interval.

    Parameters
    ----------
    gyro : SensorNoise or NoiseModel
        Gyro noise (SI: rad/s, rad/sqrt(s), ...); a NoiseModel is converted from its units
        (white, rrw, turn_on_bias, markov, telegraph, lowpass_white and flicker terms are used,
        see :mod:`allanite.impact.model_adapter`; the others are listed in ``ignored``).
    accel : SensorNoise or NoiseModel, optional
        Accelerometer noise (SI: m/s^2, m/s/sqrt(s), ...).
    t : array_like, optional
        Times of the curves in seconds (positive, increasing); default 200 log-spaced points
        from 1 s to 1 day.
    times : array_like
        Times of the table in seconds (default 1 min, 10 min, 1 h).
    latitude : float, optional
        Geodetic latitude in degrees for gravity and radius (WGS-84); default global means.
    earth : Earth, optional
        Explicit constants instead of ``latitude``.
    markov_start : {"zero", "stationary"}
        Initial Gauss-Markov state; ``zero`` matches the tabulated laws.
    accel_scale : float
        m/s^2 per unit of an accelerometer NoiseModel's coefficients (its angle-based units
        cannot name an acceleration).

    Returns
    -------
    ErrorBudget

    References
    ----------
    Titterton & Weston, "Strapdown Inertial Navigation Technology", 2nd ed., ch. 12 (error
    propagation, Schuler loop); the source dissertation's error-budget tables (docs/impact.md).
    """
    gyro_noise = as_sensor_noise(gyro, name="gyro")
    accel_noise = (
        as_sensor_noise(accel, name="accel", accel_scale=accel_scale) if accel is not None else None
    )
    grid = _check_grid(np.geomspace(1.0, 86400.0, 200) if t is None else t, "t")
    table_times = _check_grid(times, "times")
    the_earth = resolve_earth(earth, latitude)
    if markov_start not in ("zero", "stationary"):
        raise ValueError(f"markov_start must be 'zero' or 'stationary', got {markov_start!r}")

    sensors: list[tuple[str, SensorNoise]] = [("gyro", gyro_noise)]
    if accel_noise is not None:
        sensors.append(("accel", accel_noise))
    comps: list[BudgetComponent] = []
    exact, short, long_, table = [], [], [], []
    ignored: list[str] = []
    for sensor, noise in sensors:
        ignored.extend(f"{sensor}: {name}" for name in noise.ignored)
        groups: dict[str, list[Component]] = {}
        for comp in noise.components():
            groups.setdefault(comp.label, []).append(comp)
        for label, members in groups.items():
            parts = [_sigma_all(sensor, c, grid, the_earth, markov_start) for c in members]
            exact.append(_rss(np.stack([p[0] for p in parts])))
            if len(members) == 1:
                short.append(parts[0][1])
                long_.append(parts[0][2])
            else:  # a bank standing for one effect (flicker): no closed form
                short.append(np.full_like(parts[0][1], np.nan))
                long_.append(np.full_like(parts[0][2], np.nan))
            at = [_sigma_all(sensor, c, table_times, the_earth, markov_start)[0] for c in members]
            table.append(_rss(np.stack(at)))
            first = members[0]
            value = float(np.sqrt(sum(c.value**2 for c in members)))
            tau_c = first.tau_c if len(members) == 1 else None
            comps.append(BudgetComponent(sensor, first.kind, label, value, tau_c))
    if not comps:
        why = f" (terms without an error law: {', '.join(ignored)})" if ignored else ""
        raise ValueError(
            "the noise models have no white, random-walk, Gauss-Markov or random-constant "
            f"component{why}; nothing to budget"
        )
    return ErrorBudget(
        t=grid,
        components=tuple(comps),
        quantities=ALL_QUANTITIES,
        exact=np.stack(exact),
        short=np.stack(short),
        long=np.stack(long_),
        table_times=table_times,
        table=np.stack(table),
        earth=the_earth,
        markov_start=markov_start,
        ignored=tuple(ignored),
    )
