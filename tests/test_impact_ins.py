"""Navigation error laws: closed forms against Monte Carlo of the single-channel error models.

Each Monte Carlo draws ``n`` independent paths of the exactly discretised linear model; the
mean square of the zero-mean error at a fixed time then satisfies ``n * ms / sigma^2 ~ chi2(n)``,
which gives the acceptance interval (two-sided, probability ``P_REJECT`` of a false alarm).
Parameters are chosen so that the asymptotic error of each law is far below the Monte Carlo
uncertainty (checked deterministically against the exact covariance below).
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest
from scipy import stats

from allanite.impact import Earth, error_model, latitude_error_sigma
from allanite.impact.ins_errors import QUANTITIES, long_interval_sigma, short_interval_sigma
from allanite.impact.linear_model import discretize
from allanite.impact.sensor import Component

N_PATHS = 20_000
P_REJECT = 1e-4
EARTH = Earth()
WS = EARTH.schuler_frequency

GYRO = {
    "constant": Component("constant", 1e-6),
    "white": Component("white", 2e-6),
    "random_walk": Component("random_walk", 3e-8),
}
ACCEL = {
    "constant": Component("constant", 1e-3),
    "white": Component("white", 5e-4),
    "random_walk": Component("random_walk", 2e-6),
}


def _seed(*parts: str) -> int:
    """A fixed seed per case (str hash() is salted per process, crc32 is not)."""
    return zlib.crc32("/".join(parts).encode())


def _chi2_bounds(n: int) -> tuple[float, float]:
    return (
        stats.chi2.ppf(P_REJECT / 2, n) / n,
        stats.chi2.ppf(1 - P_REJECT / 2, n) / n,
    )


def _mc_ratio(model, t, seed):
    """Mean square of each output over the paths: dict name -> (len(t),)."""
    paths = model.sample(t, N_PATHS, np.random.default_rng(seed))
    return {name: np.mean(v**2, axis=0) for name, v in paths.items()}


def _assert_mc_matches(ms, law_sigma, what):
    lo, hi = _chi2_bounds(N_PATHS)
    ratio = ms / law_sigma**2
    assert np.all((ratio > lo) & (ratio < hi)), f"{what}: MC/law variance ratio {ratio}"


def _assert_mc_rejects(ms, law_sigma, what):
    lo, hi = _chi2_bounds(N_PATHS)
    ratio = ms / law_sigma**2
    assert np.all((ratio < lo) | (ratio > hi)), f"{what}: MC should reject, ratio {ratio}"


# --- short interval: free-inertial model, where the t^n laws are exact ---------------------
SHORT_T = np.array([5.0, 60.0, 300.0])
SHORT_CASES = [("gyro", kind, comp) for kind, comp in GYRO.items()] + [
    ("accel", kind, comp) for kind, comp in ACCEL.items()
]
# Gauss-Markov with t << tau_c: the law is the Wiener law with Q = 2 D mu (relative error of
# order t / tau_c = 3e-5 here)
SHORT_CASES += [
    ("gyro", "markov", Component("markov", 1e-5, 1e7)),
    ("accel", "markov", Component("markov", 1e-3, 1e7)),
]


@pytest.mark.parametrize(("sensor", "kind", "comp"), SHORT_CASES, ids=lambda v: str(v))
def test_short_interval_laws_match_monte_carlo(sensor, kind, comp):
    model = error_model(sensor, comp, EARTH, regime="free")
    ms = _mc_ratio(model, SHORT_T, seed=_seed(sensor, kind))
    for q in model.outputs:
        law = short_interval_sigma(sensor, q, comp, SHORT_T, EARTH)
        _assert_mc_matches(ms[q], law, f"{sensor} {kind} {q}")


def test_short_interval_stationary_markov_adds_the_random_constant():
    comp = Component("markov", 1e-5, 1e7)
    model = error_model("gyro", comp, EARTH, regime="free", markov_start="stationary")
    ms = _mc_ratio(model, SHORT_T, seed=11)
    for q in model.outputs:
        law = short_interval_sigma("gyro", q, comp, SHORT_T, EARTH, markov_start="stationary")
        _assert_mc_matches(ms[q], law, f"stationary markov {q}")
        # and the zero-start law is wrong for a stationary start
        _assert_mc_rejects(ms[q], short_interval_sigma("gyro", q, comp, SHORT_T, EARTH), q)


def test_tabulated_velocity_from_gyro_constant_is_twice_the_free_inertial_law():
    # the source tabulates g*dw*t^2; the free-inertial law is g*dw*t^2/2
    comp = GYRO["constant"]
    model = error_model("gyro", comp, EARTH, regime="free")
    ms = _mc_ratio(model, SHORT_T, seed=12)["velocity"]
    _assert_mc_matches(ms, EARTH.g * comp.value * SHORT_T**2 / 2, "derived")
    _assert_mc_rejects(ms, EARTH.g * comp.value * SHORT_T**2, "tabulated")


def test_quoted_source_laws_equal_the_implementation():
    # the laws quoted in the issue, written out independently
    t = np.array([10.0, 100.0])
    g, r = EARTH.g, EARTH.radius
    dw, n = GYRO["constant"].value, GYRO["white"].value
    np.testing.assert_allclose(
        short_interval_sigma("gyro", "position", GYRO["constant"], t, EARTH), g * dw * t**3 / 6
    )
    np.testing.assert_allclose(
        short_interval_sigma("gyro", "position", GYRO["white"], t, EARTH),
        g * n * t**2.5 / math.sqrt(20),
    )
    tl = np.array([1e5, 3e5])
    np.testing.assert_allclose(
        long_interval_sigma("gyro", "position", GYRO["constant"], tl, EARTH), r * dw * tl
    )
    np.testing.assert_allclose(
        long_interval_sigma("gyro", "position", GYRO["white"], tl, EARTH),
        r * n * np.sqrt(1.5 * tl),
    )
    np.testing.assert_allclose(
        long_interval_sigma("gyro", "vertical", GYRO["white"], tl, EARTH), n * np.sqrt(tl / 2)
    )
    np.testing.assert_allclose(
        long_interval_sigma("gyro", "azimuth", GYRO["white"], tl, EARTH), n * np.sqrt(tl)
    )


# --- long interval: Schuler loop ------------------------------------------------------------
LONG_T = np.array([2e5, 1e6])
LONG_CASES = [("gyro", k, c) for k, c in GYRO.items()] + [("accel", k, c) for k, c in ACCEL.items()]
# tau_c << 1/w_s (807 s): the tabulated S(0) forms hold
LONG_CASES += [
    ("gyro", "markov_fast", Component("markov", 1e-5, 30.0)),
    ("accel", "markov_fast", Component("markov", 1e-3, 30.0)),
    ("gyro", "markov_schuler", Component("markov", 1e-5, 1.0 / WS)),
    ("accel", "markov_schuler", Component("markov", 1e-3, 1.0 / WS)),
]


@pytest.mark.parametrize(("sensor", "kind", "comp"), LONG_CASES, ids=lambda v: str(v))
def test_long_interval_laws_match_monte_carlo(sensor, kind, comp):
    model = error_model(sensor, comp, EARTH, regime="schuler")
    ms = _mc_ratio(model, LONG_T, seed=_seed(sensor, kind, "long"))
    for q in model.outputs:
        law = long_interval_sigma(sensor, q, comp, LONG_T, EARTH)
        _assert_mc_matches(ms[q], law, f"{sensor} {kind} {q}")


def _tabulated_markov_long(sensor, quantity, comp, t):
    """The source's Gauss-Markov long-interval laws (white noise of intensity 2D/mu)."""
    d, mu = comp.value**2, 1.0 / comp.tau_c
    g, r = EARTH.g, EARTH.radius
    s = math.sqrt(2 * d * mu)
    return {
        ("gyro", "velocity"): g * s / (WS * mu) * np.sqrt(t / 2),
        ("gyro", "position"): r * math.sqrt(2 * d / mu) * np.sqrt(1.5 * t),
        ("accel", "velocity"): s / mu * np.sqrt(t / 2),
        ("accel", "position"): s / (WS * mu) * np.sqrt(t / 2),
    }[(sensor, quantity)]


