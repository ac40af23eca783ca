r"""Gyro vertical with a complementary filter: optimum time constant, accuracy, output noise.

A tilt angle is propagated by the gyro rate and pulled towards the accelerometer tilt
``a / g`` with time constant ``T``:

.. math:: \dot{\hat\theta} = \omega + (a/g - \hat\theta)/T .

For white gyro noise (ARW ``N``, rad/sqrt(s)) and white accelerometer noise (VRW, m/s/sqrt(s))
the error is a first-order Gauss-Markov process with correlation time ``T`` driven by the
intensity ``q = N^2 + VRW^2 / (g T)^2``, so its variance is

.. math:: \sigma^2(T) = (N^2 T + VRW^2 / (T g^2)) / 2 ,

minimal at ``T = VRW / (g N)`` with ``sigma = sqrt(N VRW / g)``. The discrete filter
``theta[k] = alpha (theta[k-1] + omega[k] T0) + (1 - alpha) a[k] / g`` with
``alpha = T / (T + T0)`` has, at the optimum, ``alpha = VRW / (g T0 N + VRW)`` (``alpha`` is
the weight of the gyro path).

Allan deviation of the filter output (the angle samples, ``avar(..., input="angle")``): with
``V = sigma^2`` and ``x = tau / T``,

.. math:: \sigma_A^2(\tau) = V (6 - 8 e^{-x} + 2 e^{-2x}) / (2 \tau^2)

(exact for the sampled AR(1) output with ``e^{-x} -> alpha^m``). Its asymptotes are
``q / tau`` (slope -1/2 of the deviation, ``tau << T``: the gyro's angle random walk) and
``3 V / tau^2`` (slope -1, ``tau >> T``: white angle noise); they cross at ``tau = 1.5 T``.
The source quotes the break at ``1.89 T``: that is the peak of the Allan deviation of the same
output taken as the signal itself (``input="rate"``, the Gauss-Markov hump at ``1.89 T_c``,
slopes +1/2 and -1/2). Both views are available here; see docs/impact.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.signal import lfilter

from allanite.impact._checks import positive as _positive
from allanite.impact.earth import STANDARD_GRAVITY
from allanite.terms.markov import PEAK_TAU, GaussMarkov

__all__ = [
    "ComplementaryFilter",
    "complementary_filter_sigma",
    "optimal_complementary_filter",
]


def complementary_filter_sigma(
    arw: float, vrw: float, time_constant: float, *, g: float = STANDARD_GRAVITY
) -> float:
    """Steady-state tilt error ``sqrt((N^2 T + VRW^2 / (T g^2)) / 2)`` in rad.

    Parameters
    ----------
    arw : float
        Gyro angle random walk ``N`` in rad/sqrt(s).
    vrw : float
        Accelerometer velocity random walk in m/s/sqrt(s).
    time_constant : float
        Filter time constant ``T`` in seconds.
    g : float
        Gravity in m/s^2.
    """
    n, v = _positive("arw", arw), _positive("vrw", vrw)
    t, gg = _positive("time_constant", time_constant), _positive("g", g)
    return math.sqrt((n**2 * t + v**2 / (t * gg**2)) / 2.0)


@dataclass(frozen=True)
class ComplementaryFilter:
    """A gyro-vertical complementary filter for white gyro and accelerometer noise.

    Attributes
    ----------
    arw : float
        Gyro angle random walk ``N`` in rad/sqrt(s).
    vrw : float
        Accelerometer velocity random walk in m/s/sqrt(s).
    time_constant : float
        ``T`` in seconds.
    dt : float
        Sample period ``T0`` of the discrete filter in seconds.
    g : float
        Gravity in m/s^2.
    """

    arw: float
    vrw: float
    time_constant: float
    dt: float
    g: float = STANDARD_GRAVITY

    def __post_init__(self) -> None:
        for name in ("arw", "vrw", "time_constant", "dt", "g"):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))

    # --- design ------------------------------------------------------------------------------
    @property
    def alpha(self) -> float:
        """Weight of the gyro path ``T / (T + T0)`` (``VRW / (g T0 N + VRW)`` at the optimum)."""
        return self.time_constant / (self.time_constant + self.dt)

    @property
    def sigma(self) -> float:
        """Steady-state tilt error of the continuous filter in rad."""
        return complementary_filter_sigma(self.arw, self.vrw, self.time_constant, g=self.g)

    @property
    def discrete_time_constant(self) -> float:
        """Correlation time ``-T0 / ln(alpha)`` of the sampled output (tends to ``T``)."""
        return -self.dt / math.log(self.alpha)

    @property
    def output_variance(self) -> float:
        """Stationary variance of the discrete filter's tilt error in rad^2.

        ``(alpha^2 T0 N^2 + (1 - alpha)^2 VRW^2 / (g^2 T0)) / (1 - alpha^2)``: the sampled
        gyro rate has variance ``N^2 / T0``, the sampled accelerometer tilt ``VRW^2 / (g^2 T0)``.
        """
        a, t0 = self.alpha, self.dt
        q = a**2 * t0 * self.arw**2 + (1.0 - a) ** 2 * self.vrw**2 / (self.g**2 * t0)
        return q / (1.0 - a**2)

    # --- the filter --------------------------------------------------------------------------
    def apply(self, rate: ArrayLike, accel: ArrayLike) -> NDArray[np.float64]:
        """Run the discrete filter on gyro rate (rad/s) and specific force (m/s^2) samples.

        ``theta[k] = alpha (theta[k-1] + rate[k] T0) + (1 - alpha) accel[k] / g`` with
        ``theta[-1] = accel[0] / g`` (started on the accelerometer tilt). The leading axis is
        time; further axes are independent channels.

        Returns
        -------
        numpy.ndarray
            Tilt angle in rad, shaped like the inputs.
        """
        w = np.asarray(rate, dtype=np.float64)
        a = np.asarray(accel, dtype=np.float64)
        if w.shape != a.shape or w.ndim == 0 or w.shape[0] < 2:
            raise ValueError(
                f"rate and accel must have the same shape with at least 2 samples along axis 0, "
                f"got {w.shape} and {a.shape}"
            )
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(a))):
            raise ValueError("rate and accel must be finite; remove or fill gaps first")
        al = self.alpha
        drive = al * self.dt * w + (1.0 - al) * a / self.g
        zi = np.asarray([al * a[0] / self.g])
        out, _ = lfilter([1.0], [1.0, -al], drive, axis=0, zi=zi.reshape((1, *w.shape[1:])))
        return np.asarray(out, dtype=np.float64)

    # --- Allan deviation of the output -------------------------------------------------------
    def output_avar(self, tau: ArrayLike, *, view: str = "angle") -> NDArray[np.float64]:
        """Exact Allan variance of the sampled filter output for white sensor noise.

        Parameters
        ----------
        tau : array_like
            Averaging times in seconds (multiples of ``dt``).
        view : {"angle", "signal"}
            ``angle``: the output as angle samples, the variance of the rate they imply
            (``avar(theta, fs, input="angle")``), ``V (6 - 8 alpha^m + 2 alpha^{2m}) /
            (2 tau^2)`` in (rad/s)^2. ``signal``: the output samples averaged directly
            (``avar(theta, fs, input="rate")``), the Gauss-Markov Allan variance in rad^2.

        Returns
        -------
        numpy.ndarray
        """
        tt = np.asarray(tau, dtype=np.float64)
        m = np.rint(tt / self.dt)
        if np.any(m < 1) or not np.allclose(m * self.dt, tt, rtol=1e-9, atol=0.0):
            raise ValueError("tau must be positive multiples of the filter's sample period dt")
        if view == "signal":
            return self._as_markov().avar(tt, self.dt)
        if view != "angle":
            raise ValueError(f"view must be 'angle' or 'signal', got {view!r}")
        a = self.alpha
        v = self.output_variance
        return np.asarray(v * (6.0 - 8.0 * a**m + 2.0 * a ** (2.0 * m)) / (2.0 * tt**2))

    def _as_markov(self) -> GaussMarkov:
        return GaussMarkov(sigma=math.sqrt(self.output_variance), tau_c=self.discrete_time_constant)

    def short_asymptote(self, tau: ArrayLike) -> NDArray[np.float64]:
        """``tau << T`` asymptote ``2 V / (T_d tau)`` of the angle-view variance (slope -1/2)."""
        tt = np.asarray(tau, dtype=np.float64)
        return np.asarray(2.0 * self.output_variance / (self.discrete_time_constant * tt))

    def long_asymptote(self, tau: ArrayLike) -> NDArray[np.float64]:
        """``tau >> T`` asymptote ``3 V / tau^2`` of the angle-view variance (slope -1)."""
        tt = np.asarray(tau, dtype=np.float64)
        return np.asarray(3.0 * self.output_variance / tt**2)

    @property
    def break_tau(self) -> float:
        """Where the two angle-view asymptotes cross: ``1.5 T_d`` seconds."""
        return 1.5 * self.discrete_time_constant

    @property
    def signal_peak_tau(self) -> float:
        """Peak of the signal-view Allan deviation: ``1.89 T_d`` (the Gauss-Markov hump)."""
        return PEAK_TAU * self.discrete_time_constant


def optimal_complementary_filter(
    arw: float, vrw: float, *, dt: float, g: float = STANDARD_GRAVITY
) -> ComplementaryFilter:
    """Build the filter with the optimum time constant ``T = VRW / (g N)``.

    Its steady-state tilt error is ``sqrt(N VRW / g)`` and its gyro weight
    ``alpha = VRW / (g T0 N + VRW)``.

    Parameters
    ----------
    arw : float
        Gyro angle random walk ``N`` in rad/sqrt(s).
    vrw : float
        Accelerometer velocity random walk in m/s/sqrt(s).
    dt : float
        Sample period ``T0`` in seconds.
    g : float
        Gravity in m/s^2.

    Returns
    -------
    ComplementaryFilter
    """
    n, v, gg = _positive("arw", arw), _positive("vrw", vrw), _positive("g", g)
    return ComplementaryFilter(arw=n, vrw=v, time_constant=v / (gg * n), dt=dt, g=gg)
