"""Bias against temperature: a polynomial fit with honest intervals, and the compensated record.

The rate of a record with a temperature channel (:attr:`allanite.io.Record.temperature`) is
modelled as

    y(t) = b_0 + sum_k c_k (T(t) - T_ref)^k [+ c_rate dT/dt] + noise,

``T_ref`` the mean temperature, ``k = 1 .. degree``. The fit works on ``n`` block means (a
few hundred blocks of equal length ``h``): averaging makes the regression cheap on records of
any length and turns white rate noise and quantisation into white noise of the block means.
The noise of the block means is modelled, not assumed independent: white noise plus a random
walk (rate random walk, and any slow wander the temperature does not explain), covariance

    Cov(e) = sigma^2 (I + lambda K),   K_ij = min(i, j),

which is exact for white + rate-random-walk noise (the block means of a random walk have
covariance ``h (min(i, j) - 1/2) - (h/6) I``: the constant goes into ``b_0``, the ``-h/6`` into
the white part). The coefficients are generalised least squares (GLS) with ``lambda``
estimated by restricted maximum likelihood (REML), so a drift the temperature does not
explain widens the intervals instead of being attributed to temperature; intervals are
Student-t with ``n - p`` degrees of freedom. ``K`` is diagonalised once per ``n``
(``K = V diag(mu) V'``), so every likelihood evaluation is a weighted least squares.

The degree (0 .. ``max_degree``, with the rate term when asked) is chosen by BIC on the
maximum likelihood (Schwarz 1978); the thermal sensitivity ``dy/dT`` at ``T_ref`` is reported
from a fit of degree at least 1, so a record whose bias does not depend on temperature still
gets an interval that covers 0. The noise terms are then fitted (by the caller) on the
compensated record ``y - sum_k c_k (T - T_ref)^k [- c_rate dT/dt]``, which keeps ``b_0``.

References: Harville (1977), "Maximum likelihood approaches to variance component estimation",
JASA 72; Schwarz (1978), "Estimating the dimension of a model", Ann. Stat. 6.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import optimize, stats

from allanite.confidence import DEFAULT_LEVEL
from allanite.fit.result import Coefficient
from allanite.io.record import Record
from allanite.terms.thermal import ThermalBias, temperature_rate
from allanite.units import convert, customary_gyro_rate, sensor_kind

__all__ = [
    "ThermalFit",
    "bias_blocks",
    "compensate_thermal",
    "fit_thermal",
    "sensitivity_unit",
]

#: default number of block means (a few hundred: cheap, and fine enough for thermal cycles)
N_BLOCKS = 400
#: highest degree tried by default (PX4's thermal calibration uses a cubic)
MAX_DEGREE = 3
#: log(lambda) search range: lambda from ~0 (white only) to a walk that dominates
_LOG_LAMBDA = (-30.0, 12.0)


@dataclass(frozen=True)
class ThermalFit:
    """The thermal bias of one channel: model, intervals, the degree choice and its noise.

    Attributes
    ----------
    channel : str
        Channel name.
    model : ThermalBias
        The chosen law (coefficients in the record's rate unit per °C^k).
    coefficients : tuple of Coefficient
        ``c_1 .. c_degree`` (and ``c_rate``) of the chosen law with standard errors.
    bias : Coefficient
        ``b_0``, the GLS intercept: the bias at the reference temperature when the noise has
        no random walk; with one, the walk's level at the start of the record (a random
        walk has no mean level), so read it with its interval.
    sensitivity : Coefficient
        ``dy/dT`` at the reference temperature (rate unit per °C), from a fit of degree at
        least 1 (so it exists, with an interval, when degree 0 is chosen).
    selection : tuple of (int, float)
        ``(degree, BIC)`` of every degree tried.
    sigma, walk : float
        Noise of the block means: white standard deviation and random-walk step
        (``sqrt(lambda) sigma``) per block, in the rate unit.
    block_s : float
        Length of the blocks in seconds; ``n_blocks`` their number.
    temperature_range : tuple of float
        Lowest and highest temperature of the record, °C.
    level : float
        Confidence level of the intervals.
    """

    channel: str
    model: ThermalBias
    coefficients: tuple[Coefficient, ...]
    bias: Coefficient
    sensitivity: Coefficient
    selection: tuple[tuple[int, float], ...]
    sigma: float
    walk: float
    block_s: float
    n_blocks: int
    temperature_range: tuple[float, float]
    level: float = DEFAULT_LEVEL

    @property
    def degree(self) -> int:
        """The chosen degree of the polynomial."""
        return self.model.degree

    @property
    def significant(self) -> bool:
        """Whether the sensitivity's interval at :attr:`level` excludes zero."""
        low, high = self.sensitivity.ci(self.level)
        return low > 0.0 or high < 0.0

    def display_scale(self) -> tuple[float, str]:
        """Factor and unit that show a bias in customary units (deg/h for a gyro, mg)."""
        rate = self.model.units
        shown = sensitivity_unit(rate).removesuffix("/°C")
        if rate is None or shown == rate:
            return 1.0, shown
        return convert(1.0, rate, shown), shown

    def customary_sensitivity(self) -> tuple[float, float, float, str]:
        """``(value, low, high, unit)`` of the sensitivity in deg/h/°C (gyro), mg/°C (accel)."""
        low, high = self.sensitivity.ci(self.level)
        scale, shown = self.display_scale()
        return self.sensitivity.value * scale, low * scale, high * scale, f"{shown}/°C"

    def lines(self) -> list[str]:
        """The thermal part as text: the law, the sensitivity with its interval, the method."""
        value, low, high, unit = self.customary_sensitivity()
        tried = ", ".join(f"{d}: {b:.1f}" for d, b in self.selection)
        verdict = (
            "significant"
            if self.significant
            else f"not significant: the interval covers 0 (degree {self.degree} chosen)"
        )
        out = [
            f"thermal bias vs temperature ({self.temperature_range[0]:.4g} to "
            f"{self.temperature_range[1]:.4g} °C, reference {self.model.reference:.4g} °C): "
            f"degree {self.degree} by BIC ({tried})",
            f"  sensitivity dB/dT = {value:.4g} {unit}  [{low:.4g}, {high:.4g}] "
            f"({100 * self.level:g} %), {verdict}",
        ]
        for c in self.coefficients:
            lo, hi = c.ci(self.level)
            out.append(f"  {c.name} = {c.value:.4g} {c.unit}  [{lo:.4g}, {hi:.4g}]")
        out.append(
            f"  (GLS on {self.n_blocks} block means of {self.block_s:.3g} s, white + "
            "random-walk noise by REML; the noise terms below are fitted on the compensated "
            "record)"
        )
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: the law, the sensitivity (record and customary units), the rest."""
        value, low, high, unit = self.customary_sensitivity()
        return {
            "channel": self.channel,
            "model": self.model.to_dict(),
            "degree": self.degree,
            "level": self.level,
            "sensitivity": {"value": value, "low": low, "high": high, "unit": unit},
            "significant": self.significant,
            "coefficients": [
                {"name": c.name, "value": c.value, "stderr": c.stderr, "unit": c.unit}
                for c in self.coefficients
            ],
            "intercept": {"value": self.bias.value, "stderr": self.bias.stderr},
            "selection": [{"degree": d, "bic": b} for d, b in self.selection],
            "noise": {"sigma": self.sigma, "walk": self.walk, "block_s": self.block_s},
            "n_blocks": self.n_blocks,
            "temperature_range": list(self.temperature_range),
        }


def sensitivity_unit(rate: str | None) -> str:
    """Customary unit of a thermal sensitivity: deg/h/°C for a gyro, mg/°C for an accelerometer."""
    if rate is None:
        return "(rate unit)/°C"
    try:
        kind = sensor_kind(rate)
    except ValueError:
        return f"{rate}/°C"
    if kind == "gyro":
        return f"{customary_gyro_rate(rate) or rate}/°C"
    if kind == "accelerometer":
        return "mg/°C"
    return f"{rate}/°C"


def _rates(record: Record) -> tuple[NDArray[np.float64], float]:
    """The samples as rates (increments times fs) and fs; angles are refused."""
    fs = record.require_fs()
    if record.input == "angle":
        raise ValueError(
            f"{record.source}: the thermal fit models the bias of a rate; the record holds "
            "angles: give increments or rates (input='increment' of the angle differences)"
        )
    samples = np.asarray(record.samples, dtype=np.float64)
    return (samples * fs if record.input == "increment" else samples), fs


@functools.lru_cache(maxsize=8)
def _walk_basis(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenvalues and eigenvectors of ``K_ij = min(i, j)``, ``i, j = 1 .. n``."""
    index = np.arange(1, n + 1, dtype=np.float64)
    mu, vectors = np.linalg.eigh(np.minimum.outer(index, index))
    return np.clip(mu, 0.0, None), vectors