@pytest.mark.parametrize("sensor", ["gyro", "accel"])
def test_tabulated_markov_long_laws_need_tau_c_far_below_the_schuler_time(sensor):
    fast = Component("markov", 1e-5 if sensor == "gyro" else 1e-3, 30.0)
    slow = Component("markov", fast.value, 1.0 / WS)
    for comp, holds in ((fast, True), (slow, False)):
        model = error_model(sensor, comp, EARTH, regime="schuler")
        ms = _mc_ratio(model, LONG_T, seed=21)
        for q in ("velocity", "position"):
            tab = _tabulated_markov_long(sensor, q, comp, LONG_T)
            if holds:
                _assert_mc_matches(ms[q], tab, f"tabulated {q} fast")
            else:
                _assert_mc_rejects(ms[q], tab, f"tabulated {q} at tau_c = 1/w_s")


# --- latitude error with the Earth-rate terms ----------------------------------------------
LAT_T = np.array([2e3, 2e4, 1e5, 4e5])


@pytest.mark.parametrize("kind", ["white", "constant"])
def test_latitude_error_with_earth_rate_matches_monte_carlo(kind):
    comp = GYRO[kind]
    model = error_model("gyro", comp, EARTH, regime="earth_rate")
    ms = _mc_ratio(model, LAT_T, seed=31)["latitude"]
    _assert_mc_matches(ms, latitude_error_sigma(comp, LAT_T, EARTH), kind)


