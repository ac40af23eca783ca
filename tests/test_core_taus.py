"""Tau grids: the original program's log grid, Stable32's octave/decade/all limits, explicit."""

from __future__ import annotations

import numpy as np
import pytest

import allanite
from allanite.variance import taus


def test_log_grid_is_the_original_programs() -> None:
    n, p = 100_000, 100
    want = np.unique(np.ceil(np.logspace(0, np.log10(2 ** np.floor(np.log2(n / 2))), p)))
    np.testing.assert_array_equal(taus.log_grid(n, p), want.astype(np.int64))


@pytest.mark.parametrize("n", [1000, 1024, 4097, 10**7])
def test_log_grid_never_passes_its_top(n: int) -> None:
    grid = taus.log_grid(n, 100)
    assert grid[0] == 1
    assert grid[-1] == 2 ** int(np.floor(np.log2(n / 2)))
    assert np.all(np.diff(grid) > 0)


@pytest.mark.parametrize(
    ("kind", "ratio"),
    [
        ("standard", 5),
        ("overlapping", 4),
        ("modified", 4),
        ("time", 4),
        ("standard_hadamard", 5),
        ("hadamard", 4),
        ("total", 2),
    ],
)
def test_named_grids_stop_where_stable32_stops(kind: str, ratio: int) -> None:
    n = 19_982  # the OCXO record of the Stable32 reference tables
    x = np.random.default_rng(0).standard_normal(n)
    octave = allanite.avar(x, fs=1.0, kind=kind, taus="octave").m  # type: ignore[arg-type]
    assert octave[-1] == 2 ** int(np.floor(np.log2(n // ratio)))
    decade = allanite.avar(x, fs=1.0, kind=kind, taus="decade").m  # type: ignore[arg-type]
    assert decade.tolist() == [
        d for d in (1, 2, 4, 10, 20, 40, 100, 200, 400, 1000, 2000, 4000, 10000) if d <= n // ratio
    ]


def test_all_grid_is_every_factor_to_the_stop() -> None:
    x = np.random.default_rng(1).standard_normal(101)
    res = allanite.avar(x, fs=1.0, kind="overlapping", taus="all")
    np.testing.assert_array_equal(res.m, np.arange(1, 101 // 4 + 1))


def test_explicit_taus_round_to_whole_samples_and_may_reach_the_kernel_limit() -> None:
    x = np.random.default_rng(2).standard_normal(1000)
    res = allanite.avar(x, fs=100.0, taus=[0.01, 0.0149, 0.5, 5.0])
    np.testing.assert_array_equal(res.m, [1, 50, 500])
    np.testing.assert_allclose(res.tau, [0.01, 0.5, 5.0])
    assert taus.max_factor("overlapping", 1001) == 500


def test_default_is_the_log_grid() -> None:
    x = np.random.default_rng(3).standard_normal(5000)
    res = allanite.avar(x, fs=1.0, points=50)
    np.testing.assert_array_equal(res.m, taus.log_grid(5000, 50))
    with pytest.raises(ValueError, match="points"):
        allanite.avar(x, fs=1.0, points=1)


def test_all_grid_on_a_long_record_is_refused_with_its_cost() -> None:
    """``taus="all"`` on 2e6 samples is 4e5 passes over the record (hours): refused before
    anything is computed, with the cost and the fix (#31); shorter records keep it."""
    n = 2_000_000
    with pytest.raises(ValueError, match=r"taus 'all' gives 500,000 averaging times") as info:
        taus.averaging_factors("all", fs=1.0, n_samples=n, n_phase=n + 1, kind="overlapping")
    assert "--points" in str(info.value)
    assert "1.0e+12" in str(info.value)
    n_ok = int(np.sqrt(4 * taus.ALL_COST_LIMIT))  # n * n/4 at the cap: still allowed
    factors = taus.averaging_factors(
        "all", fs=1.0, n_samples=n_ok, n_phase=n_ok + 1, kind="overlapping"
    )
    assert factors.size == n_ok // 4
