r"""Strapdown INS error growth from sensor noise: single-channel models and their closed forms.

One horizontal channel of a strapdown INS, errors in SI units (rad, m/s, m):

.. math::

    \dot\phi = \delta v / R + \varepsilon_g, \quad \dot\psi = \varepsilon_g, \quad
    \delta\dot v = -g \phi + \varepsilon_a, \quad \delta\dot x = \delta v

with tilt (vertical) error :math:`\phi`, azimuth (heading) error :math:`\psi`, velocity error
:math:`\delta v`, position error :math:`\delta x`, gyro error :math:`\varepsilon_g` and
accelerometer error :math:`\varepsilon_a`. Without the :math:`\delta v / R` coupling the model
is *free-inertial* (the short-interval laws, t^n growth, exact for all t in that model); with it
the errors are *Schuler-bounded* (the long-interval laws, asymptotic for
:math:`\omega_s t \gg 1`). The latitude error with the Earth-rate terms uses the impulse
response :math:`h(u) = \omega_s^2 (\cos U u - \cos \omega_s u) / (\omega_s^2 - U^2)` from the
east-gyro error to the latitude error (transfer function
:math:`\omega_s^2 s / ((s^2 + U^2)(s^2 + \omega_s^2))`).

Each sensor error is one :class:`~allanite.impact.sensor.Component`: random constant, white
noise, Wiener process (random walk, intensity ``Q = K^2``) or first-order Gauss-Markov
(variance ``D = sigma^2``, ``mu = 1/tau_c``, driving intensity ``2 D mu``). The closed forms
below are those of the source's tables (Kuznetsov-style error budget; see docs/impact.md),
re-derived here; where a tabulated coefficient differs from the derivation, the derived one is
used and the difference is documented in docs/impact.md. :func:`error_model` builds the exact
linear model that the closed forms approximate; its covariance gives the exact curves and its
samples the Monte Carlo check.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.impact.earth import Earth
from allanite.impact.linear_model import LinearErrorModel
from allanite.impact.sensor import Component

__all__ = [
    "QUANTITIES",
    "error_model",
    "latitude_error_sigma",
    "long_interval_sigma",
    "short_interval_sigma",
]

Sensor = Literal["gyro", "accel"]
Regime = Literal["free", "schuler", "earth_rate"]
MarkovStart = Literal["zero", "stationary"]

#: quantities each sensor's error drives (latitude: gyro only, with Earth-rate terms)
QUANTITIES: dict[str, tuple[str, ...]] = {
    "gyro": ("vertical", "azimuth", "velocity", "position", "latitude"),
    "accel": ("velocity", "position"),
}
#: SI unit of each quantity
UNITS: dict[str, str] = {
    "vertical": "rad",
    "azimuth": "rad",
    "velocity": "m/s",
    "position": "m",
    "latitude": "m",
}

_NAV = {"vertical": 0, "azimuth": 1, "velocity": 2, "position": 3}


def _check_sensor_quantity(sensor: str, quantity: str) -> None:
    if sensor not in QUANTITIES:
        raise ValueError(f"sensor must be 'gyro' or 'accel', got {sensor!r}")
    if quantity not in QUANTITIES[sensor]:
        raise ValueError(
            f"quantity {quantity!r} is not driven by the {sensor} in these models; use one of "
            f"{QUANTITIES[sensor]}"
        )


def _check_start(markov_start: str) -> None:
    if markov_start not in ("zero", "stationary"):
        raise ValueError(f"markov_start must be 'zero' or 'stationary', got {markov_start!r}")


# --- exact linear models -------------------------------------------------------------------


def error_model(
    sensor: Sensor,
    component: Component,
    earth: Earth,
    *,
    regime: Regime = "schuler",
    markov_start: MarkovStart = "zero",
) -> LinearErrorModel:
    """Build the exact single-channel linear error model driven by one sensor error.

    Parameters
    ----------
    sensor : {"gyro", "accel"}
        Which sensor the error belongs to.
    component : Component
        The error source (random constant, white, random walk or Gauss-Markov).
    earth : Earth
        Gravity, radius and Earth rate.
    regime : {"free", "schuler", "earth_rate"}
        ``free``: free-inertial (no Schuler feedback); ``schuler``: Schuler loop;
        ``earth_rate``: latitude error with Schuler and Earth-rate terms (gyro only).
    markov_start : {"zero", "stationary"}
        Initial Gauss-Markov state: zero (as in the tabulated laws; e.g. removed by alignment)
        or drawn from its stationary distribution.

    Returns
    -------
    LinearErrorModel
        With outputs named as in :data:`QUANTITIES` (``latitude`` for ``earth_rate``, in m).
    """
    _check_start(markov_start)
    if sensor not in QUANTITIES:
        raise ValueError(f"sensor must be 'gyro' or 'accel', got {sensor!r}")
    g, r, u, ws = earth.g, earth.radius, earth.rate, earth.schuler_frequency
    if regime == "earth_rate":
        if sensor != "gyro":
            raise ValueError("the Earth-rate latitude model is driven by the gyro only")
        n_nav = 4
        f = np.zeros((n_nav + 1, n_nav + 1))
        f[0, 1] = 1.0
        f[1, 0] = -(u**2)
        f[2, 3] = 1.0
        f[3, 2] = -(ws**2)
        entry = np.array([0.0, 1.0, 0.0, 1.0])
        scale = r * ws**2 / (ws**2 - u**2)
        outputs = {"latitude": np.array([0.0, scale, 0.0, -scale, 0.0])}
    elif regime in ("free", "schuler"):
        n_nav = 4
        f = np.zeros((n_nav + 1, n_nav + 1))
        f[2, 0] = -g
        f[3, 2] = 1.0
        if regime == "schuler":
            f[0, 2] = 1.0 / r
        entry = np.array([1.0, 1.0, 0.0, 0.0]) if sensor == "gyro" else np.array([0, 0, 1.0, 0])
        names = QUANTITIES[sensor][:4] if sensor == "gyro" else QUANTITIES[sensor]
        outputs = {q: np.eye(n_nav + 1)[_NAV[q]] for q in names}
    else:
        raise ValueError(f"regime must be 'free', 'schuler' or 'earth_rate', got {regime!r}")

    b = n_nav  # index of the sensor-error state
    gmat = np.zeros((n_nav + 1, 1))
    p0 = np.zeros((n_nav + 1, n_nav + 1))
    kind, value = component.kind, component.value
    if kind == "white":
        gmat[:n_nav, 0] = entry * value
    else:
        f[:n_nav, b] = entry
        if kind == "constant":
            p0[b, b] = value**2
        elif kind == "random_walk":
            gmat[b, 0] = value
        elif kind == "markov":
            tau_c = float(component.tau_c or 0.0)
            f[b, b] = -1.0 / tau_c
            gmat[b, 0] = value * np.sqrt(2.0 / tau_c)
            if markov_start == "stationary":
                p0[b, b] = value**2
        else:
            raise ValueError(f"unknown component kind {kind!r}")
    return LinearErrorModel(f=f, g=gmat, p0=p0, outputs=outputs)


# --- closed forms ----------------------------------------------------------------------------

VarianceLaw = Callable[[NDArray[np.float64], float, float | None, Earth], NDArray[np.float64]]


def _times(t: ArrayLike) -> NDArray[np.float64]:
    arr = np.asarray(t, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError("times must be finite and >= 0 seconds")
    return arr


def _gm_intensity(sigma: float, tau_c: float | None) -> float:
    """Driving intensity ``2 D mu`` of a Gauss-Markov error (``D = sigma^2``, ``mu = 1/tau_c``)."""
    return 2.0 * sigma**2 / float(tau_c or 1.0)


def _gm_psd(sigma: float, tau_c: float | None, w: float) -> float:
    """Two-sided PSD ``2 D mu / (mu^2 + w^2)`` of a Gauss-Markov process at angular frequency w."""
    mu = 1.0 / float(tau_c or 1.0)
    return 2.0 * sigma**2 * mu / (mu**2 + w**2)


# free-inertial (short-interval) variance laws of the integrator chain: the k-fold integral of
# white noise of intensity q has variance q t^(2k-1) / ((k-1)!^2 (2k-1)); of a random constant
# c, c^2 t^(2k) / k!^2.
def _chain_white(q: float, t: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    coef = {1: 1.0, 2: 1.0 / 3.0, 3: 1.0 / 20.0, 4: 1.0 / 252.0}[k]
    return q * coef * t ** (2 * k - 1)


def _chain_constant(c: float, t: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    fact = {1: 1.0, 2: 2.0, 3: 6.0}[k]
    return (c * t**k / fact) ** 2


# integrator depth from the sensor error to each quantity (gain g for a gyro's velocity and
# position); a random walk adds one integration
_DEPTH = {
    ("gyro", "vertical"): (1, 1.0),
    ("gyro", "azimuth"): (1, 1.0),
    ("gyro", "velocity"): (2, 1.0),
    ("gyro", "position"): (3, 1.0),
    ("gyro", "latitude"): (3, 1.0),
    ("accel", "velocity"): (1, 1.0),
    ("accel", "position"): (2, 1.0),
}


def short_interval_sigma(
    sensor: Sensor,
    quantity: str,
    component: Component,
    t: ArrayLike,
    earth: Earth,
    *,
    markov_start: MarkovStart = "zero",
) -> NDArray[np.float64]:
    r"""Free-inertial (short-interval, :math:`\omega_s t \ll 1`) standard deviation.

    Gyro error -> attitude | velocity | position (g gravity):

    - random constant dw: ``dw t`` | ``g dw t^2 / 2`` | ``g dw t^3 / 6``
    - white (ARW N): ``N sqrt(t)`` | ``g N t^1.5 / sqrt(3)`` | ``g N t^2.5 / sqrt(20)``
    - Wiener (Q = K^2): ``sqrt(Q/3) t^1.5`` | ``g sqrt(Q/20) t^2.5`` | ``g sqrt(Q/252) t^3.5``
    - Gauss-Markov (t << tau_c, zero start): the Wiener law with ``Q = 2 D mu``

    Accelerometer error -> velocity | position:

    - constant dn: ``dn t`` | ``dn t^2 / 2``; white (VRW): ``VRW sqrt(t)`` | ``VRW t^1.5/sqrt(3)``
    - Wiener: ``sqrt(Q/3) t^1.5`` | ``sqrt(Q/20) t^2.5``; Gauss-Markov: Wiener with ``2 D mu``

    With ``markov_start="stationary"`` the Gauss-Markov law adds, in quadrature, the
    random-constant law with ``dw = sigma``. The latitude error on the short interval is the
    position law. Attitude is the same for the vertical and azimuth.

    Returns
    -------
    numpy.ndarray
        Standard deviation in rad, m/s or m, shaped like ``t``.
    """
    _check_sensor_quantity(sensor, quantity)
    _check_start(markov_start)
    tt = _times(t)
    k, _ = _DEPTH[(sensor, quantity)]
    gain = earth.g if (sensor == "gyro" and k > 1) else 1.0
    kind, value = component.kind, component.value
    if kind == "constant":
        var = _chain_constant(value, tt, k)
    elif kind == "white":
        var = _chain_white(value**2, tt, k)
    elif kind == "random_walk":
        var = _chain_white(value**2, tt, k + 1)
    elif kind == "markov":
        var = _chain_white(_gm_intensity(value, component.tau_c), tt, k + 1)
        if markov_start == "stationary":
            var = var + _chain_constant(value, tt, k)
    else:
        raise ValueError(f"unknown component kind {kind!r}")
    return np.asarray(gain * np.sqrt(var), dtype=np.float64)


def long_interval_sigma(
    sensor: Sensor,
    quantity: str,
    component: Component,
    t: ArrayLike,
    earth: Earth,
) -> NDArray[np.float64]:
    r"""Schuler-bounded (long-interval, :math:`\omega_s t \gg 1`, ``t >> tau_c``) sigma.

    Gyro error -> vertical | azimuth | velocity | position (:math:`\omega_s` Schuler frequency,
    R radius; ``S(w) = 2 D mu / (mu^2 + w^2)`` the two-sided PSD of a Gauss-Markov error):

    - constant dw: ``dw |sin w_s t| / w_s`` | ``dw t`` | ``(g dw / w_s^2)(1 - cos w_s t)`` |
      ``R dw t``
    - white N: ``N sqrt(t/2)`` | ``N sqrt(t)`` | ``(g N / w_s) sqrt(t/2)`` | ``R N sqrt(3t/2)``
    - Wiener Q: ``(sqrt(Q)/w_s) sqrt(t/2)`` | ``sqrt(Q/3) t^1.5`` |
      ``(g sqrt(Q)/w_s^2) sqrt(3t/2)`` | ``R sqrt(Q) sqrt(t^3/3)``
    - Gauss-Markov: ``sqrt(S(w_s) t/2)`` | ``sqrt(S(0) t)`` | ``(g/w_s) sqrt(S(w_s) t/2)`` |
      ``R sqrt((S(0) + S(w_s)/2) t)``; the tabulated forms put ``S(0) = 2 D / mu`` everywhere,
      which is the limit ``mu >> w_s`` (docs/impact.md).

    Accelerometer error -> velocity | position:

    - constant dn: ``dn |sin w_s t| / w_s`` | ``(dn R / g)(1 - cos w_s t)``
    - white VRW: ``VRW sqrt(t/2)`` | ``(VRW / w_s) sqrt(t/2)``
    - Wiener Q: ``(sqrt(Q)/w_s) sqrt(t/2)`` | ``(R sqrt(Q)/g) sqrt(3t/2)``
    - Gauss-Markov: ``sqrt(S(w_s) t/2)`` | ``(1/w_s) sqrt(S(w_s) t/2)``

    ``quantity="latitude"`` gives :func:`latitude_error_sigma`.

    Returns
    -------
    numpy.ndarray
        Standard deviation in rad, m/s or m, shaped like ``t``.
    """
    _check_sensor_quantity(sensor, quantity)
    if quantity == "latitude":
        return latitude_error_sigma(component, t, earth)
    tt = _times(t)
    g, r, ws = earth.g, earth.radius, earth.schuler_frequency
    kind, c = component.kind, component.value
    if kind == "markov":
        s0 = _gm_psd(c, component.tau_c, 0.0)
        sw = _gm_psd(c, component.tau_c, ws)
    elif kind == "white":
        s0 = sw = c**2
    key = (sensor, quantity)
    if kind == "constant":
        sig = {
            ("gyro", "vertical"): c * np.abs(np.sin(ws * tt)) / ws,
            ("gyro", "azimuth"): c * tt,
            ("gyro", "velocity"): g * c / ws**2 * (1.0 - np.cos(ws * tt)),
            ("gyro", "position"): r * c * tt,
            ("accel", "velocity"): c * np.abs(np.sin(ws * tt)) / ws,
            ("accel", "position"): c * r / g * (1.0 - np.cos(ws * tt)),
        }[key]
        return np.asarray(sig, dtype=np.float64)
    if kind == "random_walk":
        q = c**2
        var = {
            ("gyro", "vertical"): q / ws**2 * tt / 2.0,
            ("gyro", "azimuth"): q * tt**3 / 3.0,
            ("gyro", "velocity"): g**2 * q / ws**4 * 1.5 * tt,
            ("gyro", "position"): r**2 * q * tt**3 / 3.0,
            ("accel", "velocity"): q / ws**2 * tt / 2.0,
            ("accel", "position"): r**2 * q / g**2 * 1.5 * tt,
        }[key]
    elif kind in ("white", "markov"):
        var = {
            ("gyro", "vertical"): sw * tt / 2.0,
            ("gyro", "azimuth"): s0 * tt,
            ("gyro", "velocity"): g**2 / ws**2 * sw * tt / 2.0,
            ("gyro", "position"): r**2 * (s0 + sw / 2.0) * tt,
            ("accel", "velocity"): sw * tt / 2.0,
            ("accel", "position"): sw / ws**2 * tt / 2.0,
        }[key]
    else:
        raise ValueError(f"unknown component kind {kind!r}")
    return np.asarray(np.sqrt(var), dtype=np.float64)


def latitude_error_sigma(component: Component, t: ArrayLike, earth: Earth) -> NDArray[np.float64]:
    r"""Latitude (north position) error in m from an east-gyro error, with the Earth-rate terms.

    With the impulse response :math:`h(u) = k (\cos U u - \cos \omega_s u)`,
    :math:`k = \omega_s^2 / (\omega_s^2 - U^2)`, white gyro noise ``N`` gives

    .. math::

        \sigma_L(t) = \frac{g N}{\omega_s^2 - U^2} \Big[ t
            - \frac{\sin(\omega_s - U) t}{\omega_s - U}
            - \frac{\sin(\omega_s + U) t}{\omega_s + U}
            + \frac{\sin 2 \omega_s t}{4 \omega_s} + \frac{\sin 2 U t}{4 U} \Big]^{1/2}

    (in metres, ``R k = g / (w_s^2 - U^2)``). The source tabulates the last term as
    ``sin(U t) / (4 U)``, which makes the bracket negative for small t; ``sin(2 U t)/(4 U)``
    is the integral of :math:`\cos^2 U u` (docs/impact.md). For ``U t << 1`` this tends to the
    Schuler law ``R N sqrt(3t/2)``, for ``U t >> 1`` to ``g N sqrt(t) / (w_s^2 - U^2)``. A
    random constant ``dw`` gives ``R k dw |sin(U t)/U - sin(w_s t)/w_s|``. No closed form is
    given for the Wiener and Gauss-Markov errors (NaN; use the exact model).

    Returns
    -------
    numpy.ndarray
        Standard deviation in m, shaped like ``t``.
    """
    tt = _times(t)
    ws, u = earth.schuler_frequency, earth.rate
    k = ws**2 / (ws**2 - u**2)
    if component.kind == "white":
        bracket = (
            tt
            - np.sin((ws - u) * tt) / (ws - u)
            - np.sin((ws + u) * tt) / (ws + u)
            + np.sin(2.0 * ws * tt) / (4.0 * ws)
            + np.sin(2.0 * u * tt) / (4.0 * u)
        )
        return np.asarray(
            earth.g * component.value / (ws**2 - u**2) * np.sqrt(np.maximum(bracket, 0.0)),
            dtype=np.float64,
        )
    if component.kind == "constant":
        return np.asarray(
            earth.radius * k * component.value * np.abs(np.sin(u * tt) / u - np.sin(ws * tt) / ws),
            dtype=np.float64,
        )
    return np.full(tt.shape, np.nan)
