r"""Non-stationary and non-Gaussian effects: the candidates a sim-to-real diagnosis tests.

Each is a :class:`~allanite.terms.base.Term` with its Allan variance for a sampled record
(rate samples are the means of the continuous rate over each sample period) and a streaming
simulation. Several mimic a standard term in the tau view, which is why a diagnosis needs the
time and frequency views as well:

=====================  ========================================  ===========================
term                   Allan variance                            looks like
=====================  ========================================  ===========================
TurnOnBias             0 (a constant per run)                    nothing (invisible)
WarmUp                 exact sum for a record of length ``T``    drift / ramp
BiasSteps              :math:`b^2\tau/(3T_s)` (exact mean)       rate random walk
Spikes                 :math:`p a^2\Delta t/\tau`                white noise
Telegraph              Gauss-Markov, :math:`s = a`               Gauss-Markov
LowPassWhite           :math:`N^2/\tau\,[1 - \frac{T_f}{2\tau}   white noise with a negative
                       (3 - 4e^{-\tau/T_f} + e^{-2\tau/T_f})]`   quantization part
=====================  ========================================  ===========================
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import averaging_factor, check_parameters
from allanite.terms._estimator_kurtosis import (
    iid_excess_variance,
    step_excess_variance,
    telegraph_excess_variance,
)
from allanite.terms.base import ParamSpec, Term
from allanite.terms.filter_laws import (
    FILTER_KINDS,
    box_length,
    filter_avar,
    filter_coefficients,
    filter_gain,
    filter_gain_analog,
)

__all__ = [
    "BiasSteps",
    "LowPassWhite",
    "Spikes",
    "Telegraph",
    "TurnOnBias",
    "WarmUp",
    "markov_avar_continuous",
    "markov_psd_sampled",
    "relaxation_bracket",
]


def markov_avar_continuous(variance: float, tau_c: float, tau: ArrayLike) -> NDArray[np.float64]:
    r"""Allan variance of a continuous Gauss-Markov process averaged over ``tau``.

    .. math:: \sigma^2(\tau) = \frac{2 s^2 T_c}{\tau}\left[1 - \frac{T_c}{2\tau}
              \left(3 - 4e^{-\tau/T_c} + e^{-2\tau/T_c}\right)\right]

    exact for sample means at :math:`\tau = m\Delta t` (IEEE 952 Annex C; Gelb 1974). Written
    with ``expm1`` so that it stays accurate for :math:`\tau \ll T_c`.
    """
    x = np.asarray(tau, dtype=np.float64) / tau_c
    return variance * relaxation_bracket(x) / x**2


def relaxation_bracket(x: ArrayLike) -> NDArray[np.float64]:
    r"""Return :math:`2x - 3 + 4e^{-x} - e^{-2x}` without cancellation (:math:`\approx 2x^3/3`).

    Below ``x = 0.1`` its Taylor series (terms :math:`x^3 .. x^{11}`, the coefficients
    :math:`(4(-1)^k - (-2)^k)/k!`), relative error below 1e-15 there; the direct form above.
    """
    x = np.asarray(x, dtype=np.float64)
    direct = 2.0 * x - 3.0 + 4.0 * np.exp(-x) - np.exp(-2.0 * x)
    coefficients = (
        2 / 3, -1 / 2, 7 / 30, -1 / 12, 31 / 1260, -1 / 160, 127 / 90720, -17 / 60480,
        511 / 9979200,
    )  # fmt: skip
    series = np.zeros_like(x)
    for c in reversed(coefficients):
        series = series * x + c
    return np.asarray(np.where(x < 0.1, series * x**3, direct), dtype=np.float64)


def markov_psd_sampled(
    variance: float, tau_c: float, f: ArrayLike, dt: float
) -> NDArray[np.float64]:
    r"""One-sided PSD of the sample means of a continuous Gauss-Markov process (aliasing in).

    The means over consecutive periods have the autocovariance
    :math:`r_0 = 2s^2(\theta - 1 + \phi)/\theta^2` and
    :math:`r_k = s^2 (1-\phi)^2\phi^{k-1}/\theta^2` (:math:`k \ge 1`), with
    :math:`\theta = \Delta t/T_c`, :math:`\phi = e^{-\theta}` (an ARMA(1,1) sequence), so with
    :math:`\omega = 2\pi f\Delta t`

    .. math:: S(f) = 2\Delta t\left[r_0 + \frac{2 s^2(1-\phi)^2}{\theta^2}
              \frac{\cos\omega - \phi}{1 - 2\phi\cos\omega + \phi^2}\right].
    """
    w = 2.0 * np.pi * np.asarray(f, dtype=np.float64) * dt
    theta = dt / tau_c
    phi = math.exp(-theta)
    one_minus = -math.expm1(-theta)
    r0 = variance * 2.0 * (theta - one_minus) / theta**2
    tail = 2.0 * variance * one_minus**2 / theta**2
    denominator = one_minus**2 + 4.0 * phi * np.sin(0.5 * w) ** 2
    return 2.0 * dt * (r0 + tail * (np.cos(w) - phi) / denominator)


@dataclass(frozen=True)
class TurnOnBias(Term):
    r"""Random constant turn-on bias: a rate offset drawn once per run, standard deviation ``m``.

    A constant has zero Allan variance (the estimator removes it), so this term is invisible
    in the tau view; it shows in the run-to-run spread of the mean rate, and in the angle
    error variance :math:`m^2 t^2` of the laser-gyro model.
    """

    sigma: float

    type: ClassVar[str] = "turn_on_bias"
    symbol: ClassVar[str] = "m"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("sigma", rate=1, time=0, description="run-to-run bias standard deviation"),
    )
    stationary: ClassVar[bool] = False

    def __post_init__(self) -> None:
        check_parameters(self)

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Zero: a constant has no Allan variance."""
        t, _, _ = averaging_factor(tau, dt)
        return np.zeros_like(t)

    def stream(self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None) -> Any:
        """Stream a constant per channel, ``N(0, sigma^2)``, drawn per run."""
        from allanite.simulation.effects import ConstantStream

        return ConstantStream(self.sigma, fs, n_channels, seed)