@dataclass(frozen=True)
class _Solution:
    beta: NDArray[np.float64]
    covariance: NDArray[np.float64]
    sigma2: float
    lam: float
    neg2ll: float  # -2 log likelihood (ML), without the constant


def _wls(
    xt: NDArray[np.float64], yt: NDArray[np.float64], w: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], float, NDArray[np.float64]]:
    """Weighted least squares in the rotated basis: beta, (X'WX)^-1, weighted RSS."""
    a = xt.T @ (w[:, None] * xt)
    inverse = np.linalg.pinv(a)
    beta = inverse @ (xt.T @ (w * yt))
    resid = yt - xt @ beta
    return beta, inverse, float(np.sum(w * resid**2)), a


def _gls(x: NDArray[np.float64], y: NDArray[np.float64], *, reml: bool) -> _Solution:
    """GLS of ``y`` on ``x`` with covariance ``sigma^2 (I + lambda K)``, lambda by (RE)ML."""
    n, p = x.shape
    mu, vectors = _walk_basis(n)
    xt, yt = vectors.T @ x, vectors.T @ y

    def objective(theta: float) -> float:
        lam = math.exp(theta)
        w = 1.0 / (1.0 + lam * mu)
        _, _, rss, a = _wls(xt, yt, w)
        logdet = float(np.sum(np.log1p(lam * mu)))
        if not reml:
            return float(n * math.log(max(rss, 1e-300) / n) + logdet)
        _, logdet_a = np.linalg.slogdet(a)
        return float((n - p) * math.log(max(rss, 1e-300) / (n - p)) + logdet + float(logdet_a))

    grid = np.linspace(*_LOG_LAMBDA, 43)
    values = [objective(t) for t in grid]
    best = int(np.argmin(values))
    lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)]
    refined = optimize.minimize_scalar(objective, bounds=(lo, hi), method="bounded")
    theta = float(refined.x) if refined.fun < values[best] else float(grid[best])
    lam = math.exp(theta)
    w = 1.0 / (1.0 + lam * mu)
    beta, inverse, rss, _ = _wls(xt, yt, w)
    sigma2 = rss / (n - p if reml else n)
    neg2ll = n * math.log(max(rss, 1e-300) / n) + float(np.sum(np.log1p(lam * mu)))
    return _Solution(beta, sigma2 * inverse, sigma2, lam, neg2ll)