def test_latitude_error_tabulated_sin_ut_term_is_a_typo():
    comp = GYRO["white"]
    ws, u = WS, EARTH.rate

    def bracket(t, last):
        return (
            t
            - np.sin((ws - u) * t) / (ws - u)
            + np.sin(2 * ws * t) / (4 * ws)
            - np.sin((ws + u) * t) / (ws + u)
            + last
        )

    t = np.array([10.0, 100.0, 1000.0])
    # as tabulated, sin(U t)/(4U): the "variance" is negative on the short interval
    assert np.all(bracket(t, np.sin(u * t) / (4 * u)) < 0)
    # with sin(2 U t)/(4U) (the integral of cos^2 U u) it equals the exact model
    sig = error_model("gyro", comp, EARTH, regime="earth_rate").sigma(t)["latitude"]
    fixed = EARTH.g * comp.value / (ws**2 - u**2) * np.sqrt(bracket(t, np.sin(2 * u * t) / (4 * u)))
    np.testing.assert_allclose(fixed, sig, rtol=1e-3)


def test_latitude_error_departs_from_the_schuler_law_once_earth_rate_matters():
    comp = GYRO["white"]
    model = error_model("gyro", comp, EARTH, regime="earth_rate")
    ms = _mc_ratio(model, LAT_T, seed=32)["latitude"]
    # the Schuler-only approximation R N sqrt(3t/2) fails once U t ~ 1 (t = 1e5, 4e5 s)
    schuler = EARTH.radius * comp.value * np.sqrt(1.5 * LAT_T)
    _assert_mc_rejects(ms[-2:], schuler[-2:], "Schuler-only law at U t > 1")


# --- exact covariance against the closed forms (deterministic) ------------------------------
def test_exact_covariance_equals_the_free_inertial_laws():
    t = np.array([0.5, 7.0, 90.0, 2000.0])
    for sensor, comps in (("gyro", GYRO), ("accel", ACCEL)):
        for comp in comps.values():
            sig = error_model(sensor, comp, EARTH, regime="free").sigma(t)
            for q, s in sig.items():
                law = short_interval_sigma(sensor, q, comp, t, EARTH)
                np.testing.assert_allclose(s, law, rtol=1e-8, err_msg=f"{sensor} {comp} {q}")


