"""Bounded cost of the per-candidate re-tests: the fits of one diagnosis share their work.

* the low-frequency kurtosis re-test of a Gauss-Markov candidate runs its Monte Carlo once
  per rounded correlation time (every fit finds a new ``tau_c``; nearby ones share a run);
* a drifting line's Gauss-Legendre nodes are computed once per order, not at every Allan
  variance of its fit.
"""

from __future__ import annotations

import numpy as np
import pytest

from allanite.diagnosis import time_view
from allanite.diagnosis.time_view import (
    SHAPE_STEPS_PER_OCTAVE,
    _block_kurtosis_mc,
    _rounded_shape,
    added_block_kurtosis,
)
from allanite.terms import TERM_TYPES

FS = 100.0
N = 2**15
WINDOWS = 32
BLOCKS = (8, 64, 256)


def _markov(tau_c: float, sigma: float = 0.1):  # type: ignore[no-untyped-def]
    return TERM_TYPES["markov"](sigma=sigma, tau_c=tau_c)


def test_nearby_correlation_times_share_one_monte_carlo(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(time_view, "_BLOCK_CACHE", {})
    runs = []
    real_mc = time_view._block_kurtosis_mc

    def counted(*args):  # type: ignore[no-untyped-def]
        runs.append(args[0])
        return real_mc(*args)

    monkeypatch.setattr(time_view, "_block_kurtosis_mc", counted)
    half_step = 2.0 ** (0.5 / SHAPE_STEPS_PER_OCTAVE)
    first = added_block_kurtosis(_markov(2.0), FS, N, WINDOWS, BLOCKS)
    # within the same grid cell, at another amplitude: no new run, the variance scales
    again = added_block_kurtosis(_markov(2.0 * half_step**0.8, 0.3), FS, N, WINDOWS, BLOCKS)
    assert len(runs) == 1
    np.testing.assert_allclose(again[0], first[0] * 9.0)
    np.testing.assert_array_equal(again[1], first[1])
    # a correlation time an octave away is a new shape
    added_block_kurtosis(_markov(4.0), FS, N, WINDOWS, BLOCKS)
    assert len(runs) == 2


def test_rounding_the_correlation_time_moves_the_kurtosis_far_less_than_its_spread() -> None:
    """The worst rounding (half a grid step, 2.2 %) against the exact tau_c's Monte Carlo
    (same seed): the kurtosis moves by less than a tenth of its spread across records."""
    tau_c = 3.0 * 2.0 ** (0.499 / SHAPE_STEPS_PER_OCTAVE)  # a rounding of ~half a step
    rounded = _rounded_shape(_markov(tau_c))["tau_c"]
    assert abs(np.log2(rounded / tau_c)) <= 0.5 / SHAPE_STEPS_PER_OCTAVE + 1e-12
    exact = _block_kurtosis_mc(_markov(tau_c, 1.0), FS, N, WINDOWS, BLOCKS, 32, 7)
    shifted = _block_kurtosis_mc(_markov(rounded, 1.0), FS, N, WINDOWS, BLOCKS, 32, 7)
    assert np.all(np.abs(shifted[1] - exact[1]) < 0.1 * exact[2])


def test_amplitude_and_record_length_are_never_rounded() -> None:
    line = TERM_TYPES["drifting_line"](amplitude=0.3, f_start=5.0, f_end=6.5, duration=123.4)
    shape = _rounded_shape(line)
    assert "amplitude" not in shape
    assert "duration" not in shape
    assert set(shape) == {"f_start", "f_end"}
    assert _rounded_shape(TERM_TYPES["rrw"](K=1e-3)) == {}


def test_drifting_line_nodes_are_computed_once_per_order() -> None:
    from allanite.terms import drifting_line

    drifting_line._gauss_legendre.cache_clear()
    line = TERM_TYPES["drifting_line"](amplitude=0.3, f_start=5.0, f_end=6.5, duration=600.0)
    tau = np.geomspace(0.01, 50.0, 20)
    first = line.avar(tau, 0.01)
    second = line.with_values(amplitude=0.6).avar(tau, 0.01)
    info = drifting_line._gauss_legendre.cache_info()
    assert info.misses == 1
    assert info.hits == 1
    np.testing.assert_allclose(second, 4.0 * first, rtol=1e-12)
    # the nodes are shared, so they must not be writable
    x, _ = drifting_line._gauss_legendre(64)
    with pytest.raises(ValueError, match="read-only"):
        x[0] = 0.0