def _block_means(values: NDArray[np.float64], n_blocks: int, length: int) -> NDArray[np.float64]:
    shaped = values[: n_blocks * length].reshape(n_blocks, length, *values.shape[1:])
    return np.asarray(shaped.mean(axis=1), dtype=np.float64)


def _design(
    temperature: NDArray[np.float64],
    reference: float,
    scale: float,
    degree: int,
    lag: NDArray[np.float64] | None,
    n_blocks: int,
    length: int,
) -> NDArray[np.float64]:
    """Block means of 1, x, x^2, ... (x = (T - T_ref)/scale) and of the scaled rate term."""
    x = (temperature - reference) / scale
    columns = [np.ones(n_blocks)]
    columns += [_block_means(x**k, n_blocks, length) for k in range(1, degree + 1)]
    if lag is not None:
        columns.append(_block_means(lag, n_blocks, length))
    return np.column_stack(columns)


def _coefficient(name: str, value: float, stderr: float, unit: str, dof: int) -> Coefficient:
    def interval(level: float) -> tuple[float, float]:
        half = float(stats.t.ppf(0.5 + level / 2, dof)) * stderr
        return value - half, value + half

    return Coefficient(name, float(value), float(stderr), unit, interval)


def fit_thermal(
    record: Record,
    *,
    degree: int | None = None,
    max_degree: int = MAX_DEGREE,
    rate_term: bool = False,
    rate_smoothing: float = 60.0,
    n_blocks: int = N_BLOCKS,
    level: float = DEFAULT_LEVEL,
) -> tuple[ThermalFit, ...]:
    """Fit the bias of every channel of ``record`` against its temperature.

    Parameters
    ----------
    record : Record
        A rate or increment record with :attr:`~allanite.io.Record.temperature` (read with
        ``temperature=`` / ``--temperature``) and a sampling frequency.
    degree : int, optional
        Fix the polynomial degree (default: chosen by BIC from 0 to ``max_degree``).
    max_degree : int
        Highest degree tried (default 3).
    rate_term : bool
        Add ``c_rate dT/dt`` for thermal lag (the temperature is averaged over
        ``rate_smoothing`` seconds before its rate is taken).
    rate_smoothing : float
        Seconds of averaging before the temperature rate (default 60).
    n_blocks : int
        Number of block means the regression works on (default 400; fewer for short records:
        at least 20 are needed).
    level : float
        Confidence level of the intervals.

    Returns
    -------
    tuple of ThermalFit
        One per channel.

    Raises
    ------
    ValueError
        Without a temperature, with angles, with too few samples or blocks, or a temperature
        that does not vary.
    """
    if record.temperature is None:
        raise ValueError(
            f"{record.source}: the record has no temperature; read it with temperature= "
            "(CLI: --temperature NAME, the column, variable or topic of the temperature)"
        )
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    top = max_degree if degree is None else degree
    if top < 0 or top > 6:
        raise ValueError(f"the degree must lie between 0 and 6, got {top}")
    rates, fs = _rates(record)
    temperature = np.asarray(record.temperature, dtype=np.float64)
    n_blocks = min(n_blocks, record.n_samples)
    length = record.n_samples // n_blocks
    if n_blocks < 20:
        raise ValueError(
            f"{record.source}: {record.n_samples} samples are too few for a thermal fit "
            "(20 block means at least); use a longer record"
        )
    reference = float(np.mean(temperature[: n_blocks * length]))
    spread = float(np.max(np.abs(temperature - reference)))
    if spread < 1e-6:
        raise ValueError(
            f"{record.source}: the temperature does not vary ({reference:.4g} °C throughout); "
            "a thermal sensitivity needs a record over a range of temperatures"
        )
    lag, lag_scale = None, 1.0
    if rate_term:
        lag = temperature_rate(temperature, fs=fs, smooth_s=rate_smoothing)
        lag_scale = float(np.std(lag)) or 1.0
        lag = lag / lag_scale
    unit = record.rate_unit()
    setup = _Setup(
        temperature, reference, spread, lag, lag_scale, n_blocks, length, fs, unit, level
    )
    y = _block_means(rates, n_blocks, length)
    return tuple(
        _fit_channel(setup, y[:, c], name, degree, top, rate_smoothing)
        for c, name in enumerate(record.channels)
    )


