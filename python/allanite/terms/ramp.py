"""Rate ramp, IEEE symbol R."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import averaging_factor, check_parameters
from allanite.terms._guess import curve_bound
from allanite.terms.base import ParamSpec, Term

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream
    from allanite.variance import AllanResult

__all__ = ["RateRamp"]


@dataclass(frozen=True)
class RateRamp(Term):
    r"""Rate ramp (a deterministic drift of the rate), coefficient ``R`` (rate / s).

    Adjacent block means of :math:`r(t) = R t` differ by exactly :math:`R\tau`, so for any
    sampled record

    .. math:: \sigma^2(\tau) = R^2\tau^2 / 2.

    Not stationary: no PSD (IEEE 952 quotes :math:`R^2/(2\pi f)^3` for the two-sided PSD of
    the equivalent random process; a ramp is better seen in the time domain).

    References
    ----------
    IEEE Std 952-1997, Annex C.
    """

    R: float

    type: ClassVar[str] = "ramp"
    symbol: ClassVar[str] = "R"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec(
            "R",
            rate=1,
            time=-1,
            description="rate ramp",
            accel_description="acceleration ramp",
        ),
    )
    stationary: ClassVar[bool] = False

    def __post_init__(self) -> None:
        check_parameters(self)

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Allan variance ``R^2 tau^2 / 2`` (exact)."""
        t, _, _ = averaging_factor(tau, dt)
        return 0.5 * self.R**2 * t**2

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Sample means of ``R t``: ``R (k + 1/2) dt``."""
        from allanite.simulation.effects import RampStream

        return RampStream(self.R, fs, n_channels, seed)

    @classmethod
    def guess(cls, result: AllanResult) -> RateRamp | None:
        """Largest ``R`` the curve allows: ``sqrt(2 min(var / tau^2))``."""
        bound = curve_bound(result, -2.0)
        return None if bound is None else cls(R=float(np.sqrt(2.0 * bound)))
