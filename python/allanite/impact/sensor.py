"""The noise of one inertial sensor as the error laws need it: plain coefficients in SI units.

The navigation error laws act on four kinds of sensor error: a random constant (turn-on bias,
constant over the run, random from run to run), white noise (ARW for a gyro, VRW for an
accelerometer), a Wiener process (rate/acceleration random walk) and first-order Gauss-Markov
processes. :class:`SensorNoise` holds their coefficients in SI units;
:func:`allanite.impact.model_adapter.as_sensor_noise` also accepts a
:class:`allanite.model.NoiseModel` (see :mod:`allanite.impact.model_adapter`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from allanite.impact._checks import nonnegative as _check_nonneg

__all__ = ["Component", "MarkovNoise", "SensorNoise"]

ComponentKind = Literal["constant", "white", "random_walk", "markov"]
COMPONENT_KINDS: tuple[str, ...] = ("constant", "white", "random_walk", "markov")


@dataclass(frozen=True)
class MarkovNoise:
    """First-order Gauss-Markov error ``b' = -b / tau_c + sigma sqrt(2 / tau_c) w``.

    Attributes
    ----------
    sigma : float
        Stationary standard deviation (gyro rad/s, accelerometer m/s^2); ``D = sigma^2``.
    tau_c : float
        Correlation time in seconds; ``mu = 1 / tau_c``. The driving white noise has intensity
        ``2 D mu`` (the "Wiener intensity" of the short-interval laws).
    source : str, optional
        Name of the effect this process stands for (e.g. ``flicker(B=...)`` for a member of a
        flicker bank); processes with the same source form one row of a budget.
    """

    sigma: float
    tau_c: float
    source: str | None = None

    def __post_init__(self) -> None:
        _check_nonneg("MarkovNoise.sigma", self.sigma)
        if _check_nonneg("MarkovNoise.tau_c", self.tau_c) == 0.0:
            raise ValueError("MarkovNoise.tau_c must be > 0 seconds")


@dataclass(frozen=True)
class Component:
    """One independent error source of a sensor, as the error models consume it.

    ``value`` is the random-constant sigma, the white-noise density, the random-walk
    coefficient ``K`` (Wiener intensity ``K^2``) or the Gauss-Markov sigma; ``tau_c`` is set
    for Gauss-Markov only.
    """

    kind: ComponentKind
    value: float
    tau_c: float | None = None
    source: str | None = None

    @property
    def label(self) -> str:
        """Short name such as ``white`` or ``markov(tau_c=300 s)`` (or the ``source``)."""
        if self.source is not None:
            return self.source
        if self.kind == "markov":
            return f"markov(tau_c={self.tau_c:.4g} s)"
        return self.kind


@dataclass(frozen=True)
class SensorNoise:
    """Error coefficients of one sensor axis, SI units.

    Attributes
    ----------
    constant : float
        Random constant (turn-on bias) standard deviation: gyro rad/s, accelerometer m/s^2.
    white : float
        White-noise density: gyro ARW ``N`` in rad/sqrt(s), accelerometer VRW in m/s/sqrt(s).
    random_walk : float
        Random-walk coefficient ``K``: gyro rad/s/sqrt(s), accelerometer m/s^2/sqrt(s); the
        Wiener intensity of the tabulated laws is ``Q = K^2``.
    markov : tuple of MarkovNoise
        Gauss-Markov errors.
    ignored : tuple of str
        Effects of the source model that have no error law here (e.g. ``quantization``).
    """

    constant: float = 0.0
    white: float = 0.0
    random_walk: float = 0.0
    markov: tuple[MarkovNoise, ...] = field(default_factory=tuple)
    ignored: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        for name in ("constant", "white", "random_walk"):
            value = _check_nonneg(f"SensorNoise.{name}", getattr(self, name))
            object.__setattr__(self, name, value)
        markov = tuple(self.markov)
        for item in markov:
            if not isinstance(item, MarkovNoise):
                raise TypeError(
                    "SensorNoise.markov must hold MarkovNoise(sigma, tau_c) items, got "
                    f"{type(item).__name__}"
                )
        object.__setattr__(self, "markov", markov)
        object.__setattr__(self, "ignored", tuple(str(x) for x in self.ignored))

    def components(self) -> tuple[Component, ...]:
        """Return the non-zero error sources (constant, white, random walk, Gauss-Markov)."""
        out: list[Component] = []
        if self.constant > 0:
            out.append(Component("constant", self.constant))
        if self.white > 0:
            out.append(Component("white", self.white))
        if self.random_walk > 0:
            out.append(Component("random_walk", self.random_walk))
        out.extend(
            Component("markov", m.sigma, m.tau_c, m.source) for m in self.markov if m.sigma > 0
        )
        return tuple(out)
