"""Bad input raises ValueError/TypeError naming the problem; never a crash or a silent NaN."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import allanite
from allanite import _core

RNG = np.random.default_rng(0)
GOOD = RNG.standard_normal(200)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("input_kind", ["rate", "increment", "angle"])
def test_non_finite_samples_are_rejected(bad: float, dtype: type, input_kind: str) -> None:
    x = GOOD.astype(dtype)
    x[17] = bad
    with pytest.raises(ValueError, match=r"NaN or inf at sample 17"):
        allanite.avar(x, fs=1.0, input=input_kind)


def test_non_finite_in_second_channel_names_the_channel() -> None:
    x = np.column_stack([GOOD, GOOD])
    x[5, 1] = np.nan
    with pytest.raises(ValueError, match=r"sample 5, channel 1"):
        allanite.avar(x, fs=1.0)


@pytest.mark.parametrize("n", [0, 1, 2])
def test_empty_and_too_short_records(n: int) -> None:
    with pytest.raises(ValueError, match="too short"):
        allanite.avar(np.zeros(n), fs=1.0)
    with pytest.raises(ValueError, match="too short"):
        allanite.avar(np.zeros((n, 2)) if n else np.zeros((0, 1)), fs=1.0)


def test_too_short_for_hadamard() -> None:
    with pytest.raises(ValueError, match=r"record too short|tau grid is empty"):
        allanite.avar(np.arange(3.0), fs=1.0, kind="hadamard", input="angle")


@pytest.mark.parametrize("kind", ["overlapping", "standard", "total"])
def test_taus_beyond_half_the_record(kind: str) -> None:
    with pytest.raises(ValueError, match=r"exceeds the longest"):
        allanite.avar(GOOD, fs=1.0, kind=kind, taus=[1.0, 150.0])
    with pytest.raises(ValueError, match=r"exceeds the longest"):
        allanite.avar(GOOD, fs=10.0, kind=kind, m=[101])


def test_taus_shorter_than_a_sample_or_invalid() -> None:
    with pytest.raises(ValueError, match="shorter than one sample"):
        allanite.avar(GOOD, fs=1.0, taus=[0.2])
    for taus in ([], [np.nan], [-1.0], [0.0]):
        with pytest.raises(ValueError, match="taus"):
            allanite.avar(GOOD, fs=1.0, taus=taus)
    with pytest.raises(ValueError, match="unknown tau grid"):
        allanite.avar(GOOD, fs=1.0, taus="weekly")


def test_bad_averaging_factors() -> None:
    with pytest.raises(ValueError, match="whole numbers"):
        allanite.avar(GOOD, fs=1.0, m=[1.5])
    with pytest.raises(ValueError, match="empty"):
        allanite.avar(GOOD, fs=1.0, m=[])
    with pytest.raises(ValueError, match="shorter than one sample"):
        allanite.avar(GOOD, fs=1.0, m=[0, 2])


@pytest.mark.parametrize("fs", [0.0, -1.0, np.nan, np.inf])
def test_non_positive_or_non_finite_fs(fs: float) -> None:
    with pytest.raises(ValueError, match="fs must be a positive"):
        allanite.avar(GOOD, fs=fs)


def test_fs_of_the_wrong_type() -> None:
    with pytest.raises(TypeError, match="fs must be a number"):
        allanite.avar(GOOD, fs="fast")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "x",
    [np.zeros((10, 2, 2)), np.float64(3.0)],
    ids=["3-D", "0-D"],
)
def test_wrong_shapes(x: np.ndarray) -> None:
    with pytest.raises(ValueError, match="must be 1-D"):
        allanite.avar(x, fs=1.0)


def test_channels_as_rows_is_caught() -> None:
    with pytest.raises(ValueError, match=r"fewer samples than channels.*x\.T"):
        allanite.avar(np.zeros((3, 500)), fs=1.0)


@pytest.mark.parametrize(
    "x",
    [
        GOOD.astype(np.complex128),
        GOOD > 0,
        np.array(["1", "2", "3", "4"]),
        np.array([1.0, None, 3.0, 4.0], dtype=object),
        np.arange(10, dtype=np.uint64),
    ],
    ids=["complex", "bool", "str", "object", "uint64"],
)
def test_wrong_dtypes(x: np.ndarray) -> None:
    with pytest.raises(TypeError, match="dtype"):
        allanite.avar(x, fs=1.0)


def test_small_integer_dtypes_are_widened_exactly() -> None:
    x8 = (RNG.integers(-100, 100, 300)).astype(np.int8)
    res = allanite.avar(x8, fs=1.0, taus="octave")
    ref = allanite.avar(x8.astype(np.int64), fs=1.0, taus="octave")
    np.testing.assert_array_equal(res.var, ref.var)


def test_exotic_strides_are_rejected_by_the_core() -> None:
    """A view whose byte stride is not a multiple of the item size (unaligned records)."""
    buf = np.zeros(8 * 100 + 1, dtype=np.uint8)
    x = np.ndarray(shape=(50, 1), dtype=np.float64, buffer=buf, offset=1, strides=(9, 8))
    with pytest.raises(TypeError, match="strides"):
        _core.phase(x, "rate")
    with pytest.raises(TypeError, match=r"strides.*ascontiguousarray"):
        allanite.avar(x, fs=1.0)


def test_unknown_kind_input_threads() -> None:
    with pytest.raises(ValueError, match="unknown kind"):
        allanite.avar(GOOD, fs=1.0, kind="allan")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown input"):
        allanite.avar(GOOD, fs=1.0, input="phase")  # type: ignore[arg-type]
    for threads in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="threads"):
            allanite.avar(GOOD, fs=1.0, threads=threads)  # type: ignore[arg-type]


def test_core_rejects_bad_arguments() -> None:
    phase = _core.phase(GOOD.reshape(-1, 1), "rate")
    with pytest.raises(ValueError, match="outside"):
        _core.variance(phase, [1000], "overlapping", 1)
    with pytest.raises(ValueError, match="kind must be one of"):
        _core.variance(phase, [1], "allan", 1)
    with pytest.raises(ValueError, match="input must be"):
        _core.phase(GOOD.reshape(-1, 1), "phase")
    with pytest.raises(ValueError, match="2-D"):
        _core.phase(GOOD, "rate")


def test_bad_alpha_and_level() -> None:
    with pytest.raises(ValueError, match="alpha must hold integer"):
        allanite.avar(GOOD, fs=1.0, alpha=3)
    with pytest.raises(ValueError, match="alpha must hold integer"):
        allanite.avar(GOOD, fs=1.0, alpha=0.5)
    with pytest.raises(ValueError, match="alpha has shape"):
        allanite.avar(GOOD, fs=1.0, taus="octave", alpha=[0, 0])
    with pytest.raises(TypeError, match="alpha"):
        allanite.avar(GOOD, fs=1.0, alpha="white")  # type: ignore[arg-type]
    res = allanite.avar(GOOD, fs=1.0, taus="octave")
    for level in (0.0, 1.0, -0.5, 2.0):
        with pytest.raises(ValueError, match="level"):
            res.ci(level)


def test_constant_record_gives_zeros_not_nan() -> None:
    """A perfectly constant (or perfectly linear angle) record: zero variance, finite EDF."""
    for kind in ("overlapping", "modified", "hadamard", "total"):
        res = allanite.avar(np.full(100, 3.0), fs=1.0, kind=kind, taus="octave")
        assert np.all(res.var == 0.0)
        assert np.all(np.isfinite(res.edf))
        lo, hi = res.ci()
        assert np.all(lo == 0.0)
        assert np.all(hi == 0.0)


# dtype objects that equal the native ones but are other objects: '<f8' made through
# newbyteorder is float64 (regression: the core compared dtypes by identity and refused them)
_SAME_TYPES = ["float64", "float32", "int16", "int32", "int64"]


def _same_but_other_object(name: str) -> np.dtype[Any]:
    native = np.dtype(name)
    other = native.newbyteorder("S").newbyteorder("S")  # a distinct descriptor object
    assert other == native
    return other


@pytest.mark.parametrize("name", _SAME_TYPES)
def test_core_compares_dtypes_by_kind_size_and_order(name: str) -> None:
    x = (RNG.normal(size=(400, 2)) * 100).astype(name)
    y = x.astype(_same_but_other_object(name))
    little = x.astype(np.dtype(name).newbyteorder("<"))
    for z in (y, little):
        np.testing.assert_array_equal(_core.phase(z, "rate"), _core.phase(x, "rate"))
        np.testing.assert_array_equal(_core.phase(z, "angle"), _core.phase(x, "angle"))
        np.testing.assert_array_equal(
            _core.lag1_acf(z, [1, 2, 4], "frequency", 2),
            _core.lag1_acf(x, [1, 2, 4], "frequency", 2),
        )
    np.testing.assert_array_equal(allanite.avar(y, fs=1.0).var, allanite.avar(x, fs=1.0).var)


@pytest.mark.parametrize("name", _SAME_TYPES)
def test_chunked_phase_accepts_equal_dtype_objects(name: str) -> None:
    from allanite.variance.chunked import ArrayRecord
    from allanite.variance.phase_store import build_phase_store

    x = (RNG.normal(size=(500, 2)) * 100).astype(name)
    y = x.astype(_same_but_other_object(name))
    for kind in ("rate", "angle"):
        with build_phase_store(
            ArrayRecord(y), kind, chunk_rows=128, max_memory_bytes=None
        ) as store:
            got = store.read(0, np.empty((store.rows, store.channels)))
        np.testing.assert_array_equal(got, _core.phase(x, kind))


def test_core_refuses_foreign_byte_order_with_the_fix() -> None:
    swapped = ">f8" if np.little_endian else "<f8"
    x = RNG.normal(size=(100, 1)).astype(swapped)
    with pytest.raises(TypeError, match=r"not in native byte order.*newbyteorder\('='\)"):
        _core.phase(x, "rate")
    # the public API converts instead
    np.testing.assert_array_equal(
        allanite.avar(x, fs=1.0).var, allanite.avar(x.astype(np.float64), fs=1.0).var
    )
