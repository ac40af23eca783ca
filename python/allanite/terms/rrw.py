"""Rate random walk, IEEE symbol K."""

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

__all__ = ["RateRandomWalk"]


@dataclass(frozen=True)
class RateRandomWalk(Term):
    r"""Rate random walk, coefficient ``K`` (rate / sqrt(s)).

    Sampled model: :math:`r_k = r_{k-1} + K\sqrt{\Delta t}\,w_k` with unit white :math:`w`.
    The difference of adjacent block means weighs the increments with the triangle
    :math:`(1, 2, \dots, m, \dots, 1)/m`, whence exactly

    .. math:: \sigma^2(\tau) = K^2 \Delta t\,\frac{2m^2 + 1}{6m}
              = \frac{K^2\tau}{3} + \frac{K^2 \Delta t^2}{6\tau}

    (the continuous asymptote is :math:`K^2\tau/3`). One-sided PSD :math:`K^2/(2\pi^2 f^2)`
    (IEEE 952 two-sided :math:`(K/2\pi)^2/f^2`); sampled
    :math:`K^2\Delta t^2 / (2\sin^2(\pi f\Delta t))`.

    References
    ----------
    IEEE Std 952-1997, Annex C.
    """

    K: float

    type: ClassVar[str] = "rrw"
    symbol: ClassVar[str] = "K"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec(
            "K",
            rate=1,
            time=-0.5,
            description="rate random walk",
            accel_description="acceleration random walk",
        ),
    )

    def __post_init__(self) -> None:
        check_parameters(self)

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact sampled Allan variance ``K^2 dt (2 m^2 + 1) / (6 m)``."""
        _, m, step = averaging_factor(tau, dt)
        return self.K**2 * step * (2.0 * m**2 + 1.0) / (6.0 * m)

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD ``K^2 / (2 pi^2 f^2)`` in rate^2/Hz."""
        f = np.asarray(f, dtype=np.float64)
        return self.K**2 / (2.0 * np.pi**2 * f**2)

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """One-sided PSD of the sampled random walk, ``K^2 dt^2 / (2 sin^2(pi f dt))``."""
        f = np.asarray(f, dtype=np.float64)
        return self.K**2 * dt**2 / (2.0 * np.sin(np.pi * f * dt) ** 2)

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Stream the sampled random walk ``r[k] = r[k-1] + K sqrt(dt) w[k]`` (C++ recursion)."""
        from allanite.simulation.gaussian import random_walk_stream

        return random_walk_stream(self.K, fs, n_channels, seed)

    @classmethod
    def guess(cls, result: AllanResult) -> RateRandomWalk | None:
        """Largest ``K`` the curve allows: ``sqrt(3 min(var / tau))``."""
        bound = curve_bound(result, -1.0)
        return None if bound is None else cls(K=float(np.sqrt(3.0 * bound)))
