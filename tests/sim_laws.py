"""Independent implementations of simulators' IMU noise laws, written from their sources.

Used to validate :mod:`allanite.formats`: each function takes the simulator's own parameters
(as its config holds them, in its units) and returns rate samples of one axis exactly as the
simulator would add them to a zero true rate. They do not use allanite.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal


def _ar1(phi: float, drive: np.ndarray) -> np.ndarray:
    """x[k] = phi x[k-1] + drive[k], x[-1] = 0."""
    return signal.lfilter([1.0], [1.0, -phi], drive)


def gz_sensors(p: dict, n: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """gz-sensors GaussianNoiseModel + ImuSensor dynamic bias (src/GaussianNoiseModel.cc)."""
    dt = 1.0 / rate
    bias = rng.normal(p.get("bias_mean", 0.0), p.get("bias_stddev", 0.0))
    if rng.uniform() < 0.5:
        bias = -bias
    out = rng.normal(p.get("mean", 0.0), p["stddev"], n) + bias
    s_b, tc = p.get("dynamic_bias_stddev", 0.0), p.get("dynamic_bias_correlation_time", 0.0)
    if s_b > 0 and tc > 0:
        phi = math.exp(-dt / tc)
        out += _ar1(phi, s_b * math.sqrt(tc / 2.0 * (1.0 - phi**2)) * rng.standard_normal(n))
    prec = p.get("precision", 0.0)
    if prec > 0:
        out = np.round(out / prec) * prec
    return out


def px4_plugin(
    p: dict, n: int, rate: float, rng: np.random.Generator, sensor: str = "gyroscope"
) -> np.ndarray:
    """RotorS/PX4 gazebo_imu_plugin.cpp addNoise, one axis of ``sensor`` (or accelerometer)."""
    dt = 1.0 / rate
    tau = p[sensor + "BiasCorrelationTime"]
    sigma_g_d = 1.0 / math.sqrt(dt) * p[sensor + "NoiseDensity"]
    sigma_b_g = p[sensor + "RandomWalk"]
    sigma_b_g_d = math.sqrt(-sigma_b_g * sigma_b_g * tau / 2.0 * (math.exp(-2.0 * dt / tau) - 1.0))
    phi = math.exp(-1.0 / tau * dt)
    turn_on = p[sensor + "TurnOnBiasSigma"] * rng.standard_normal()
    bias = _ar1(phi, sigma_b_g_d * rng.standard_normal(n))  # updated before it is added
    return bias + sigma_g_d * rng.standard_normal(n) + turn_on


def airsim(p: dict, n: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """AirSim ImuSimple::addNoise, gyroscope (settings units: deg/sqrt(h), deg/h, s)."""
    arw = p["AngularRandomWalk"] / math.sqrt(3600.0) * math.pi / 180.0
    bias_stability = p["GyroBiasStability"] / 3600.0 * math.pi / 180.0
    norm = bias_stability / math.sqrt(p["GyroBiasStabilityTau"])
    sqrt_dt = math.sqrt(max(1.0 / rate, 1.0 / 1000.0))
    steps = norm * sqrt_dt * rng.standard_normal(n)
    bias = np.concatenate([[0.0], np.cumsum(steps)[:-1]])  # added, then updated
    return arw / sqrt_dt * rng.standard_normal(n) + bias


def kalibr(p: dict, n: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Kalibr IMU noise model (wiki): white density*sqrt(rate), bias walk rw/sqrt(rate).

    The same law as OpenVINS' simulator (Simulator.cpp: sigma/sqrt(dt), sigma_b*sqrt(dt)) and
    ORB-SLAM3's discretisation (Tracking.cc: Ng*sqrt(f), Ngw/sqrt(f)).
    """
    white = p["noise_density"] * math.sqrt(rate) * rng.standard_normal(n)
    walk = np.cumsum(p["random_walk"] / math.sqrt(rate) * rng.standard_normal(n))
    return white + walk


