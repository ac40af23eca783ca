"""First-order Gauss-Markov process (exponentially correlated noise)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import averaging_factor, check_parameters
from allanite.terms._guess import hump
from allanite.terms.base import ParamSpec, Term
from allanite.terms.transients import relaxation_bracket

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream
    from allanite.variance import AllanResult

__all__ = ["PEAK_ADEV", "PEAK_TAU", "GaussMarkov", "sampled_ar1_avar"]

#: ADEV peak of a Gauss-Markov process: 0.617 sigma at tau = 1.89 Tc
PEAK_ADEV = 0.6166
PEAK_TAU = 1.893


@dataclass(frozen=True)
class GaussMarkov(Term):
    r"""First-order Gauss-Markov noise: standard deviation ``sigma`` and correlation time.

    Sampled model :math:`x_k = \phi x_{k-1} + \sigma\sqrt{1-\phi^2}\,w_k`,
    :math:`\phi = e^{-\Delta t/T_c}`, innovation variance :math:`q^2 = \sigma^2(1-\phi^2)`.
    Exact Allan variance of the samples (the autocovariance :math:`\sigma^2\phi^{|l|}` summed
    over the two blocks):

    .. math:: \sigma^2(m\Delta t) = q^2\,\frac{m - 3\phi - m\phi^2 + 4\phi^{m+1}
              - \phi^{2m+1}}{m^2 (1-\phi)^2 (1-\phi^2)}

    which tends to the continuous form :math:`(2\sigma^2 T_c/\tau)[1 - (T_c/2\tau)(3 -
    4e^{-\tau/T_c} + e^{-2\tau/T_c})]` (ADEV peak :math:`0.617\sigma` at
    :math:`\tau = 1.89 T_c`). One-sided PSD :math:`4\sigma^2 T_c / (1 + (2\pi f T_c)^2)`.

    Parameters
    ----------
    sigma : float
        Standard deviation of the process, in the model's rate unit.
    tau_c : float
        Correlation time in seconds.

    References
    ----------
    A. Gelb, *Applied Optimal Estimation* (1974), table 3.1-1; IEEE Std 952-1997, Annex C.
    """

    sigma: float
    tau_c: float

    type: ClassVar[str] = "markov"
    symbol: ClassVar[str] = "sigma"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("sigma", rate=1, time=0, description="standard deviation"),
        ParamSpec("tau_c", rate=0, time=1, description="correlation time"),
    )

    def __post_init__(self) -> None:
        check_parameters(self, positive=("tau_c",))

    @classmethod
    def from_ar1(cls, phi: float, innovation_variance: float, dt: float) -> GaussMarkov:
        """Build the term of a discrete AR(1) ``x[k] = phi x[k-1] + e[k]``, ``Var(e) = s2``."""
        if not 0.0 < phi < 1.0:
            raise ValueError(f"phi must lie in (0, 1) for a Gauss-Markov process, got {phi}")
        return cls(sigma=math.sqrt(innovation_variance / (1.0 - phi**2)), tau_c=-dt / math.log(phi))

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact Allan variance of the sampled process (see the class docstring)."""
        _, m, step = averaging_factor(tau, dt)
        return sampled_ar1_avar(self.sigma**2, step / self.tau_c, m)

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD ``4 sigma^2 Tc / (1 + (2 pi f Tc)^2)`` in rate^2/Hz."""
        f = np.asarray(f, dtype=np.float64)
        return 4.0 * self.sigma**2 * self.tau_c / (1.0 + (2.0 * np.pi * f * self.tau_c) ** 2)

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """One-sided PSD of the sampled AR(1): ``2 dt q^2 / |1 - phi e^{-2 pi i f dt}|^2``."""
        f = np.asarray(f, dtype=np.float64)
        phi = math.exp(-dt / self.tau_c)
        q2 = self.sigma**2 * (1.0 - phi**2)
        return 2.0 * dt * q2 / (1.0 - 2.0 * phi * np.cos(2.0 * np.pi * f * dt) + phi**2)

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Stream the exact stationary AR(1) of the class docstring (C++ recursion)."""
        from allanite.simulation.gaussian import gauss_markov_stream

        return gauss_markov_stream(self.sigma, self.tau_c, fs, n_channels, seed)

    @classmethod
    def guess(cls, result: AllanResult) -> GaussMarkov | None:
        """From the ADEV hump: ``tau_c = tau_peak / 1.89``, ``sigma = adev_peak / 0.617``."""
        peak = hump(result)
        if peak is None:
            return None
        tau, var = peak
        return cls(sigma=math.sqrt(var) / PEAK_ADEV, tau_c=tau / PEAK_TAU)


def _walk_bracket(theta: float) -> float:
    r"""Return :math:`2\theta(1 - e^{-\theta}) - (e^{-2\theta} - 1 + 2\theta) \approx \theta^3/3`.

    Below ``theta = 0.1`` its Taylor series, coefficients :math:`(-1)^j (2j - 2^j)/j!`,
    ``j = 3 .. 14``; the direct form (written with ``expm1``) above.
    """
    if theta >= 0.1:
        return -2.0 * theta * math.expm1(-theta) - math.expm1(-2.0 * theta) - 2.0 * theta
    total = 0.0
    for j in range(14, 2, -1):
        total = total * theta + (-1) ** j * (2 * j - 2**j) / math.factorial(j)
    return total * theta**3


def sampled_ar1_avar(variance: float, theta: float, m: ArrayLike) -> NDArray[np.float64]:
    r"""Exact Allan variance of a point-sampled stationary AR(1), stable for any ``theta``.

    With :math:`\phi = e^{-\theta}` (:math:`\theta = \Delta t/T_c`) the class docstring's
    numerator is :math:`m\,P(\theta) + \phi\,C(m\theta)` with
    :math:`P = 2\theta(1-\phi) - (\phi^2 - 1 + 2\theta)` and
    :math:`C(x) = 2x - 3 + 4e^{-x} - e^{-2x}`
    (:func:`~allanite.terms.transients.relaxation_bracket`), both evaluated without
    cancellation, so that

    .. math:: \sigma^2(m\Delta t) = s^2\,\frac{m P(\theta) + \phi C(m\theta)}
              {m^2 (1-\phi)^2}

    keeps full relative precision for correlation times far beyond the record
    (:math:`\to s^2\theta(2m^2+1)/(3m)`, a random walk) as well as for white-like ones.
    """
    m = np.asarray(m, dtype=np.float64)
    one_minus = -math.expm1(-theta)
    numerator = m * _walk_bracket(theta) + math.exp(-theta) * relaxation_bracket(m * theta)
    return variance * numerator / (m**2 * one_minus**2)
