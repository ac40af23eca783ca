"""Sinusoidal rate error (vibration, a rotating part)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import averaging_factor, check_parameters
from allanite.terms._guess import hump
from allanite.terms.base import ParamSpec, Term

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream
    from allanite.variance import AllanResult

__all__ = ["PEAK_ADEV", "PEAK_FTAU", "Sine"]

#: ADEV peak of a sinusoid: 0.725 A at tau = 0.371 / f0
PEAK_ADEV = 0.7246
PEAK_FTAU = 0.3710


@dataclass(frozen=True)
class Sine(Term):
    r"""A sinusoid :math:`A\sin(2\pi f_0 t + \varphi)` in the rate, sampled at period ``dt``.

    The mean over the starting phase of the Allan variance of the samples is exactly

    .. math:: \sigma^2(m\Delta t) = \frac{A^2 \sin^4(\pi f_0 m\Delta t)}
              {(m \sin(\pi f_0 \Delta t))^2},

    periodic in :math:`f_0` with period :math:`1/\Delta t`, so aliasing is included (a tone at
    a multiple of the sampling rate is a constant and has zero Allan variance). The continuous
    limit is :math:`A^2\sin^4(\pi f_0\tau)/(\pi f_0\tau)^2` (ADEV peak :math:`0.725 A` at
    :math:`\tau = 0.371/f_0`). Its spectrum is a line of power :math:`A^2/2` at :math:`f_0`,
    which a density cannot hold: :meth:`psd` is zero everywhere.

    Parameters
    ----------
    amplitude : float
        Amplitude ``A`` in the model's rate unit.
    frequency : float
        Frequency ``f0`` in Hz.
    """

    amplitude: float
    frequency: float

    type: ClassVar[str] = "sine"
    symbol: ClassVar[str] = "amplitude"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("amplitude", rate=1, time=0, description="amplitude"),
        ParamSpec("frequency", rate=0, time=-1, description="frequency in Hz"),
    )

    def __post_init__(self) -> None:
        check_parameters(self, positive=("frequency",))

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact phase-averaged Allan variance of the sampled sinusoid (aliasing included)."""
        _, m, step = averaging_factor(tau, dt)
        denom = (m * np.sin(np.pi * self.frequency * step)) ** 2
        numer = self.amplitude**2 * np.sin(np.pi * self.frequency * m * step) ** 4
        tiny = denom <= 1e-300 + 1e-24 * m**2
        return np.where(tiny, 0.0, numer / np.where(tiny, 1.0, denom))

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """Zero: the sinusoid is a spectral line (power ``A^2/2`` at ``f0``), see :meth:`line`."""
        return np.zeros(np.shape(f))

    def line(self) -> tuple[float, float]:
        """Return the spectral line ``(frequency in Hz, power A^2/2 in rate^2)``."""
        return self.frequency, 0.5 * self.amplitude**2

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Point samples with a random phase per channel and run."""
        from allanite.simulation.effects import SineStream

        return SineStream(self.amplitude, self.frequency, fs, n_channels, seed)

    @classmethod
    def guess(cls, result: AllanResult) -> Sine | None:
        """From the ADEV hump: ``f0 = 0.371 / tau_peak``, ``A = adev_peak / 0.725``."""
        peak = hump(result)
        if peak is None:
            return None
        tau, var = peak
        return cls(amplitude=math.sqrt(var) / PEAK_ADEV, frequency=PEAK_FTAU / tau)
