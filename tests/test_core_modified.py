"""The modified Allan variance kernel at its worst case, against exact rational arithmetic.

The kernel moves a running window w(j+1) = w(j) + d3(j) along the terms, in lanes restarted
from the exact prefix sums of the phase (every 256 or 1024 terms for factors up to 8192, at
most every 64 Ki terms beyond); the steps d3 round relative to the phase's lag-m differences,
not to the phase. The worst case for that drift is a long record on a large bias whose phase
wanders far from zero (white rate noise plus a rate random walk: |phase| ~ 1e6 while a step at
m = 1 is ~1) and factors from 1 to M/3. The reference is the definition evaluated exactly on
the very float64 phase the kernel reads (every double is an integer times a power of two:
prefix sums and windows in Python integers, the sum of squares as a fraction).
"""

from __future__ import annotations

from fractions import Fraction
from itertools import accumulate

import numpy as np
import pytest

from allanite import _core

N = 300_000


def _exact_modified(x: np.ndarray, m: int) -> float:
    """sum_j (S[j+3m] - 3 S[j+2m] + 3 S[j+m] - S[j])^2 / (2 m^4 (M - 3m + 1)), S the prefix
    sums of x, in exact arithmetic, rounded once."""
    scale = int(np.max(53 - np.frexp(x[x != 0])[1]))  # x * 2^scale are integers
    s = [0, *accumulate(int(v) for v in np.ldexp(x, scale).tolist())]
    n = x.size - 3 * m + 1
    total = 0
    for j in range(n):
        w = s[j + 3 * m] - 3 * s[j + 2 * m] + 3 * s[j + m] - s[j]
        total += w * w
    return float(Fraction(total, 2 * m**4 * n * 4**scale))


@pytest.fixture(scope="module")
def rates() -> np.ndarray:
    """Two channels: white rate noise plus a rate random walk on biases of +-1e10."""
    rng = np.random.default_rng(20261125)
    walk = np.cumsum(rng.standard_normal((N, 2)), axis=0) * 0.1
    return np.array([1e10, -3e9]) + rng.standard_normal((N, 2)) + walk


# up to 8192: the tiled pass, lanes of 1024 terms (100, 1000, 5752) or of 256 (the others, whose
# taps fall near each other modulo 512 rows); beyond, one factor at a time: 40_000, 50_000,
# 65_000 with lanes spread m, m / 2 and m / 3 apart (whole groups of 4 m, 2 m and 4 m / 3 terms,
# then neighbouring lanes for the rest), 8193 and 70_000 with neighbouring lanes only
TILED = [1, 2, 3, 100, 255, 256, 257, 1000, 1023, 1024, 1025, 5752, 8192]
FACTORS = [*TILED, 8193, 40_000, 50_000, 65_000, 70_000, (N + 1) // 3]


def test_modified_long_wandering_record_matches_exact_value(rates: np.ndarray) -> None:
    phase = np.asarray(_core.phase(np.ascontiguousarray(rates[:, :1]), "rate"))
    assert np.abs(phase).max() > 1e5  # the phase is far from zero: steps cancel
    got = np.asarray(_core.variance(phase, FACTORS, "modified", 2))[:, 0]
    exact = np.array([_exact_modified(phase[:, 0], m) for m in FACTORS])
    rel = np.abs(got / exact - 1.0)
    assert rel.max() < 1e-12, f"worst relative error {rel.max():.2e} at m = {FACTORS[rel.argmax()]}"


def test_modified_spread_lanes_over_two_passes_match_exact_value() -> None:
    """A factor beyond 64 Ki whose lanes are spread m apart covers each lane's m terms in two
    passes (64 Ki terms, then the rest), each started from the prefix sums; the record is
    the same hard case, long enough for one whole group of 4 m terms and a tail."""
    rng = np.random.default_rng(20261126)
    n = 470_000
    walk = np.cumsum(rng.standard_normal(n)) * 0.1
    rates = (1e10 + rng.standard_normal(n) + walk).reshape(-1, 1)
    phase = np.asarray(_core.phase(rates, "rate"))
    m = 66_000  # 4 m = 264_000 of the 272_002 terms in spread lanes
    got = float(np.asarray(_core.variance(phase, [m], "modified", 1))[0, 0])
    assert abs(got / _exact_modified(phase[:, 0], m) - 1.0) < 1e-12
    assert np.asarray(_core.variance(phase, [8, m], "modified", 2))[1, 0] == got


def test_modified_paths_agree_bit_for_bit(rates: np.ndarray) -> None:
    """Steps read straight from the phase (one contiguous channel) or through a buffer
    (interleaved channels) are the same arithmetic; each factor alone, in a list, on one or
    two threads gives the same bits."""
    both = np.asarray(
        _core.variance(np.asarray(_core.phase(rates, "rate")), FACTORS, "modified", 2)
    )
    one = np.asarray(_core.phase(np.ascontiguousarray(rates[:, :1]), "rate"))
    alone = np.vstack([np.asarray(_core.variance(one, [m], "modified", 1)) for m in FACTORS])
    assert np.array_equal(alone[:, 0], both[:, 0])
    assert np.array_equal(np.asarray(_core.variance(one, FACTORS, "modified", 2))[:, 0], both[:, 0])


def test_naive_prefix_sums_would_fail_on_this_record(rates: np.ndarray) -> None:
    """The record is a hard case: windows from float64 prefix sums of the phase (the O(1)
    formula without the kernel's split sums) miss 1e-12 by orders of magnitude at m = 1."""
    phase = np.asarray(_core.phase(np.ascontiguousarray(rates[:, :1]), "rate"))[:, 0]
    s = np.concatenate(([0.0], np.cumsum(phase)))
    w = s[3:] - 3.0 * s[2:-1] + 3.0 * s[1:-2] - s[:-3]
    naive = float(np.sum(w**2) / (2.0 * w.size))
    assert abs(naive / _exact_modified(phase, 1) - 1.0) > 1e-10  # measured 1.7e-8
