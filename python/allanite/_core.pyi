"""Type stub of the private compiled module ``allanite._core`` (pybind11, cpp/src).

Hand-written: keep in step with cpp/src/register_*.cpp. Every function raises ValueError
(std::invalid_argument) or TypeError on bad arguments; the numeric work runs without the GIL.
"""

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

SUM_BLOCK: int
SUM_LANES_STATE: int
PHASE_BLOCK: int

# register_variances.cpp ---------------------------------------------------------------------

def phase(x: NDArray[np.generic], input: str, threads: int = 0) -> NDArray[np.float64]:
    """Detrended, compensated phase (prefix sums) of a 2-D ``(N, C)`` record.

    ``input`` is ``"rate"``/``"increment"`` (mean removed, ``(N + 1, C)`` result) or ``"angle"``
    (least-squares line removed, ``(N, C)``). ``x`` may be float64, float32, int16, int32 or
    int64 and strided (no copy). The same bits for any ``threads`` (0: all cores).
    """

def variance(
    phase: NDArray[np.float64], m: Sequence[int] | NDArray[np.int64], kind: str, threads: int = 0
) -> NDArray[np.float64]:
    """Allan-family variance in sample units (tau0 = 1), shape ``(len(m), C)``.

    ``kind``: overlapping, standard, modified, hadamard, standard_hadamard, total.
    ``threads`` = 0 uses every core; results are bit-identical for any thread count. Every
    kind costs O(rows) per factor: modified as a running window moved on by third differences
    of the phase, restarted from its exact prefix sums, total as the overlapping sum plus its
    reflected end terms (no extended series is built).
    """

def lag1_acf(
    x: NDArray[np.generic],
    m: Sequence[int] | NDArray[np.int64],
    series: str,
    levels: int,
    threads: int = 0,
) -> NDArray[np.float64]:
    """Lag-1 autocorrelations for noise identification, shape ``(len(m), C * levels)``.

    Entry ``(t, c * levels + d)`` is the lag-1 autocorrelation of the d-th difference of
    ``x[::m, c]`` (``series="phase"``) or of its first difference, the m-sample frequency
    averages (``series="frequency"``). One streaming pass over tiles of rows per group of
    factors (no copies); ``x`` as for :func:`phase`. Bit-identical for any ``threads``.
    """

def mvar_avar_ratio(
    phase: NDArray[np.float64], m: Sequence[int] | NDArray[np.int64], threads: int = 0
) -> NDArray[np.float64]:
    """R(n) = modified / overlapping Allan variance, shape ``(len(m), C)`` (``3m <= rows``).

    The two variances of :func:`variance` (``"modified"`` and ``"overlapping"``) divided; NaN
    where the Allan variance is zero. Bit-identical for any ``threads``.
    """

def n_terms(kind: str, n_phase: int, m: int) -> int:
    """Return the number of difference terms the estimator averages for factor ``m``."""

def max_m(kind: str, n_phase: int) -> int:
    """Return the largest averaging factor the kernel supports for ``n_phase`` phase points."""

# register_generators.cpp --------------------------------------------------------------------

def ar1_bank(
    state: NDArray[np.float64],
    phi: ArrayLike,
    q: ArrayLike,
    a: ArrayLike,
    b: ArrayLike,
    z: ArrayLike,
    threads: int = 1,
) -> NDArray[np.float64]:
    """Bank of first-order recursions; ``state`` ``(J, C)`` updated in place, returns ``(B, C)``."""

def running_sum(
    hi: NDArray[np.float64], lo: NDArray[np.float64], x: ArrayLike
) -> NDArray[np.float64]:
    """Compensated running sum of ``x`` ``(B, C)`` continuing from the state ``(hi, lo)``."""

# register_streaming.cpp ---------------------------------------------------------------------

def stream_sums(
    x: NDArray[np.generic], k0: int, state: NDArray[np.float64], a: ArrayLike, b: ArrayLike
) -> NDArray[np.float64]:
    """Values ``(blocks, C)`` of the ``PHASE_BLOCK`` blocks a chunk completes.

    ``state`` ``(C, SUM_LANES_STATE)`` carries the current block.
    """

def stream_sums_value(state: NDArray[np.float64]) -> NDArray[np.float64]:
    """Values ``(C,)`` of the partial block carried in a :func:`stream_sums` state."""

def stream_block_total(values: ArrayLike) -> NDArray[np.float64]:
    """Totals ``(C,)`` of block values ``(blocks, C)`` in block order."""

def stream_block_bases(values: ArrayLike, corr: ArrayLike) -> NDArray[np.float64]:
    """Starting states ``(blocks, C, 2)`` of the accumulation in every block."""

def stream_moment(
    x: NDArray[np.generic],
    k0: int,
    kbar: float,
    mean1: ArrayLike,
    corr: ArrayLike,
    state: NDArray[np.float64],
) -> None:
    """Accumulate the centred first moment of a chunk into ``state``."""

def stream_prefix(
    x: NDArray[np.generic],
    k0: int,
    mean1: ArrayLike,
    corr: ArrayLike,
    bases: ArrayLike,
    state: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:
    """Rate/increment phase rows of a chunk into ``out`` ``(L, C)``."""

def stream_detrend(
    x: NDArray[np.generic],
    k0: int,
    kbar: float,
    mean1: ArrayLike,
    corr: ArrayLike,
    slope: ArrayLike,
    out: NDArray[np.float64],
) -> None:
    """Angle phase rows (least-squares residual) into ``out``."""

def diff_square_sums(
    windows: Sequence[NDArray[np.float64]], term_stride: int, count: int, state: NDArray[np.float64]
) -> None:
    """Accumulate squared difference sums over phase windows into ``state``."""
