"""The output resolution of quantized records and the held-sample check built on it.

Every record here comes from a generator written in the test (numpy only): a 1 Hz logger
that differences a float angle (its 0.532 mrad/s counts carry 1e-15 rounding), ring-laser
pulse increments (a quantized random walk; independent draws at 13/66/21 %), a dithered pulse
counter; and the same records with samples held by the logger.
"""

from __future__ import annotations

import numpy as np
import pytest

from allanite.diagnosis.resolution import HELD_FLOOR, held_excess, output_resolution
from allanite.diagnosis.time_base import held_samples_item

LEVEL = 0.005
Q_LOGGER = 0.532e-3


def _logger(seed: int, n: int = 40_000) -> np.ndarray:
    """1 Hz rate counts of 0.532 mrad/s, written as differences of an accumulated float angle."""
    rng = np.random.default_rng(seed)
    rate = 1.5e-3 * rng.standard_normal(n) + np.cumsum(2e-6 * rng.standard_normal(n)) + 7.29e-5
    return np.diff(1.0 + np.cumsum(np.rint(rate / Q_LOGGER) * Q_LOGGER))


def _ring_laser(seed: int, n: int = 100_000) -> np.ndarray:
    """Pulse increments (2 urad per pulse) of a quantized angle random walk: -1/0/+1 pulses."""
    rng = np.random.default_rng(seed)
    theta = np.cumsum(0.08 + 0.52 * rng.standard_normal(n + 1))
    return np.diff(np.floor(theta) * 2e-6)  # the angle in pulses times the scale


def _draws(seed: int, n: int = 100_000) -> np.ndarray:
    """Independent pulse increments at 13/66/21 %, differenced from the angle in pulses."""
    rng = np.random.default_rng(seed)
    pulses = rng.choice([-1.0, 0.0, 1.0], size=n + 1, p=[0.13, 0.66, 0.21])
    return np.diff(np.cumsum(pulses) * 2e-6)


def _dithered(seed: int, n: int = 100_000) -> np.ndarray:
    """A pulse counter read at 100 Hz with a 3-pulse, 412.37 Hz dither left in the angle."""
    rng = np.random.default_rng(seed)
    k = np.arange(n + 1)
    theta = np.cumsum(0.3 + 0.4 * rng.standard_normal(n + 1))
    theta += 3.0 * np.sin(2.0 * np.pi * 412.37 * k / 100.0)
    return np.diff(np.floor(theta) * 1.5e-6)


def _hold(x: np.ndarray, share: float, seed: int = 99) -> np.ndarray:
    """The logger repeats the previous value for ``share`` of the samples (runs allowed)."""
    rng = np.random.default_rng(seed)
    y = x.copy()
    for k in np.flatnonzero(rng.random(x.size) < share):
        if k > 0:
            y[k] = y[k - 1]
    return y


GENERATORS = {"logger": _logger, "ring laser": _ring_laser, "draws": _draws,
              "dithered": _dithered}  # fmt: skip
STEP = {"logger": Q_LOGGER, "ring laser": 2e-6, "draws": 2e-6, "dithered": 1.5e-6}


@pytest.mark.parametrize("name", sorted(GENERATORS))
def test_the_resolution_is_found_through_float_rounding(name):
    x = GENERATORS[name](1)
    assert np.any((np.abs(np.diff(x)) > 0) & (np.abs(np.diff(x)) < 1e-12))  # rounding noise
    q = output_resolution(x)
    assert q == pytest.approx(STEP[name], rel=1e-6)


def test_continuous_samples_have_no_resolution():
    x = np.random.default_rng(3).standard_normal(10_000)
    assert output_resolution(x) is None
    assert output_resolution(np.cumsum(x) + 1e3) is None


def test_the_issues_cases_raise_no_held_alarm():
    # before: the 1 Hz logger read "3469 held samples, 109 expected, p = 3e-168", the ring
    # laser "38 % held, 0.5 expected", the independent draws "50 % held, 0.5 expected" (the
    # float rounding of the differenced angle taken for the resolution)
    for name, gen in GENERATORS.items():
        for seed in (1, 2, 3):
            x = gen(seed)
            assert held_samples_item(x, 1.0, LEVEL) is None, (name, seed)


def test_independent_pulses_repeat_as_their_levels_say():
    x = _draws(4)
    test = held_excess(x, 2e-6)
    # independent draws repeat with probability 0.13^2 + 0.66^2 + 0.21^2 = 0.4966; the
    # expected count is the levels' own estimate, within its binomial uncertainty
    m = x.size - 1
    p = 0.13**2 + 0.66**2 + 0.21**2
    assert abs(test.expected - m * p) < 4.0 * np.sqrt(m * p * (1 - p))
    assert abs(test.held_share) < HELD_FLOOR


@pytest.mark.parametrize("name", ["logger", "draws"])
def test_held_samples_of_a_quantized_logger_are_found(name):
    x = _hold(GENERATORS[name](5), 0.05)
    item = held_samples_item(x, 1.0, LEVEL)
    assert item is not None
    assert item.evidence == "held"
    assert item.size["resolution"] == pytest.approx(STEP[name], rel=1e-6)
    assert item.size["count"] > item.size["expected"]


@pytest.mark.parametrize("name", ["ring laser", "dithered"])
def test_held_pulse_increments_are_found(name):
    # increments of a counter are anticorrelated (fewer repeats than independent draws), so
    # the independent-levels law is conservative there: a logger holding 15 % is found
    x = _hold(GENERATORS[name](6), 0.15)
    item = held_samples_item(x, 100.0, LEVEL)
    assert item is not None
    assert item.evidence == "held"


def test_the_adis16405_counts_raise_no_held_alarm(shared_data):
    z = np.load(shared_data / "imu" / "adis16405" / "run1.npz")
    for key, lsb in (("gyro_counts", 0.05), ("accel_counts", 0.00333)):
        for c in range(3):
            x = z[key][:, c] * lsb
            for half in (x[: x.size // 2], x[x.size // 2 :]):
                assert output_resolution(half) == pytest.approx(lsb, rel=1e-9)
                assert held_samples_item(half, 100.0, LEVEL) is None, (key, c)
