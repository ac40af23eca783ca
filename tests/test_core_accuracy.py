"""Accuracy under a large bias or drift, against exact integer arithmetic on the stored data.

The records are built so that every stored sample minus its bias (rate) or every stored angle
is an exact multiple of a power of two; the second differences are then computed exactly in
int64 and their squares summed with math.fsum, which gives the overlapping Allan variance of
the very same float64 data to about one rounding. The compiled kernels must stay within 1e-12
relative of that, whatever the bias (a plain cumsum loses everything at b = 1e10).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import allanite

N = 1_000_000
GRID = 2.0**20  # every (y - b) and every angle is a multiple of 1/GRID
FACTORS = np.array([1, 3, 100, 10_000, 250_000], dtype=np.int64)


def _exact_avar_from_phase_ints(phase: np.ndarray, m: int) -> float:
    """sum (x[k+2m] - 2x[k+m] + x[k])^2 / (2 m^2 (M - 2m)) with integer phase x, exactly."""
    d2 = phase[2 * m :] - 2 * phase[m:-m] + phase[: -2 * m]
    assert np.max(np.abs(d2)) < 2**53  # exact as float64
    total = math.fsum((d2.astype(np.float64) ** 2).tolist())
    return total / (2.0 * m * m * d2.size)


@pytest.fixture(scope="module")
def white_ints() -> np.ndarray:
    rng = np.random.default_rng(20260101)
    return np.round(rng.standard_normal(N) * GRID).astype(np.int64)


@pytest.mark.parametrize("bias", [0.0, 1e3, 1e6, 1e8, 1e10])
def test_rate_with_large_bias_matches_exact_value(white_ints: np.ndarray, bias: float) -> None:
    y = bias + white_ints / GRID  # stored float64: y - bias is exact
    w = np.round((y - bias) * GRID).astype(np.int64)
    assert np.array_equal(w.astype(np.float64) / GRID, y - bias)
    # the phase of y is cumsum(y - mean); the mean cancels in every second difference exactly
    phase = np.concatenate(([0], np.cumsum(w)))
    exact = np.array([_exact_avar_from_phase_ints(phase, int(m)) for m in FACTORS]) / GRID**2
    res = allanite.avar(y, fs=1.0, kind="overlapping", m=FACTORS)
    rel = np.abs(res.var / exact - 1.0)
    assert rel.max() < 1e-12, f"bias {bias:g}: worst relative error {rel.max():.2e}"


ANGLE_GRID = 2.0**12  # angles on a 2^-12 grid: room for drifts up to 1e6 per sample


@pytest.mark.parametrize("drift", [1.0, 1e3, 1e6])
def test_angle_with_large_drift_matches_exact_value(drift: float) -> None:
    """theta[k] = 2^28 + drift k + unit noise, every stored angle a multiple of 2^-12."""
    rng = np.random.default_rng(7)
    noise = np.round(rng.standard_normal(N) * ANGLE_GRID).astype(np.int64)
    k = np.arange(N, dtype=np.int64)
    theta_ints = 2**40 + int(drift * ANGLE_GRID) * k + noise
    assert theta_ints.max() < 2**53  # theta * 2^12 exact in float64
    theta = theta_ints.astype(np.float64) / ANGLE_GRID
    assert np.array_equal(np.round(theta * ANGLE_GRID).astype(np.int64), theta_ints)
    exact = np.array([_exact_avar_from_phase_ints(theta_ints, int(m)) for m in FACTORS])
    exact /= ANGLE_GRID**2
    res = allanite.avar(theta, fs=1.0, input="angle", kind="overlapping", m=FACTORS)
    rel = np.abs(res.var / exact - 1.0)
    assert rel.max() < 1e-12, f"drift {drift:g}: worst relative error {rel.max():.2e}"


def _exact_variance(x: np.ndarray, m: int, kind: str) -> float:
    """Variance of every kind from an int64 phase, differences exact, squares summed by fsum."""
    big_m = x.size
    if kind in ("overlapping", "standard"):
        d = x[2 * m :] - 2 * x[m : big_m - m] + x[: big_m - 2 * m]
        if kind == "standard":
            d = d[::m][: (big_m - 1) // m - 1]
        den = 2.0 * m * m * d.size
    elif kind in ("hadamard", "standard_hadamard"):
        d = x[3 * m :] - 3 * x[2 * m : big_m - m] + 3 * x[m : big_m - 2 * m] - x[: big_m - 3 * m]
        if kind == "standard_hadamard":
            d = d[::m][: (big_m - 1) // m - 2]
        den = 6.0 * m * m * d.size
    elif kind == "modified":
        d2 = x[2 * m :] - 2 * x[m : big_m - m] + x[: big_m - 2 * m]
        prefix = np.concatenate(([0], np.cumsum(d2)))
        n = big_m - 3 * m + 1
        d = prefix[m : m + n] - prefix[:n]  # window sums of m second differences
        den = 2.0 * m**4 * n
    else:  # total: point reflection at both ends
        left = 2 * x[0] - x[big_m - 2 : 0 : -1]
        right = 2 * x[-1] - x[big_m - 2 : 0 : -1]
        ext = np.concatenate((left, x, right))
        i = np.arange(1, big_m - 1) + big_m - 2
        d = ext[i - m] - 2 * ext[i] + ext[i + m]
        den = 2.0 * m * m * (big_m - 2)
    assert np.max(np.abs(d)) < 2**53
    return math.fsum((d.astype(np.float64) ** 2).tolist()) / den


@pytest.mark.parametrize(
    "kind", ["overlapping", "standard", "modified", "hadamard", "standard_hadamard", "total"]
)
def test_every_kind_with_bias_matches_exact_value(white_ints: np.ndarray, kind: str) -> None:
    n, bias = 100_000, 1e10
    y = bias + white_ints[:n] / GRID
    w = np.round((y - bias) * GRID).astype(np.int64)
    phase = np.concatenate(([0], np.cumsum(w)))
    top = allanite.variance.taus.max_factor(kind, n + 1)
    factors = np.unique([1, 2, 7, 100, 1000, top // 3, top])
    exact = np.array([_exact_variance(phase, int(m), kind) for m in factors]) / GRID**2
    res = allanite.avar(y, fs=1.0, kind=kind, m=factors)  # type: ignore[arg-type]
    rel = np.abs(res.var / exact - 1.0)
    assert rel.max() < 1e-12, f"{kind}: worst relative error {rel.max():.2e}"


def test_plain_cumsum_would_fail_at_large_bias(white_ints: np.ndarray) -> None:
    """The test above is not vacuous: the naive estimator is far off at b = 1e10."""
    y = 1e10 + white_ints / GRID
    phase = np.concatenate(([0.0], np.cumsum(y)))
    d2 = phase[2:] - 2 * phase[1:-1] + phase[:-2]
    naive = np.mean(d2**2) / 2.0
    good = allanite.avar(y, fs=1.0, kind="overlapping", m=[1]).var[0]
    assert abs(naive / good - 1.0) > 1e-3