def test_exact_schuler_velocity_from_white_gyro_has_the_oscillating_term():
    # var dv = (g N / w_s)^2 (t/2 - sin(2 w_s t) / (4 w_s)), exact
    comp = GYRO["white"]
    t = np.array([100.0, 1234.0, 5000.0, 7e4])
    sig = error_model("gyro", comp, EARTH, regime="schuler").sigma(t)["velocity"]
    exact = EARTH.g * comp.value / WS * np.sqrt(t / 2 - np.sin(2 * WS * t) / (4 * WS))
    np.testing.assert_allclose(sig, exact, rtol=1e-8)


@pytest.mark.parametrize("sensor", ["gyro", "accel"])
def test_long_laws_are_the_asymptotes_of_the_exact_model(sensor):
    comps = dict(GYRO if sensor == "gyro" else ACCEL)
    comps["markov"] = Component("markov", 1e-5, 200.0)
    for comp in comps.values():
        model = error_model(sensor, comp, EARTH, regime="schuler")
        errs = []
        for t in (np.array([3e4, 3.3e4]), np.array([3e6, 3.3e6])):
            sig = model.sigma(t)
            errs.append(
                max(
                    np.max(np.abs(sig[q] / long_interval_sigma(sensor, q, comp, t, EARTH) - 1))
                    for q in sig
                )
            )
        # the relative error shrinks at least tenfold for 100 times longer t
        assert errs[1] < errs[0] / 10 or errs[1] < 1e-6, (comp, errs)
        assert errs[1] < 2e-3


def test_discretize_doubling_matches_direct_step():
    comp = Component("markov", 1e-5, 50.0)
    model = error_model("gyro", comp, EARTH, regime="schuler")
    phi, qd = discretize(model.f, model.qc, 3000.0)
    # composing 3000 one-second steps gives the same transition and noise
    p1, q1 = discretize(model.f, model.qc, 1.0)
    phi_n, q_n = np.eye(5), np.zeros((5, 5))
    for _ in range(3000):
        q_n = p1 @ q_n @ p1.T + q1
        phi_n = p1 @ phi_n
    np.testing.assert_allclose(phi, phi_n, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(qd, q_n, rtol=1e-7, atol=1e-30)


def test_every_quantity_has_a_law():
    t = np.array([10.0, 1e5])
    for sensor, quantities in QUANTITIES.items():
        for q in quantities:
            for comp in (GYRO if sensor == "gyro" else ACCEL).values():
                assert np.all(np.isfinite(short_interval_sigma(sensor, q, comp, t, EARTH)))
                if q != "latitude" or comp.kind in ("white", "constant"):
                    assert np.all(np.isfinite(long_interval_sigma(sensor, q, comp, t, EARTH)))


def test_bad_arguments_are_rejected():
    comp = GYRO["white"]
    with pytest.raises(ValueError, match="quantity"):
        short_interval_sigma("accel", "azimuth", comp, [1.0], EARTH)
    with pytest.raises(ValueError, match="sensor"):
        short_interval_sigma("baro", "position", comp, [1.0], EARTH)
    with pytest.raises(ValueError, match="times"):
        long_interval_sigma("gyro", "position", comp, [-1.0], EARTH)
    with pytest.raises(ValueError, match="markov_start"):
        error_model("gyro", comp, EARTH, markov_start="warm")
    with pytest.raises(ValueError, match="regime"):
        error_model("gyro", comp, EARTH, regime="orbit")
    with pytest.raises(ValueError, match="gyro only"):
        error_model("accel", comp, EARTH, regime="earth_rate")
    with pytest.raises(ValueError, match="increasing"):
        error_model("gyro", comp, EARTH).sigma([5.0, 1.0])
    with pytest.raises(ValueError, match="latitude"):
        Earth.at_latitude(95.0)


def test_earth_at_latitude():
    eq, pole = Earth.at_latitude(0.0), Earth.at_latitude(90.0)
    assert eq.g == pytest.approx(9.7803253359)
    assert pole.g == pytest.approx(9.8321849378, rel=1e-9)
    assert 5000 < Earth().schuler_period < 5100
