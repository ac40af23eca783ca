r"""Gaussian streams: white noise, angle quantization and banks of first-order recursions.

The recursive generators (rate random walk, Gauss-Markov, the AR(1) bank of the
streaming flicker generator, low-pass filtered white noise) all run in the C++ core
(:func:`allanite._core.ar1_bank`, GIL released): ``J`` recursions per channel

.. math:: e = q_j z,\qquad y_k \mathrel{+}= a_j x_j + b_j e,\qquad x_j \leftarrow \phi_j x_j + e

driven by standard normal numbers drawn here (so the seed fixes every sample), plus an
independent Gaussian part of standard deviation ``g`` per sample where the sample is the
average of a continuous process over the sample period.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite import _core
from allanite.simulation.streams import TermStream

__all__ = [
    "Ar1BankStream",
    "QuantizationStream",
    "WhiteStream",
    "averaged_gauss_markov",
    "gauss_markov_stream",
    "random_walk_stream",
]

#: normal numbers drawn per sub-block of a bank (bounds the memory of many-component banks)
_BANK_VALUES = 1 << 20


class WhiteStream(TermStream):
    """Independent Gaussian samples of standard deviation ``sigma`` (white rate noise).

    For the angle random walk ``N`` the rate samples have ``sigma = N / sqrt(dt)``, whence the
    Allan variance ``N^2 / tau`` exactly.
    """

    def __init__(self, sigma: float, fs: float, n_channels: int, seed: Any = None) -> None:
        super().__init__(fs, n_channels, seed)
        self.sigma = float(sigma)

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        return self.sigma * self.rng.standard_normal((n, self.n_channels))


class QuantizationStream(TermStream):
    r"""Angle quantization noise as a differenced uniform angle error.

    Rate :math:`(e_k - e_{k-1})/\Delta t`, :math:`e` uniform on :math:`\pm\sqrt 3 Q` and
    independent (variance :math:`Q^2`), so the Allan variance is :math:`3Q^2/\tau^2`.
    """

    def __init__(self, Q: float, fs: float, n_channels: int, seed: Any = None) -> None:
        super().__init__(fs, n_channels, seed)
        self.half_width = math.sqrt(3.0) * float(Q)
        self._last = self._errors(1)[0]

    def _errors(self, n: int) -> NDArray[np.float64]:
        return self.rng.uniform(-self.half_width, self.half_width, (n, self.n_channels))

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        e = self._errors(n)
        rate = np.empty_like(e)
        rate[0] = e[0] - self._last
        rate[1:] = e[1:] - e[:-1]
        self._last = e[-1].copy()
        return rate * self.fs


class Ar1BankStream(TermStream):
    """Sum of ``J`` first-order recursions per channel, computed in the C++ core.

    Parameters
    ----------
    phi, q, a, b : array_like, shape (J,)
        Recursion coefficient, innovation standard deviation, weight of the state and weight
        of the innovation in each sample (see the module docstring).
    g : float
        Standard deviation of an extra independent Gaussian part of each sample (the part of
        a sample average not explained by the two ends of the interval).
    state : array_like, shape (J, C)
        Initial states.
    fs, n_channels, seed
        See :class:`TermStream`.
    threads : int
        Threads of the C++ loop over channels (results do not depend on it).
    """

    def __init__(
        self,
        phi: ArrayLike,
        q: ArrayLike,
        a: ArrayLike,
        b: ArrayLike,
        *,
        g: float = 0.0,
        fs: float,
        n_channels: int,
        seed: Any = None,
        initial_sd: ArrayLike = 0.0,
        threads: int = 1,
    ) -> None:
        super().__init__(fs, n_channels, seed)
        self.phi = np.ascontiguousarray(phi, dtype=np.float64).reshape(-1)
        j = self.phi.size
        self.q, self.a, self.b = (
            np.ascontiguousarray(np.broadcast_to(np.asarray(v, dtype=np.float64), (j,)))
            for v in (q, a, b)
        )
        self.g = float(g)
        self.threads = int(threads)
        sd = np.broadcast_to(np.asarray(initial_sd, dtype=np.float64), (j,))[:, None]
        self.state = np.ascontiguousarray(sd * self.rng.standard_normal((j, self.n_channels)))
        self._sub = max(1, _BANK_VALUES // (j * self.n_channels))

    def _generate(self, start: int, n: int) -> NDArray[np.float64]:
        out = np.empty((n, self.n_channels))
        j = self.phi.size
        for lo in range(0, n, self._sub):
            hi = min(n, lo + self._sub)
            z = self.rng.standard_normal((hi - lo, j, self.n_channels))
            out[lo:hi] = _core.ar1_bank(
                self.state, self.phi, self.q, self.a, self.b, z, self.threads
            )
            if self.g > 0.0:
                out[lo:hi] += self.g * self.rng.standard_normal((hi - lo, self.n_channels))
        return out


def random_walk_stream(K: float, fs: float, n_channels: int, seed: Any = None) -> Ar1BankStream:
    r"""Rate random walk :math:`r_k = r_{k-1} + K\sqrt{\Delta t}\,w_k` from :math:`r_{-1} = 0`.

    Allan variance exactly :math:`K^2\Delta t(2m^2+1)/(6m)` (``RateRandomWalk.avar``).
    """
    q = float(K) * math.sqrt(1.0 / fs)
    return Ar1BankStream([1.0], [q], [1.0], [1.0], fs=fs, n_channels=n_channels, seed=seed)


def gauss_markov_stream(
    sigma: ArrayLike, tau_c: ArrayLike, fs: float, n_channels: int, seed: Any = None, **kw: Any
) -> Ar1BankStream:
    r"""Sum of stationary point-sampled AR(1) processes (exact Gauss-Markov discretisation).

    :math:`x_k = \phi x_{k-1} + \sigma\sqrt{1-\phi^2}\,w_k`, :math:`\phi = e^{-\Delta t/T_c}`,
    started from the stationary law :math:`x_{-1} \sim N(0, \sigma^2)`; the sample is
    :math:`x_k`. Allan variance: ``GaussMarkov.avar`` (the sampled AR(1) form).
    """
    sigma = np.atleast_1d(np.asarray(sigma, dtype=np.float64))
    theta = (1.0 / fs) / np.atleast_1d(np.asarray(tau_c, dtype=np.float64))
    phi = np.exp(-theta)
    q = sigma * np.sqrt(-np.expm1(-theta) * (1.0 + phi))
    return Ar1BankStream(
        phi, q, phi, 1.0, fs=fs, n_channels=n_channels, seed=seed, initial_sd=sigma, **kw
    )


def _residual_variance(theta: float) -> float:
    """Var(average | both ends) / sigma^2 of a unit Gauss-Markov process over theta = dt/Tc.

    Direct form for theta >= 0.1; below, its Taylor series (derived with exact rational
    arithmetic), accurate to 1e-15 there, avoids the cancellation of the direct form.
    """
    if theta >= 0.1:
        phi = math.exp(-theta)
        om = -math.expm1(-theta)
        return (2.0 * (theta - om) - om * om - om**3 / (1.0 + phi)) / theta**2
    t2 = theta * theta
    return theta * (
        1 / 6 + t2 * (-1 / 60 + t2 * (17 / 10080 + t2 * (-31 / 181440 + t2 * 691 / 39916800)))
    )


def averaged_gauss_markov(
    sigma: float, tau_c: float, fs: float, n_channels: int, seed: Any = None
) -> Ar1BankStream:
    r"""Sample averages of a continuous Gauss-Markov process (exact, also for ``Tc << dt``).

    With :math:`\theta = \Delta t/T_c`, :math:`\phi = e^{-\theta}`, the average of the process
    over a sample period, given its value :math:`x_k` at the start and the innovation
    :math:`e` to the end, is

    .. math:: \bar x_k = \frac{1-\phi}{\theta} x_k + \frac{1-\phi}{\theta(1+\phi)} e
              + \gamma w,\qquad
              \gamma^2/\sigma^2 = \frac{2(\theta - 1 + \phi) - (1-\phi)^2}{\theta^2}
              - \frac{(1-\phi)^3}{\theta^2 (1+\phi)}

    (Gaussian conditioning). Its Allan variance is the continuous Gauss-Markov formula at
    :math:`\tau = m\Delta t`: :math:`(2\sigma^2T_c/\tau)[1 - (T_c/2\tau)(3 - 4e^{-\tau/T_c}
    + e^{-2\tau/T_c})]`. This is also first-order low-pass filtered white noise.
    """
    theta = (1.0 / fs) / float(tau_c)
    phi = math.exp(-theta)
    om = -math.expm1(-theta)
    q = float(sigma) * math.sqrt(om * (1.0 + phi))
    a = om / theta
    b = om / (theta * (1.0 + phi))
    g = float(sigma) * math.sqrt(max(_residual_variance(theta), 0.0))
    return Ar1BankStream(
        [phi], [q], [a], [b], g=g, fs=fs, n_channels=n_channels, seed=seed, initial_sd=sigma
    )
