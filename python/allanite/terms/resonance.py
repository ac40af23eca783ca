r"""A mechanical resonance: white noise through a second-order band-pass."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import averaging_factor, check_parameters
from allanite.terms.base import ParamSpec, Term

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream

__all__ = ["Resonance", "geometric_avar"]


def geometric_avar(
    phi: complex | NDArray[np.complex128], m: NDArray[np.float64]
) -> NDArray[np.complex128]:
    r"""Allan variance at ``m`` samples of a unit "process" with autocovariance ``phi^|l|``.

    The Allan variance is linear in the autocovariance; for ``gamma_l = phi^|l|`` it is

    .. math:: A(\phi, m) = \frac{m - 3\phi - m\phi^2 + 4\phi^{m+1} - \phi^{2m+1}}
              {m^2 (1-\phi)^2},

    a rational function of ``phi`` that also holds for complex ``phi`` (a real process with
    autocovariance ``Re(C p^l)`` has Allan variance ``Re(C A(p, m))``). ``|phi| < 1``.
    """
    phi = np.asarray(phi, dtype=np.complex128)
    num = m - 3.0 * phi - m * phi**2 + 4.0 * phi ** (m + 1.0) - phi ** (2.0 * m + 1.0)
    return np.asarray(num / (m**2 * (1.0 - phi) ** 2), dtype=np.complex128)


@dataclass(frozen=True)
class Resonance(Term):
    r"""White rate noise through a second-order band-pass (a lightly damped resonance).

    The continuous process is white noise of angle random walk ``N`` (one-sided PSD
    :math:`2N^2`) through

    .. math:: H(s) = \frac{2\zeta\omega_0 s}{s^2 + 2\zeta\omega_0 s + \omega_0^2},
              \qquad \omega_0 = 2\pi f_0,

    whose gain is 1 at :math:`f_0`: the one-sided PSD :math:`2N^2|H(2\pi i f)|^2` peaks at the
    level of white noise ``N`` and falls off on both sides (half-power width :math:`2\zeta
    f_0`). Its variance is :math:`\sigma^2 = N^2\zeta\omega_0` and, with :math:`\alpha =
    \zeta\omega_0`, :math:`\omega_d = \omega_0\sqrt{1-\zeta^2}` (``0 < zeta < 1``), its
    autocovariance is :math:`\gamma(t) = \sigma^2 e^{-\alpha|t|}(\cos\omega_d t -
    (\alpha/\omega_d)\sin\omega_d |t|) = \sigma^2\,\mathrm{Re}(C p^{|t|/\Delta t})` with
    :math:`C = 1 + i\alpha/\omega_d`, :math:`p = e^{(-\alpha + i\omega_d)\Delta t}`.

    The samples are point samples of this process. Their Allan variance is exactly
    :math:`\sigma^2\,\mathrm{Re}(C\,A(p, m))` (:func:`geometric_avar`), their one-sided PSD
    :math:`2\Delta t\,\sigma^2[1 + \mathrm{Re}(C(g(\theta) + g(-\theta)))]` with
    :math:`g(\theta) = pe^{i\theta}/(1 - pe^{i\theta})`, :math:`\theta = 2\pi f\Delta t`
    (aliasing included), and the simulation is the exact discretisation of the state
    :math:`(x, \dot x)` of :math:`1/(s^2 + 2\zeta\omega_0 s + \omega_0^2)` (output
    :math:`2\zeta\omega_0\dot x`).

    Parameters
    ----------
    N : float
        Level: the white noise whose PSD the resonance reaches at its peak.
    frequency : float
        Resonance frequency ``f0`` in Hz.
    damping : float
        Damping ratio ``zeta`` in (0, 1) (quality factor ``Q = 1 / (2 zeta)``).
    """

    N: float
    frequency: float
    damping: float

    type: ClassVar[str] = "resonance"
    symbol: ClassVar[str] = "N"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("N", rate=1, time=0.5, description="white-noise level at the resonance peak"),
        ParamSpec("frequency", rate=0, time=-1, description="resonance frequency in Hz"),
        ParamSpec("damping", rate=0, time=0, description="damping ratio (Q = 1 / (2 zeta))"),
    )

    def __post_init__(self) -> None:
        check_parameters(self, positive=("frequency", "damping"))
        if not 0.0 < self.damping < 1.0:
            raise ValueError(
                f"resonance: damping must lie in (0, 1) (an underdamped band-pass), got "
                f"{self.damping}; an overdamped filter is two Gauss-Markov terms"
            )

    @property
    def omega0(self) -> float:
        """Angular resonance frequency in rad/s."""
        return 2.0 * math.pi * self.frequency

    @property
    def variance(self) -> float:
        """Variance of the continuous process ``N^2 zeta omega0``."""
        return self.N**2 * self.damping * self.omega0

    def _pole(self, dt: float) -> tuple[complex, complex]:
        a = self.damping * self.omega0
        wd = self.omega0 * math.sqrt(1.0 - self.damping**2)
        return complex(1.0, a / wd), complex(np.exp(complex(-a, wd) * dt))

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact Allan variance of the point samples (see the class docstring)."""
        _, m, step = averaging_factor(tau, dt)
        c, p = self._pole(step)
        return np.asarray(self.variance * np.real(c * geometric_avar(p, m)), dtype=np.float64)

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD ``2 N^2 |H(2 pi i f)|^2`` of the continuous process."""
        w = 2.0 * np.pi * np.asarray(f, dtype=np.float64)
        bw = 2.0 * self.damping * self.omega0 * w
        return 2.0 * self.N**2 * bw**2 / ((self.omega0**2 - w**2) ** 2 + bw**2)

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact one-sided PSD of the point samples (aliasing included)."""
        theta = 2.0 * np.pi * np.asarray(f, dtype=np.float64) * dt
        c, p = self._pole(dt)
        e = np.exp(1j * theta)
        g = p * e / (1.0 - p * e) + p / e / (1.0 - p / e)
        return np.asarray(2.0 * dt * self.variance * (1.0 + np.real(c * g)), dtype=np.float64)

    def transition(self, dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Exact one-step transition ``Phi`` and noise covariance ``Q`` of the state (x, x')."""
        from scipy.linalg import expm

        a1, a0 = 2.0 * self.damping * self.omega0, self.omega0**2
        phi = expm(np.array([[0.0, 1.0], [-a0, -a1]]) * dt)
        # stationary covariance for white input of two-sided PSD N^2
        sigma = np.diag([self.N**2 / (2.0 * a1 * a0), self.N**2 / (2.0 * a1)])
        q = sigma - phi @ sigma @ phi.T
        return phi, 0.5 * (q + q.T)

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Exact point samples: the discretised state recursion, run block-wise by lfilter."""
        from scipy import signal

        from allanite.simulation.streams import TermStream

        term = self
        gain = 2.0 * self.damping * self.omega0

        class ResonanceStream(TermStream):
            def __init__(self) -> None:
                super().__init__(fs, n_channels, seed)
                self.phi, q = term.transition(self.dt)
                self.chol = np.linalg.cholesky(q + 1e-300 * np.eye(2))
                a1, a0 = 2.0 * term.damping * term.omega0, term.omega0**2
                sd = np.sqrt([term.N**2 / (2.0 * a1 * a0), term.N**2 / (2.0 * a1)])
                self.state = sd[:, None] * self.rng.standard_normal((2, self.n_channels))
                mu, vec = np.linalg.eig(self.phi)
                self.mu, self.vec, self.vec_inv = mu, vec, np.linalg.inv(vec)

            def _generate(self, start: int, n: int) -> NDArray[np.float64]:
                z = self.rng.standard_normal((2, n, self.n_channels))
                u = np.einsum("ij,jkc->ikc", self.chol, z)
                ph = self.phi
                den = [1.0, -np.trace(ph), np.linalg.det(ph)]
                x = signal.lfilter([1.0, -ph[1, 1]], den, u[0], axis=0) + signal.lfilter(
                    [0.0, ph[0, 1]], den, u[1], axis=0
                )
                v = signal.lfilter([0.0, ph[1, 0]], den, u[0], axis=0) + signal.lfilter(
                    [1.0, -ph[0, 0]], den, u[1], axis=0
                )
                k = np.arange(1, n + 1)
                mk = self.mu[None, :] ** k[:, None]  # (n, 2)
                # Phi^k z0 = V diag(mu^k) V^-1 z0
                w0 = self.vec_inv @ self.state  # (2, C)
                hom = np.real(np.einsum("ij,kj,jc->kic", self.vec, mk, w0))  # (n, 2, C)
                x = x + hom[:, 0, :]
                v = v + hom[:, 1, :]
                self.state = np.stack([x[-1], v[-1]])
                return np.asarray(gain * v, dtype=np.float64)

        return ResonanceStream()