@dataclass(frozen=True)
class WarmUp(Term):
    r"""Exponential warm-up transient :math:`A e^{-t/T_w}` in a record of duration ``T``.

    With :math:`r = e^{-\Delta t/T_w}`, sample means :math:`c\,r^k`,
    :math:`c = A (T_w/\Delta t)(1 - r)`, and :math:`n = T/\Delta t` samples, the block means
    over :math:`m` samples differ by :math:`c\,r^k (1-r^m)^2/(m(1-r))`, so the overlapping
    Allan variance of the record is exactly

    .. math:: \sigma^2(m\Delta t) = \frac{c^2 (1-r^m)^4}{2 m^2 (1-r)^2 (n-2m+1)}
              \,\frac{1 - r^{2(n-2m+1)}}{1 - r^2}.

    It depends on the record length (the transient is diluted by a long record), which is
    therefore a parameter.

    Parameters
    ----------
    amplitude : float
        Rate offset at switch-on, ``A`` (its sign does not change the Allan variance).
    tau_w : float
        Time constant ``T_w`` in seconds.
    duration : float
        Record length ``T`` in seconds the Allan variance refers to.
    """

    amplitude: float
    tau_w: float
    duration: float

    type: ClassVar[str] = "warmup"
    symbol: ClassVar[str] = "A"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("amplitude", rate=1, time=0, description="rate offset at switch-on"),
        ParamSpec("tau_w", rate=0, time=1, description="warm-up time constant"),
        ParamSpec("duration", rate=0, time=1, description="record length"),
    )
    stationary: ClassVar[bool] = False

    def __post_init__(self) -> None:
        check_parameters(self, positive=("tau_w", "duration"))

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact overlapping Allan variance of the transient in a record of ``duration``."""
        _, m, step = averaging_factor(tau, dt)
        n = round(self.duration / step)
        one_minus_r = -math.expm1(-step / self.tau_w)
        c = self.amplitude * (self.tau_w / step) * one_minus_r
        terms = n - 2.0 * m + 1.0
        ok = terms >= 1.0
        terms = np.where(ok, terms, 1.0)
        log_r = -step / self.tau_w
        block = -np.expm1(m * log_r)  # 1 - r^m
        geometric = np.expm1(2.0 * terms * log_r) / math.expm1(2.0 * log_r)
        value = c**2 * block**4 * geometric / (2.0 * m**2 * one_minus_r**2 * terms)
        return np.where(ok, value, np.nan)

    def stream(self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None) -> Any:
        """Stream the deterministic transient (same in every channel)."""
        from allanite.simulation.effects import WarmUpStream

        return WarmUpStream(self.amplitude, self.tau_w, fs, n_channels, seed)


@dataclass(frozen=True)
class BiasSteps(Term):
    r"""Bias steps of random size (standard deviation ``size``) every ``interval`` s on average.

    The steps occur at the events of a Poisson process, so the rate is a compound-Poisson
    random walk with the second-order structure of a Wiener process of intensity
    :math:`K^2 = b^2/T_s`; its sample means have exactly

    .. math:: \sigma^2(\tau) = \frac{b^2\tau}{3 T_s},

    the rate-random-walk look-alike (one step in a record of length :math:`T`:
    :math:`b^2\tau/(3T)`).
    """

    size: float
    interval: float

    type: ClassVar[str] = "bias_steps"
    symbol: ClassVar[str] = "b"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("size", rate=1, time=0, description="step size standard deviation"),
        ParamSpec("interval", rate=0, time=1, description="mean time between steps"),
    )
    stationary: ClassVar[bool] = False

    def __post_init__(self) -> None:
        check_parameters(self, positive=("interval",))

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """``size^2 tau / (3 interval)`` (exact expectation)."""
        t, _, _ = averaging_factor(tau, dt)
        return self.size**2 * t / (3.0 * self.interval)

    def avar_excess_variance(self, tau: ArrayLike, dt: float, n: int) -> NDArray[np.float64]:
        """Exact excess variance of the estimate: few steps make it a Poisson count.

        Compound-Poisson steps of Gaussian size, ``E[J^4] = 3 size^4``
        (:func:`~allanite.terms._estimator_kurtosis.step_excess_variance`).
        """
        return step_excess_variance(tau, dt, n, 1.0 / self.interval, 3.0 * self.size**4)

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        r"""Spectrum of the sample means, the second-order twin of rate random walk.

        The steps have the covariance of the sample means of a Wiener process of intensity
        :math:`K^2 = b^2/T_s`, whose increments are MA(1) (variance :math:`2K^2\Delta t/3`,
        lag-one covariance :math:`K^2\Delta t/6`); with :math:`\omega = 2\pi f\Delta t`

        .. math:: S(f) = \frac{K^2\Delta t^2\,(2 + \cos\omega)}{6\sin^2(\omega/2)}

        (a random walk's spectrum: the process itself is not stationary, its differences are).
        """
        w = 2.0 * np.pi * np.asarray(f, dtype=np.float64) * dt
        k2 = self.size**2 / self.interval
        return k2 * dt**2 * (2.0 + np.cos(w)) / (6.0 * np.sin(0.5 * w) ** 2)

    def stream(self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None) -> Any:
        """Poisson steps, exact sample means."""
        from allanite.simulation.effects import StepStream

        return StepStream(self.size, self.interval, fs, n_channels, seed)


@dataclass(frozen=True)
class Spikes(Term):
    r"""Isolated spikes (outliers) of height ``amplitude`` at ``rate`` per second.

    A sample is hit with probability :math:`p = 1 - e^{-\lambda\Delta t}` and then reads
    :math:`\pm a` more.

    Independent, zero-mean, per-sample variance :math:`p a^2`, hence white-noise-like:

    .. math:: \sigma^2(\tau) = p\,a^2\,\Delta t/\tau.
    """

    amplitude: float
    rate: float

    type: ClassVar[str] = "spikes"
    symbol: ClassVar[str] = "a"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("amplitude", rate=1, time=0, description="spike height"),
        ParamSpec("rate", rate=0, time=-1, description="spikes per second"),
    )
    stationary: ClassVar[bool] = True

    def __post_init__(self) -> None:
        check_parameters(self)

    def probability(self, dt: float) -> float:
        """Probability that a sample of period ``dt`` carries a spike."""
        return -math.expm1(-self.rate * dt)

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """``p a^2 dt / tau`` (exact)."""
        t, _, step = averaging_factor(tau, dt)
        return self.probability(step) * self.amplitude**2 * step / t

    def avar_excess_variance(self, tau: ArrayLike, dt: float, n: int) -> NDArray[np.float64]:
        r"""Exact excess variance of the estimate (i.i.d. samples, heavy-tailed).

        Per-sample fourth cumulant :math:`\kappa_4 = p a^4 (1 - 3p)`, i.e. excess kurtosis
        :math:`1/p - 3` (:func:`~allanite.terms._estimator_kurtosis.iid_excess_variance`).
        """
        p = self.probability(dt)
        return iid_excess_variance(tau, dt, n, p * self.amplitude**4 * (1.0 - 3.0 * p))

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """White: ``2 p a^2 dt``."""
        return np.full(np.shape(f), 2.0 * self.probability(dt) * self.amplitude**2 * dt)

    def stream(self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None) -> Any:
        """Bernoulli spikes with random sign."""
        from allanite.simulation.effects import SpikeStream

        return SpikeStream(self.amplitude, self.rate, fs, n_channels, seed)


@dataclass(frozen=True)
class Telegraph(Term):
    r"""Random telegraph (burst, popcorn) noise :math:`\pm a`, correlation time :math:`T_c`.

    Switching rate :math:`1/(2T_c)` each way, autocovariance :math:`a^2 e^{-|t|/T_c}`: in the
    Allan variance exactly a Gauss-Markov process of standard deviation ``a`` (continuous
    form, :func:`markov_avar_continuous`); only the amplitude distribution (two values) and
    the time series tell it apart. One-sided PSD :math:`4a^2T_c/(1 + (2\pi f T_c)^2)`.
    """

    amplitude: float
    tau_c: float

    type: ClassVar[str] = "telegraph"
    symbol: ClassVar[str] = "a"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("amplitude", rate=1, time=0, description="level"),
        ParamSpec("tau_c", rate=0, time=1, description="correlation time"),
    )

    def __post_init__(self) -> None:
        check_parameters(self, positive=("tau_c",))

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Continuous Gauss-Markov Allan variance with ``s = amplitude`` (exact)."""
        t, _, _ = averaging_factor(tau, dt)
        return markov_avar_continuous(self.amplitude**2, self.tau_c, t)

    def avar_excess_variance(self, tau: ArrayLike, dt: float, n: int) -> NDArray[np.float64]:
        """Exact excess variance of the estimate, positive or negative.

        Positive (a Poisson count of switches) at tau << Tc, negative (a two-valued signal is
        lighter-tailed than Gaussian) at tau >> Tc
        (:func:`~allanite.terms._estimator_kurtosis.telegraph_excess_variance`).
        """
        return telegraph_excess_variance(tau, dt, n, self.amplitude, self.tau_c)

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD ``4 a^2 Tc / (1 + (2 pi f Tc)^2)``."""
        f = np.asarray(f, dtype=np.float64)
        return 4.0 * self.amplitude**2 * self.tau_c / (1.0 + (2.0 * np.pi * f * self.tau_c) ** 2)

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact PSD of the sample means (:func:`markov_psd_sampled`, aliasing included)."""
        return markov_psd_sampled(self.amplitude**2, self.tau_c, f, dt)

    def stream(self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None) -> Any:
        """Exact sample means of the switching signal."""
        from allanite.simulation.effects import TelegraphStream

        return TelegraphStream(self.amplitude, self.tau_c, fs, n_channels, seed)


@dataclass(frozen=True)
class LowPassWhite(Term):
    r"""The sensor's output filter: white rate noise ``N`` seen through a low-pass of ``bandwidth``.

    ``N`` is the density of the UNFILTERED sensor (what the Allan curve shows at taus well
    above the filter, ``N^2/tau``), ``bandwidth`` the -3 dB frequency in Hz, ``filter`` the
    kind (:mod:`allanite.terms.filter_laws`):

    * ``rc`` (default): an analog first-order low-pass before the sampler, :math:`T_f =
      1/(2\pi f_c)`. The output is a Gauss-Markov process of variance :math:`N^2/(2T_f)`
      and correlation time :math:`T_f`; its sample means have exactly

      .. math:: \sigma^2(\tau) = \frac{N^2}{\tau}\left[1 - \frac{T_f}{2\tau}
                \left(3 - 4e^{-\tau/T_f} + e^{-2\tau/T_f}\right)\right]
                \approx \frac{N^2}{\tau} - \frac{3N^2T_f}{2\tau^2}\quad(\tau \gg T_f),

      which a fit with a free quantization term reads as :math:`Q^2 < 0`.
      One-sided PSD :math:`2N^2/(1 + (f/f_c)^2)`.
    * ``one_pole``, ``butterworth`` (of ``order``, default 2), ``moving_average`` and
      ``bartlett`` (decimation filters; their length in samples :meth:`length`): digital
      filters on the white samples, with the exact discrete law of
      :func:`~allanite.terms.filter_laws.filter_avar`.

    Only the white noise is filtered here: flicker, rate random walk and the other terms of
    a model pass unchanged. That is exact to the filter's gain at their frequencies, which
    differs from 1 by less than :math:`(f/f_c)^2` (first order) where they matter, at
    taus far above :math:`1/f_c` (for B and K the error at :math:`\tau` is of order
    :math:`(2\pi f_c\tau)^{-2}`).
    """

    N: float
    bandwidth: float
    filter: str = "rc"
    order: float | None = None

    type: ClassVar[str] = "lowpass_white"
    symbol: ClassVar[str] = "N"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec(
            "N",
            rate=1,
            time=0.5,
            description="angle random walk before the filter",
            accel_description="velocity random walk before the filter",
        ),
        ParamSpec("bandwidth", rate=0, time=-1, description="-3 dB bandwidth in Hz"),
    )
    optional: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("order", rate=0, time=0, description="Butterworth filter order"),
    )
    settings: ClassVar[dict[str, tuple[str, ...]]] = {"filter": FILTER_KINDS}

    def __post_init__(self) -> None:
        check_parameters(self, positive=("bandwidth",))
        if self.filter not in FILTER_KINDS:
            raise ValueError(
                f"unknown filter {self.filter!r}; known filters: {', '.join(FILTER_KINDS)}"
            )
        if self.order is not None and (
            self.filter != "butterworth" or not 1 <= self.order <= 12 or self.order % 1
        ):
            raise ValueError(
                f"order is the order of a butterworth filter, a whole number 1..12; got "
                f"order={self.order!r} for filter={self.filter!r}"
            )

    @property
    def tau_f(self) -> float:
        """Filter time constant ``1 / (2 pi bandwidth)`` in seconds."""
        return 1.0 / (2.0 * math.pi * self.bandwidth)

    @property
    def n_order(self) -> int:
        """Butterworth order (2 unless given)."""
        return 2 if self.order is None else int(self.order)

    def length(self, dt: float) -> float | None:
        """Box length in samples of a ``moving_average`` or ``bartlett`` filter, else None."""
        if self.filter not in ("moving_average", "bartlett"):
            return None
        return box_length(self.filter, self.bandwidth, dt)

    def describe_filter(self, dt: float | None = None) -> str:
        """Name the filter and its bandwidth, e.g. ``butterworth order 4, -3 dB at 5 Hz``."""
        name = {"rc": "first-order (analog RC)", "one_pole": "first-order (digital)"}.get(
            self.filter, self.filter.replace("_", " ")
        )
        if self.filter == "butterworth":
            name += f" order {self.n_order}"
        text = f"{name} low-pass, -3 dB at {self.bandwidth:.4g} Hz"
        if dt is not None and self.filter in ("moving_average", "bartlett"):
            text += f" ({self.length(dt):.3g} samples)"
        return text

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact Allan variance of the sample means (see the class docstring)."""
        t, m, step = averaging_factor(tau, dt)
        if self.filter == "rc":
            return markov_avar_continuous(self.N**2 / (2.0 * self.tau_f), self.tau_f, t)
        return self.N**2 * filter_avar(self.filter, self.bandwidth, self.n_order, m, step)

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD ``2 N^2 |H(f)|^2`` of the continuous-time equivalent filter."""
        f = np.asarray(f, dtype=np.float64)
        return 2.0 * self.N**2 * filter_gain_analog(self.filter, self.bandwidth, self.n_order, f)

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact PSD of the samples (``rc``: :func:`markov_psd_sampled`, aliasing included)."""
        if self.filter == "rc":
            return markov_psd_sampled(self.N**2 / (2.0 * self.tau_f), self.tau_f, f, dt)
        f = np.asarray(f, dtype=np.float64)
        return 2.0 * self.N**2 * filter_gain(self.filter, self.bandwidth, self.n_order, f, dt)

    def stream(self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None) -> Any:
        """Exact samples: the ``rc`` means by the C++ recursion, digital filters by lfilter."""
        if self.filter == "rc":
            from allanite.simulation.gaussian import averaged_gauss_markov

            sigma = self.N / math.sqrt(2.0 * self.tau_f)
            return averaged_gauss_markov(sigma, self.tau_f, fs, n_channels, seed)
        from allanite.simulation.effects import FilteredWhiteStream

        taps, sos = filter_coefficients(self.filter, self.bandwidth, 1.0 / fs, self.n_order)
        return FilteredWhiteStream(self.N * math.sqrt(fs), taps, sos, fs, n_channels, seed)
