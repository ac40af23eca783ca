"""Earth constants for the navigation error laws: gravity, radius, Earth rate, Schuler frequency.

The single-channel error models of :mod:`allanite.impact` need only four numbers: the gravity
magnitude ``g``, the Earth radius ``R`` seen by the horizontal channel, the Earth rotation rate
``U`` and the Schuler angular frequency ``w_s = sqrt(g / R)`` (period about 84.4 min).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from allanite.units import STANDARD_GRAVITY

__all__ = ["EARTH_RATE", "STANDARD_GRAVITY", "Earth"]

#: WGS-84 Earth rotation rate in rad/s
EARTH_RATE = 7.292115e-5
# standard gravity g = 9.80665 m/s^2 is defined once, in allanite.units
#: mean Earth radius in m (IUGG)
MEAN_RADIUS = 6_371_008.8

# WGS-84 ellipsoid and Somigliana normal gravity
_A = 6_378_137.0
_E2 = 6.69437999014e-3
_GE = 9.7803253359
_K = 1.93185265241e-3


@dataclass(frozen=True)
class Earth:
    """Gravity, radius and rotation rate used by the error models.

    Attributes
    ----------
    g : float
        Gravity magnitude in m/s^2.
    radius : float
        Earth radius of the horizontal channel in m.
    rate : float
        Earth rotation rate ``U`` in rad/s.
    latitude : float or None
        Geodetic latitude in degrees the values were computed for (None: global means).
    """

    g: float = STANDARD_GRAVITY
    radius: float = MEAN_RADIUS
    rate: float = EARTH_RATE
    latitude: float | None = None

    def __post_init__(self) -> None:
        for name in ("g", "radius", "rate"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"Earth.{name} must be a positive finite number, got {value!r}")
        if self.rate >= self.schuler_frequency:
            raise ValueError(
                f"Earth rate {self.rate} rad/s must be below the Schuler frequency "
                f"{self.schuler_frequency:.4g} rad/s; check g and radius"
            )

    @classmethod
    def at_latitude(cls, latitude: float) -> Earth:
        """WGS-84 values at a geodetic latitude (degrees), on the ellipsoid.

        ``g`` is Somigliana's normal gravity
        ``g = g_e (1 + k sin^2 L) / sqrt(1 - e^2 sin^2 L)`` and the radius the Gaussian mean
        radius ``sqrt(R_M R_N)`` with ``R_N = a / sqrt(1 - e^2 sin^2 L)`` and
        ``R_M = a (1 - e^2) / (1 - e^2 sin^2 L)^{3/2}`` (NIMA TR8350.2, ch. 4).

        Parameters
        ----------
        latitude : float
            Geodetic latitude in degrees, in [-90, 90].

        Returns
        -------
        Earth
        """
        if not (isinstance(latitude, (int, float)) and -90.0 <= latitude <= 90.0):
            raise ValueError(f"latitude must be a number of degrees in [-90, 90], got {latitude!r}")
        s2 = math.sin(math.radians(latitude)) ** 2
        w = 1.0 - _E2 * s2
        g = _GE * (1.0 + _K * s2) / math.sqrt(w)
        r_n = _A / math.sqrt(w)
        r_m = _A * (1.0 - _E2) / w**1.5
        return cls(g=g, radius=math.sqrt(r_m * r_n), rate=EARTH_RATE, latitude=float(latitude))

    @property
    def schuler_frequency(self) -> float:
        """Schuler angular frequency ``w_s = sqrt(g / R)`` in rad/s."""
        return math.sqrt(self.g / self.radius)

    @property
    def schuler_period(self) -> float:
        """Schuler period ``2 pi / w_s`` in seconds (about 5060 s)."""
        return 2.0 * math.pi / self.schuler_frequency


def resolve_earth(earth: Earth | None, latitude: float | None) -> Earth:
    """Return the Earth to use: an explicit one, the one at ``latitude``, or the global means."""
    if earth is not None and latitude is not None:
        raise ValueError("give either earth= or latitude=, not both")
    if earth is not None:
        if not isinstance(earth, Earth):
            raise TypeError(f"earth must be an allanite.impact.Earth, got {type(earth).__name__}")
        return earth
    if latitude is not None:
        return Earth.at_latitude(latitude)
    return Earth()
