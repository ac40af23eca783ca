"""The thermal bias law: the bias as a polynomial of the sensor temperature (and its rate).

``bias(t) = sum_k c_k (T(t) - T_ref)^k + c_rate dT/dt`` for ``k = 1 .. degree``; the bias at
``T_ref`` itself stays in the record (it is the constant offset, not a thermal effect). This
is the law PX4's thermal calibration applies (``TC_G*``/``TC_A*``: a polynomial about a
reference temperature) with the optional rate term for thermal lag.

Not a :class:`~allanite.terms.base.Term` (and not in ``TERM_TYPES``): its Allan variance
and its simulation depend on the temperature profile, which a Term's ``avar(tau, dt)`` and
``stream(fs, ...)`` do not take. The law lives here, in one place, so that the fit
(:mod:`allanite.fit.thermal`), the compensation and later the simulation and the exports use
the same evaluation and the same JSON.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ThermalBias", "temperature_rate"]


def temperature_rate(
    temperature: ArrayLike, *, fs: float, smooth_s: float = 0.0
) -> NDArray[np.float64]:
    """dT/dt in °C/s at every sample, from a local quadratic over ``smooth_s`` seconds.

    A temperature sensor quantises (0.01-0.1 °C steps); its raw difference is mostly that
    step, so the rate is the derivative of a least-squares quadratic over a window of
    ``smooth_s`` seconds around each sample (Savitzky-Golay; at the ends the window's own
    fit, not a padded copy, so the first and last samples get no spurious zero rate).
    Without smoothing (a window under 5 samples) it is the central difference.
    """
    from scipy.signal import savgol_filter

    values = np.asarray(temperature, dtype=np.float64)
    width = round(smooth_s * fs) // 2 * 2 + 1
    if values.size < 2:
        return np.zeros(values.size)
    if width < 5 or values.size <= width:
        return np.asarray(np.gradient(values) * fs, dtype=np.float64)
    rate = savgol_filter(values, width, 2, deriv=1, delta=1.0 / fs, mode="interp")
    return np.asarray(rate, dtype=np.float64)


@dataclass(frozen=True)
class ThermalBias:
    """Bias as a polynomial of temperature about ``reference`` (and optionally its rate).

    Attributes
    ----------
    coefficients : tuple of float
        ``c_1 .. c_degree``: bias per °C^k in the record's rate unit (``c_1`` is the thermal
        sensitivity at the reference temperature); empty for degree 0.
    reference : float
        Reference temperature ``T_ref`` in °C.
    units : str or None
        Rate unit of the coefficients (the record's rate unit).
    rate : float or None
        ``c_rate``: bias per °C/s of temperature rate (thermal lag), or None when not modelled.
    rate_smoothing : float
        Seconds over which the temperature is averaged before its rate is taken.
    """

    coefficients: tuple[float, ...]
    reference: float
    units: str | None = None
    rate: float | None = None
    rate_smoothing: float = 0.0

    @property
    def degree(self) -> int:
        """Degree of the polynomial (0: no temperature dependence)."""
        return len(self.coefficients)

    def bias(self, temperature: ArrayLike, *, fs: float | None = None) -> NDArray[np.float64]:
        """The thermal bias at every temperature sample (zero at ``reference``, no rate).

        Parameters
        ----------
        temperature : array_like
            Temperatures in °C, one per sample.
        fs : float, optional
            Sampling frequency in Hz; needed when the model has a rate term.
        """
        x = np.asarray(temperature, dtype=np.float64) - self.reference
        out = np.zeros(x.shape)
        for k, c in enumerate(self.coefficients, start=1):
            out += c * x**k
        if self.rate is not None:
            if fs is None:
                raise ValueError("the thermal model has a rate term: give fs to evaluate it")
            out += self.rate * temperature_rate(
                np.asarray(temperature, dtype=np.float64), fs=fs, smooth_s=self.rate_smoothing
            )
        return out

    def sensitivity(self, temperature: float | None = None) -> float:
        """The slope d bias / dT at ``temperature`` (default: the reference), rate unit/°C."""
        x = 0.0 if temperature is None else float(temperature) - self.reference
        return float(sum(k * c * x ** (k - 1) for k, c in enumerate(self.coefficients, start=1)))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready ``{"type": "thermal", "coefficients": [...], "reference": ..., ...}``."""
        out: dict[str, Any] = {
            "type": "thermal",
            "coefficients": [float(c) for c in self.coefficients],
            "reference": float(self.reference),
            "units": self.units,
        }
        if self.rate is not None:
            out |= {"rate": float(self.rate), "rate_smoothing": float(self.rate_smoothing)}
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ThermalBias:
        """The inverse of :meth:`to_dict` (a ValueError names a missing or wrong field)."""
        if data.get("type") != "thermal":
            raise ValueError(f"not a thermal model: type is {data.get('type')!r}, not 'thermal'")
        try:
            rate = data.get("rate")
            return cls(
                coefficients=tuple(float(c) for c in data["coefficients"]),
                reference=float(data["reference"]),
                units=data.get("units"),
                rate=None if rate is None else float(rate),
                rate_smoothing=float(data.get("rate_smoothing", 0.0)),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(
                f"thermal model: {exc}; it needs 'coefficients' (a list of numbers) and "
                "'reference' (°C)"
            ) from None