@dataclass(frozen=True)
class _Setup:
    temperature: NDArray[np.float64]
    reference: float
    scale: float
    lag: NDArray[np.float64] | None
    lag_scale: float
    n_blocks: int
    length: int
    fs: float
    unit: str | None
    level: float

    def design(self, degree: int) -> NDArray[np.float64]:
        return _design(
            self.temperature,
            self.reference,
            self.scale,
            degree,
            self.lag,
            self.n_blocks,
            self.length,
        )


def _fit_channel(
    setup: _Setup,
    y: NDArray[np.float64],
    name: str,
    degree: int | None,
    top: int,
    rate_smoothing: float,
) -> ThermalFit:
    """One channel: BIC over the degrees, REML refit, coefficients back in °C units."""
    n = setup.n_blocks
    selection = []
    for d in range(0 if degree is None else degree, top + 1):
        ml = _gls(setup.design(d), y, reml=False)
        p = d + 1 + (setup.lag is not None) + 2  # coefficients, sigma^2, lambda
        selection.append((d, ml.neg2ll + p * math.log(n)))
    chosen = min(selection, key=lambda item: item[1])[0]
    fit = _gls(setup.design(chosen), y, reml=True)
    linear = fit if chosen >= 1 else _gls(setup.design(1), y, reml=True)
    rate = setup.unit or "(rate unit)"
    dof = n - fit.beta.size
    coefficients = []
    values = []
    for k in range(1, chosen + 1):
        factor = setup.scale**-k
        values.append(float(fit.beta[k]) * factor)
        se = math.sqrt(max(fit.covariance[k, k], 0.0)) * factor
        per = "°C" if k == 1 else f"°C^{k}"
        coefficients.append(_coefficient(f"c{k}", values[-1], se, f"{rate}/{per}", dof))
    rate_value = None
    if setup.lag is not None:
        rate_value = float(fit.beta[-1]) / setup.lag_scale
        se = math.sqrt(max(fit.covariance[-1, -1], 0.0)) / setup.lag_scale
        coefficients.append(_coefficient("c_rate", rate_value, se, f"{rate}/(°C/s)", dof))
    model = ThermalBias(
        tuple(values),
        setup.reference,
        setup.unit,
        rate_value,
        rate_smoothing if rate_value is not None else 0.0,
    )
    s1 = math.sqrt(max(linear.covariance[1, 1], 0.0)) / setup.scale
    sensitivity = _coefficient(
        "dy/dT", float(linear.beta[1]) / setup.scale, s1, f"{rate}/°C", n - linear.beta.size
    )
    b0 = _coefficient(
        "b0", float(fit.beta[0]), math.sqrt(max(fit.covariance[0, 0], 0.0)), rate, dof
    )
    return ThermalFit(
        channel=name,
        model=model,
        coefficients=tuple(coefficients),
        bias=b0,
        sensitivity=sensitivity,
        selection=tuple(selection),
        sigma=math.sqrt(fit.sigma2),
        walk=math.sqrt(fit.lam * fit.sigma2),
        block_s=setup.length / setup.fs,
        n_blocks=n,
        temperature_range=(float(np.min(setup.temperature)), float(np.max(setup.temperature))),
        level=setup.level,
    )


