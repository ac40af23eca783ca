"""White rate noise (angle random walk), IEEE symbol N."""

from __future__ import annotations

import math
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

__all__ = ["White", "WhiteLaws"]


class WhiteLaws:
    """The laws of white rate noise of amplitude ``N`` (rate * sqrt(s)), for a Term to inherit.

    Shared by :class:`White` and the terms whose record-average power is white noise of
    amplitude ``N`` (:class:`allanite.terms.WhiteDrift`: a level that moves over the record).
    """

    N: float

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Allan variance ``N^2 / tau`` (exact for sampled white noise)."""
        t, _, _ = averaging_factor(tau, dt)
        return self.N**2 / t

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD ``2 N^2`` in rate^2/Hz."""
        return np.full(np.shape(f), 2.0 * self.N**2)

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """White stays white after sampling: ``2 N^2``."""
        return self.psd(f)


@dataclass(frozen=True)
class White(WhiteLaws, Term):
    r"""White rate noise, the angle random walk coefficient ``N`` (rate * sqrt(s)).

    Allan variance (exact for any sampled record, samples of variance :math:`N^2/\Delta t`):

    .. math:: \sigma^2(\tau) = N^2 / \tau

    One-sided PSD of the rate: :math:`S(f) = 2 N^2` (IEEE Std 952-1997 writes the two-sided
    :math:`N^2`). ``N`` in deg/sqrt(s) equals the noise density in deg/s/sqrt(Hz).

    References
    ----------
    IEEE Std 952-1997, Annex C; IEEE Std 1431-2004.
    """

    N: float

    type: ClassVar[str] = "white"
    symbol: ClassVar[str] = "N"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec(
            "N",
            rate=1,
            time=0.5,
            description="angle random walk",
            accel_description="velocity random walk",
        ),
    )

    def __post_init__(self) -> None:
        check_parameters(self)

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Independent Gaussian rate samples of standard deviation ``N sqrt(fs)``."""
        from allanite.simulation.gaussian import WhiteStream

        return WhiteStream(self.N * math.sqrt(fs), fs, n_channels, seed)

    @classmethod
    def guess(cls, result: AllanResult) -> White | None:
        """Largest ``N`` the curve allows: ``sqrt(min(var * tau))``."""
        bound = curve_bound(result, 1.0)
        return None if bound is None else cls(N=float(np.sqrt(bound)))