def gnss_ins_sim(p: dict, n: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """gnss-ins-sim gyro_gen + bias_drift (deg/h, deg/sqrt(h), s)."""
    d2r = math.pi / 180.0
    dt = 1.0 / rate
    arw = p["gyro_arw"] * d2r / 60.0
    drift = p["gyro_b_stability"] * d2r / 3600.0
    corr = p["gyro_b_corr"]
    if math.isinf(corr):
        bias = drift * rng.standard_normal(n)
    else:
        a = 1.0 - 1.0 / rate / corr
        b = drift * math.sqrt(1.0 - math.exp(-2.0 / (rate * corr)))
        noise = rng.standard_normal(n)
        bias = np.concatenate([[0.0], _ar1(a, b * noise[:-1])])
    return p["gyro_b"] * d2r / 3600.0 + bias + arw / math.sqrt(dt) * rng.standard_normal(n)


def kasdin_denominator(poles: int, alpha: float = 1.0) -> np.ndarray:
    """Kasdin (1995) eq. 116 AR coefficients of 1/f^alpha noise, as MATLAB's fractalcoef."""
    a = [1.0]
    for k in range(1, poles + 1):
        a.append(a[-1] * (k - 1 - alpha / 2.0) / k)
    return np.array(a)


def matlab_imu(p: dict, n: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """MATLAB imuSensor, one axis (fusion.internal.IMUSensorSimulator, R2023b+).

    ``p``: gyroparams fields NoiseDensity, BiasInstability, RandomWalk, ConstantBias,
    NoiseType ("double-sided" default), Numerator/Denominator (default fractalcoef: 1 and
    [1 -0.5]). Bandwidth fs/2 (double-sided) or fs; white std sqrt(bw)*ND; random-walk steps
    RW/sqrt(bw), summed from 0, added after the step; bias instability
    filter(num, den, BI*sqrt(2/(fs*Tc))*randn) with Tc = 2/fs, filter state from 0.
    """
    bw = rate / 2.0 if p.get("NoiseType", "double-sided") == "double-sided" else rate
    num = np.atleast_1d(p.get("Numerator", 1.0))
    den = np.atleast_1d(p.get("Denominator", [1.0, -0.5]))
    corr = 2.0 / rate
    draws = rng.standard_normal((n, 3))  # bias-instability, white, random-walk columns
    bias = signal.lfilter(
        num, den, p.get("BiasInstability", 0.0) * math.sqrt(2.0 / (rate * corr)) * draws[:, 0]
    )
    white = math.sqrt(bw) * p.get("NoiseDensity", 0.0) * draws[:, 1]
    walk = np.cumsum(p.get("RandomWalk", 0.0) / math.sqrt(bw) * draws[:, 2])
    return p.get("ConstantBias", 0.0) + bias + white + walk


def filtered_white_avar(num, den, m: np.ndarray) -> np.ndarray:
    """Exact Allan variance (sample units) of ``lfilter(num, den, unit white)`` at m samples.

    sigma^2(m) = int_0^{1/2} 2 |H(nu)|^2 * 2 sin^4(pi nu m) / (m sin(pi nu))^2 d nu, on a grid
    fine enough for the largest m (the stationary process; checked against the closed forms
    of white and Gauss-Markov noise in the tests).
    """
    m = np.atleast_1d(np.asarray(m, dtype=np.float64))
    lo = min(1e-4, 0.01 / float(np.max(m)))
    nu = np.concatenate([np.geomspace(lo * 1e-3, lo, 2000)[:-1], np.linspace(lo, 0.5, 2**18)])
    _, h = signal.freqz(num, den, worN=2.0 * np.pi * nu)
    spectrum = 2.0 * np.abs(h) ** 2
    out = np.empty(m.size)
    for i, mm in enumerate(m):
        kernel = 2.0 * np.sin(np.pi * nu * mm) ** 4 / (mm * np.sin(np.pi * nu)) ** 2
        out[i] = np.trapezoid(spectrum * kernel, nu)
    return out
