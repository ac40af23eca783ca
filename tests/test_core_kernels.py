"""Compiled kernels against the numpy oracle (variance/oracle.py) on hypothesis-generated records.

Every kernel kind, every input kind, every accepted dtype, multi-channel records and strided
views (steps, negative strides, column slices, Fortran order, zero strides) must agree with the
textbook implementation to 1e-12 relative, and the thread count must not change a single bit.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import allanite
from allanite import _core
from allanite.variance import oracle

KINDS = ("overlapping", "standard", "modified", "hadamard", "standard_hadamard", "total")
INPUTS = ("rate", "increment", "angle")
DTYPES = (np.float64, np.float32, np.int16, np.int32, np.int64)
VIEWS = ("contiguous", "step2", "reversed", "reversed_step3", "column", "fortran", "channels_step")
RTOL = 1e-12


def _base(rng: np.random.Generator, n: int, c: int, dtype: type) -> np.ndarray:
    """A (n, c) record of the dtype: noise plus an offset per channel, integers on a grid.

    No drift here: a drift makes the Hadamard variances ill-conditioned (they cancel it), and
    then the naive oracle itself is only good to its own rounding; drifts and biases are tested
    against exact arithmetic in test_core_accuracy.py.
    """
    values = 40.0 * rng.standard_normal((n, c)) + rng.uniform(-200, 200, c)
    if np.issubdtype(dtype, np.integer):
        return np.round(values).astype(dtype)
    return values.astype(dtype)


def _view(rng: np.random.Generator, n: int, c: int, dtype: type, how: str) -> np.ndarray:
    """Record of shape (n, c) (or (n,) for c == 1 in some views) reached through a strided view."""
    if how == "contiguous":
        return _base(rng, n, c, dtype)
    if how == "step2":
        return _base(rng, 2 * n, c, dtype)[::2]
    if how == "reversed":
        return _base(rng, n, c, dtype)[::-1]
    if how == "reversed_step3":
        return _base(rng, 3 * n, c, dtype)[::-3]
    if how == "column":
        return _base(rng, n, c + 2, dtype)[:, 1 : 1 + c]
    if how == "fortran":
        return np.asfortranarray(_base(rng, n, c, dtype))
    if how == "channels_step":
        return _base(rng, n, 2 * c, dtype)[:, ::-2]
    raise AssertionError(how)


def _reference(x: np.ndarray, m: np.ndarray, kind: str, input_kind: str) -> np.ndarray:
    return np.asarray(oracle.variance(x, m, kind, input=input_kind)).reshape(m.size, -1)


def _factors(rng: np.random.Generator, kind: str, n_phase: int) -> np.ndarray:
    top = int(_core.max_m(kind, n_phase))
    picks = {1, top, max(1, top // 2)} | set(rng.integers(1, top + 1, 3).tolist())
    return np.array(sorted(picks), dtype=np.int64)


record = st.fixed_dictionaries(
    {
        "seed": st.integers(0, 2**32 - 1),
        "n": st.integers(9, 160),
        "c": st.integers(1, 3),
        "dtype": st.sampled_from(DTYPES),
        "view": st.sampled_from(VIEWS),
        "input": st.sampled_from(INPUTS),
    }
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rec=record)
def test_phase_matches_reference(rec: dict) -> None:
    rng = np.random.default_rng(rec["seed"])
    x = _view(rng, rec["n"], rec["c"], rec["dtype"], rec["view"])
    got = _core.phase(x, rec["input"])
    want = np.column_stack(
        [oracle.phase_from_record(x[:, j], rec["input"]) for j in range(x.shape[1])]
    )
    scale = np.max(np.abs(want), axis=0)
    assert got.shape == want.shape
    assert np.all(np.abs(got - want) <= 1e-12 * np.maximum(scale, 1e-300))


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rec=record, kind=st.sampled_from(KINDS))
@example(  # an integer record whose longest-tau variance is exactly zero
    rec={"seed": 3836539, "n": 46, "c": 3, "dtype": np.int16, "view": "column", "input": "rate"},
    kind="overlapping",
)
def test_variance_matches_reference(rec: dict, kind: str) -> None:
    rng = np.random.default_rng(rec["seed"])
    x = _view(rng, rec["n"], rec["c"], rec["dtype"], rec["view"])
    fs = 4.0
    phase = _core.phase(x, rec["input"])
    factors = _factors(rng, kind, phase.shape[0])
    res = allanite.avar(x, fs=fs, kind=kind, input=rec["input"], m=factors)
    scale = 1.0 if rec["input"] == "rate" else fs * fs
    want = _reference(x, factors, kind, rec["input"]) * scale
    # where the exact variance is 0 (integer records can cancel exactly) rounding leaves ~1e-33:
    # there the comparison is relative to the record's own variance instead
    floor = 1e-20 * scale * float(np.var(x.astype(np.float64)))
    np.testing.assert_allclose(res.var.reshape(want.shape), want, rtol=RTOL, atol=floor)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("dtype", DTYPES)
def test_every_dtype_every_kind_multichannel(kind: str, dtype: type) -> None:
    rng = np.random.default_rng(11)
    x = _base(rng, 301, 3, dtype)
    factors = np.arange(1, int(_core.max_m(kind, 302)) + 1, 7)
    res = allanite.avar(x, fs=1.0, kind=kind, m=factors)
    np.testing.assert_allclose(res.var, _reference(x, factors, kind, "rate"), rtol=RTOL)
    # a 1-D record gives the first channel, shaped (T,)
    one = allanite.avar(np.ascontiguousarray(x[:, 0]), fs=1.0, kind=kind, m=factors)
    assert one.var.shape == (factors.size,)
    np.testing.assert_array_equal(one.var, res.var[:, 0])


def test_zero_stride_broadcast_record() -> None:
    """np.broadcast_to gives a 0 channel stride: each channel is the same record."""
    rng = np.random.default_rng(5)
    col = rng.standard_normal(200)
    x = np.broadcast_to(col[:, None], (200, 3))
    res = allanite.avar(x, fs=1.0, kind="overlapping", taus="all")
    for j in range(3):
        np.testing.assert_array_equal(res.var[:, j], res.var[:, 0])
    np.testing.assert_allclose(res.var[:, 0], oracle.variance(col, res.m, "overlapping"), rtol=RTOL)


@pytest.mark.parametrize("kind", KINDS)
@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), c=st.integers(1, 4))
def test_thread_count_gives_bit_identical_results(kind: str, seed: int, c: int) -> None:
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((3000, c)) + 1e4
    phase = _core.phase(x, "rate")
    factors = np.unique(np.geomspace(1, _core.max_m(kind, phase.shape[0]), 40).astype(np.int64))
    results = [_core.variance(phase, factors, kind, t) for t in (1, 2, 3, 4)]
    for other in results[1:]:
        assert np.array_equal(results[0], other)
    default = allanite.avar(x, fs=1.0, kind=kind, m=factors)
    assert np.array_equal(default.var.reshape(results[0].shape), results[0])


def test_time_variance_is_tau_squared_mvar_over_three() -> None:
    rng = np.random.default_rng(3)
    x = rng.standard_normal(400)
    fs = 2.0
    mod = allanite.mdev(x, fs=fs, input="angle", taus="all")
    tim = allanite.tdev(x, fs=fs, input="angle", taus="all")
    np.testing.assert_allclose(tim.var, mod.tau**2 * mod.var / 3.0, rtol=1e-15)
    np.testing.assert_allclose(tim.dev, mod.tau * mod.dev / np.sqrt(3.0), rtol=1e-15)


def test_twins_select_their_kind() -> None:
    rng = np.random.default_rng(4)
    x = rng.standard_normal(300)
    pairs = {
        allanite.adev: "standard",
        allanite.oadev: "overlapping",
        allanite.mdev: "modified",
        allanite.hdev: "standard_hadamard",
        allanite.ohdev: "hadamard",
        allanite.totdev: "total",
    }
    for twin, kind in pairs.items():
        res = twin(x, fs=1.0, taus="octave")
        assert res.kind == kind
        np.testing.assert_allclose(res.var, oracle.variance(x, res.m, kind), rtol=RTOL)


def test_n_terms_match_the_definitions() -> None:
    big_m = 101
    for m in (1, 2, 7, 33):
        assert _core.n_terms("overlapping", big_m, m) == big_m - 2 * m
        assert _core.n_terms("standard", big_m, m) == (big_m - 1) // m - 1
        assert _core.n_terms("modified", big_m, m) == big_m - 3 * m + 1
        assert _core.n_terms("hadamard", big_m, m) == big_m - 3 * m
        assert _core.n_terms("standard_hadamard", big_m, m) == (big_m - 1) // m - 2
        assert _core.n_terms("total", big_m, m) == big_m - 2


def test_reference_definitions_on_a_hand_example() -> None:
    """Tiny example worked by hand: phase 0, 1, 4, 9, 16 (constant second difference 2)."""
    x = np.array([0.0, 1.0, 4.0, 9.0, 16.0])
    assert oracle.overlapping_variance(x, 1) == pytest.approx(4.0 / 2.0)
    assert oracle.overlapping_variance(x, 2) == pytest.approx(64.0 / (2 * 4))
    assert oracle.hadamard_variance(x, 1) == pytest.approx(0.0)
    assert oracle.modified_variance(x, 1) == pytest.approx(2.0)


@pytest.mark.parametrize("kind", ["modified", "total", "overlapping"])
def test_long_record_paths_match_reference_and_each_other(kind: str) -> None:
    """Every path of variances.hpp on a record longer than a tile (8192 terms).

    Factors up to 8192 share tiles (for ``modified`` through a window of prefix sums
    regenerated tile by tile), larger ones run alone (``modified``: four lanes of a running
    window started from exact prefix sums), ``total`` adds the reflected end terms. Channels:
    white noise on a 1e10 bias, and a rate random walk (large prefix sums). Each factor
    computed alone must give the bits it gets within the list, whatever the thread count.
    (Not Hadamard: a rate random walk makes it cancel a drift, and the naive oracle is then
    only good to its own rounding, see _base.)
    """
    rng = np.random.default_rng(2024)
    n = 26_000
    x = np.column_stack(
        [1e10 + rng.standard_normal(n), 5.0 + np.cumsum(rng.standard_normal(n)) * 0.01]
    )
    phase = _core.phase(x, "rate")
    top = int(_core.max_m(kind, phase.shape[0]))
    factors = np.array([m for m in (1, 3, 64, 1000, 4097, 8192, 8193, 8333, top) if m <= top])
    got = np.asarray(_core.variance(phase, factors, kind, 2))
    want = np.column_stack(
        [np.asarray(oracle.variance(x[:, c], factors, kind, input="rate")) for c in range(2)]
    )
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=0)
    assert np.array_equal(np.asarray(_core.variance(phase, factors, kind, 1)), got)
    alone = np.vstack(
        [
            np.asarray(_core.variance(phase, factors[i : i + 1], kind, 1))
            for i in range(factors.size)
        ]
    )
    assert np.array_equal(alone, got)


def test_hadamard_factors_side_by_side_match_reference_and_alone() -> None:
    """One channel of Hadamard factors on a record of several tiles (8192 terms): the factors
    of a tile run up to four side by side (their first taps share the loads) over the whole
    blocks they all have, the rest of a tile one by one. Threads 1, 2 and 3 split the factors
    into groups of 8, 4 + 4 and 3 + 3 + 2 (four, three and two side by side), the factors
    above 8192 in a four and a one; the last tiles end at different terms for each factor.
    White noise on a 1e10 bias: 1e-12 against the oracle, and every factor alone, whatever
    the thread count, gives the bits it gets in the list."""
    rng = np.random.default_rng(31)
    n = 40_000
    x = 1e10 + rng.standard_normal(n)
    phase = _core.phase(x.reshape(-1, 1), "rate")
    top = int(_core.max_m("hadamard", phase.shape[0]))
    factors = np.array([1, 2, 3, 5, 64, 1000, 3000, 8192, 8193, 9000, 10000, 12000, top])
    got = np.asarray(_core.variance(phase, factors, "hadamard", 1))
    want = np.asarray(oracle.variance(x, factors, "hadamard", input="rate")).reshape(got.shape)
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=0)
    for threads in (2, 3):
        assert np.array_equal(np.asarray(_core.variance(phase, factors, "hadamard", threads)), got)
    alone = np.vstack(
        [np.asarray(_core.variance(phase, factors[i : i + 1], "hadamard", 1)) for i in range(13)]
    )
    assert np.array_equal(alone, got)


@pytest.mark.parametrize(
    "n", [3, 1023, 1024, 1025, 3 * 1024 - 1, 4 * 1024 - 1, 4 * 1024, 5 * 1024 + 7]
)
def test_modified_prefix_plan_segment_edges(n: int) -> None:
    """The prefix sums' plan sums four segments of whole 1024-row blocks side by side and
    joins them: record lengths at block and segment edges (an empty or short last segment,
    a mark at row M) match the oracle on a 1e10 bias, every factor, one or two threads."""
    rng = np.random.default_rng(n)
    x = np.column_stack([1e10 + rng.standard_normal(n), np.cumsum(rng.standard_normal(n))])
    phase = _core.phase(x, "rate")
    top = int(_core.max_m("modified", phase.shape[0]))
    factors = np.unique(np.array([1, 2, top // 2, top]).clip(1, top))
    got = np.asarray(_core.variance(phase, factors, "modified", 2))
    want = np.column_stack(
        [np.asarray(oracle.variance(x[:, c], factors, "modified", input="rate")) for c in range(2)]
    )
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=0)
    assert np.array_equal(np.asarray(_core.variance(phase, factors, "modified", 1)), got)


@pytest.mark.parametrize("kind", ["overlapping", "hadamard", "total"])
def test_phase_blocks_match_reference_on_a_bias(kind: str) -> None:
    """The phase is built in blocks of PHASE_BLOCK samples (each restarted from its base, the
    blocks on threads, four of them side by side in one vector for a contiguous channel): on
    a record of several blocks and a partial one, white noise on a 1e10 bias and on none, the
    variances at factors that straddle block edges match the oracle, and the phase has the
    same bits for one, two or three threads and for a channel alone (contiguous: the vector
    path) or beside another (strided: one block after the other)."""
    block = int(_core.PHASE_BLOCK)
    n = 5 * block + 777
    rng = np.random.default_rng(77)
    x = np.column_stack([1e10 + rng.standard_normal(n), rng.standard_normal(n)])
    phase = _core.phase(x, "rate", threads=1)
    for threads in (2, 3):
        assert np.array_equal(_core.phase(x, "rate", threads=threads), phase)
    for c in range(2):
        alone = _core.phase(np.ascontiguousarray(x[:, [c]]), "rate", threads=2)
        assert np.array_equal(alone[:, 0], phase[:, c])
    factors = np.array([1, 7, block - 1, block, block + 3, n // 3 - 1])
    got = np.asarray(_core.variance(phase, factors, kind, 2))
    want = np.column_stack(
        [np.asarray(oracle.variance(x[:, c], factors, kind, input="rate")) for c in range(2)]
    )
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=0)