def compensate_thermal(record: Record, fits: tuple[ThermalFit, ...]) -> Record:
    """The record with each channel's thermal bias removed (its bias at ``T_ref`` kept).

    ``y_c - bias_c(T)`` for rates, ``(y_c - bias_c(T)) / fs`` subtracted for increments; the
    temperature stays attached. A note in :attr:`Record.warnings` says what was removed.
    """
    if record.temperature is None:
        raise ValueError(f"{record.source}: the record has no temperature to compensate")
    if len(fits) != record.n_channels:
        raise ValueError(f"{len(fits)} thermal fits for {record.n_channels} channels")
    fs = record.require_fs()
    samples = np.array(record.samples, dtype=np.float64)
    for c, fit in enumerate(fits):
        bias = fit.model.bias(record.temperature, fs=fs)
        samples[:, c] -= bias / fs if record.input == "increment" else bias
    removed = ", ".join(
        f"{f.channel} (degree {f.degree})" for f in fits if f.degree or f.model.rate
    )
    note = f"thermal bias removed before the noise fit: {removed}" if removed else None
    warnings = record.warnings if note is None else (*record.warnings, note)
    return dataclasses.replace(record, samples=samples, warnings=warnings)


def bias_blocks(
    record: Record, fit: ThermalFit, channel: int, *, compensated: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Block means of temperature and of the bias, as the fit saw them (for a plot).

    ``record`` is the record the fit was made on, or (``compensated=True``) that record after
    :func:`compensate_thermal`, whose thermal bias is added back.
    """
    if record.temperature is None:
        raise ValueError(f"{record.source}: the record has no temperature")
    rates, fs = _rates(record)
    y = rates[:, channel]
    if compensated:
        y = y + fit.model.bias(record.temperature, fs=fs)
    length = record.n_samples // fit.n_blocks
    return (
        _block_means(np.asarray(record.temperature, dtype=np.float64), fit.n_blocks, length),
        _block_means(y, fit.n_blocks, length),
    )
