"""Flicker rate noise (bias instability), IEEE symbol B, with its high cutoff f0."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

from allanite.terms._checks import averaging_factor, check_parameters
from allanite.terms._guess import curve_bound
from allanite.terms.base import ParamSpec, Term
from allanite.terms.flicker_psd import flicker_psd_sampled

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream
    from allanite.variance import AllanResult

__all__ = ["PLATEAU", "Flicker"]

#: Allan variance plateau per B^2: 2 ln 2 / pi (ADEV = 0.664 B)
PLATEAU = 2.0 * math.log(2.0) / math.pi


@dataclass(frozen=True)
class Flicker(Term):
    r"""Flicker rate noise, the bias instability coefficient ``B`` (rate).

    PSD (one-sided) :math:`S(f) = B^2/(\pi f)` for :math:`0 < f \le f_0`, zero above (IEEE 952
    two-sided :math:`(B^2/2\pi)/f`). With :math:`x = \pi f_0 \tau` the Allan variance is

    .. math:: \sigma^2(\tau) = \frac{2B^2}{\pi}\left[\ln 2
              - \frac{\sin^3 x\,(\sin x + 4x\cos x)}{2x^2} + \mathrm{Ci}(2x)
              - \mathrm{Ci}(4x)\right]

    which tends to the plateau :math:`(2\ln 2/\pi) B^2` (ADEV = 0.664 B) for
    :math:`\tau \gg 1/f_0`. It is exact for rate samples that are the averages of the
    continuous rate over each sample period (angle or increment output).

    Parameters
    ----------
    B : float
        Bias instability coefficient in the model's rate unit.
    f0 : float or None
        Cutoff frequency in Hz; None (the default) means the Nyquist frequency ``1/(2 dt)``
        of the record the term is evaluated for.

    References
    ----------
    IEEE Std 952-1997, Annex C, eq. (C.16).
    """

    B: float
    f0: float | None = None

    type: ClassVar[str] = "flicker"
    symbol: ClassVar[str] = "B"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("B", rate=1, time=0, description="bias instability"),
    )
    optional: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("f0", rate=0, time=-1, description="cutoff frequency (default Nyquist)"),
    )

    def __post_init__(self) -> None:
        check_parameters(self)
        if self.f0 is not None and not (math.isfinite(self.f0) and self.f0 > 0):
            raise ValueError(
                f"Flicker.f0 must be a positive frequency in Hz or None, got {self.f0!r}"
            )

    def cutoff(self, dt: float) -> float:
        """Return the cutoff in Hz for sample period ``dt`` (``f0``, or ``1/(2 dt)`` when unset)."""
        return 0.5 / dt if self.f0 is None else float(self.f0)

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact Allan variance of band-limited flicker noise (IEEE 952 eq. C.16)."""
        t, _, step = averaging_factor(tau, dt)
        return self.B**2 * flicker_shape(np.pi * self.cutoff(step) * t)

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD ``B^2 / (pi f)`` below ``f0`` (everywhere when ``f0`` is unset)."""
        f = np.asarray(f, dtype=np.float64)
        out = self.B**2 / (np.pi * f)
        if self.f0 is not None:
            out = np.where(f <= self.f0, out, 0.0)
        return out

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """One-sided PSD of the sampled rate (interval averages): ``psd(f) sinc^2(f dt)``."""
        return flicker_psd_sampled(f, self.B, dt, self.cutoff(dt))

    def stream(
        self,
        fs: float,
        n_channels: int,
        seed: Any,
        *,
        n_samples: int | None = None,
        method: str = "auto",
    ) -> TermStream:
        """Stream flicker noise (see :mod:`allanite.simulation.flicker`).

        ``method="auto"``: spectral synthesis of the exact sampled PSD for records of known
        length up to 2^21 samples, else the streaming AR(1) bank + FIR generator (exact law
        too, any length); ``"spectral"``,
        ``"kasdin"`` (Kasdin's fractional filter) or ``"bank"`` force one.
        """
        from allanite.simulation.flicker import flicker_stream

        return flicker_stream(self, fs, n_channels, seed, n_samples=n_samples, method=method)

    @classmethod
    def guess(cls, result: AllanResult) -> Flicker | None:
        """Largest ``B`` the curve allows: ``sqrt(min(var) / (2 ln 2 / pi))``."""
        bound = curve_bound(result, 0.0)
        return None if bound is None else cls(B=float(np.sqrt(bound / PLATEAU)))


def flicker_shape(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return the bracket of IEEE 952 eq. (C.16) times ``2/pi``, with ``x = pi f0 tau``."""
    x = np.asarray(x, dtype=np.float64)
    _, ci2 = special.sici(2.0 * x)
    _, ci4 = special.sici(4.0 * x)
    s, c = np.sin(x), np.cos(x)
    bracket = math.log(2.0) - s**3 * (s + 4.0 * x * c) / (2.0 * x**2) + ci2 - ci4
    return np.asarray((2.0 / np.pi) * bracket, dtype=np.float64)
