"""The phase (prefix-sum) array of a record, in memory or in a temporary file.

:func:`build_phase_store` runs the passes of the compiled ``phase`` kernel one chunk of rows at
a time (:mod:`allanite.variance.chunked` supplies the chunks), carrying the compensated sums between
chunks, so the result equals ``allanite._core.phase(x, input)`` bit for bit whatever the chunk
size. The phase lives in a numpy array when it fits the memory budget, otherwise in a
temporary float64 file that is read back in windows and deleted by :meth:`PhaseStore.close`.

Passes over the input: rate/increment three (sum, compensated mean correction, prefix sums),
angle four (sum, correction, least-squares slope, residuals).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite import _core
from allanite.variance.chunked import ChunkedRecord
from allanite.variance.kernel import ProgressCallback

__all__ = ["PhaseStore", "ProgressCallback", "build_phase_store"]

_ITEM = 8  # float64 phase


@dataclass
class PhaseStore:
    """A ``(rows, channels)`` float64 phase array held in memory or in a temporary file.

    Attributes
    ----------
    rows, channels : int
        Shape of the phase array.
    array : numpy.ndarray or None
        The array when held in memory.
    path : pathlib.Path or None
        The temporary file (row-major float64) otherwise.
    """

    rows: int
    channels: int
    array: NDArray[np.float64] | None = None
    path: Path | None = None
    _fd: int | None = field(default=None, repr=False)

    @property
    def in_memory(self) -> bool:
        """Whether the phase is a numpy array (else a temporary file)."""
        return self.array is not None

    @property
    def nbytes(self) -> int:
        """Size of the phase array in bytes."""
        return self.rows * self.channels * _ITEM

    def read(self, start: int, out: NDArray[np.float64]) -> NDArray[np.float64]:
        """Rows ``start : start + len(out)`` into ``out`` (file) or as a view (memory)."""
        n = out.shape[0]
        if start < 0 or start + n > self.rows:
            raise IndexError(
                f"rows {start}:{start + n} outside the phase array of {self.rows} rows"
            )
        if self.array is not None:
            return self.array[start : start + n]
        assert self._fd is not None
        view = memoryview(out).cast("B")  # type: ignore[arg-type]
        done, offset = 0, start * self.channels * _ITEM
        while done < view.nbytes:
            got = os.preadv(self._fd, [view[done:]], offset + done)
            if got == 0:
                raise OSError(f"temporary phase file {self.path} is shorter than expected")
            done += got
        return out

    def read_rows(self, rows: NDArray[np.int64]) -> NDArray[np.float64]:
        """Individual rows (a fancy-index gather), shape ``(len(rows), channels)``."""
        if self.array is not None:
            return self.array[rows]
        out = np.empty((rows.size, self.channels), dtype=np.float64)
        for i, r in enumerate(rows.tolist()):
            self.read(int(r), out[i : i + 1])
        return out

    def close(self) -> None:
        """Release the array or close and delete the temporary file."""
        self.array = None
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        if self.path is not None:
            with contextlib.suppress(FileNotFoundError):
                self.path.unlink()
            self.path = None

    def __enter__(self) -> PhaseStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Writer:
    """Sequential writer into a PhaseStore being built."""

    def __init__(self, store: PhaseStore) -> None:
        self.store = store
        self.row = 0

    def write(self, block: NDArray[np.float64]) -> None:
        n = block.shape[0]
        if self.store.array is not None:
            self.store.array[self.row : self.row + n] = block
        else:
            assert self.store._fd is not None
            data = np.ascontiguousarray(block)
            view = memoryview(data).cast("B")  # type: ignore[arg-type]
            done, offset = 0, self.row * self.store.channels * _ITEM
            while done < view.nbytes:
                done += os.pwrite(self.store._fd, view[done:], offset + done)
        self.row += n


def _value(state: NDArray[np.float64]) -> NDArray[np.float64]:
    """Value of carried Neumaier sums: hi + lo (the same rounding as NeumaierSum::value)."""
    return state[:, 0] + state[:, 1]


def _allocate(
    rows: int, channels: int, in_memory: bool, tmpdir: str | os.PathLike[str] | None
) -> PhaseStore:
    if in_memory:
        return PhaseStore(rows, channels, array=np.empty((rows, channels), dtype=np.float64))
    fd, name = tempfile.mkstemp(prefix="allanite-phase-", suffix=".f64", dir=tmpdir)
    store = PhaseStore(rows, channels, path=Path(name), _fd=fd)
    try:
        os.ftruncate(fd, rows * channels * _ITEM)
    except OSError:
        store.close()
        raise
    return store


def build_phase_store(
    record: ChunkedRecord,
    input: str,
    *,
    chunk_rows: int,
    max_memory_bytes: int | None,
    tmpdir: str | os.PathLike[str] | None = None,
    progress: ProgressCallback | None = None,
) -> PhaseStore:
    r"""Detrended, compensated phase of a chunked record (equal to ``_core.phase`` bit for bit).

    Parameters
    ----------
    record : ChunkedRecord
        The samples, read in chunks of ``chunk_rows`` rows per pass.
    input : {"rate", "increment", "angle"}
        Record type: rate/increment give ``N + 1`` phase rows
        :math:`x_{k+1} = \sum_{i\le k} (y_i - \bar y)`, angle gives ``N`` rows (the residual
        of the least-squares line).
    chunk_rows : int
        Rows per chunk (sets the working memory of the passes).
    max_memory_bytes : int or None
        Keep the phase in memory if it needs at most this many bytes (None: always), else in
        a temporary file in ``tmpdir``.
    tmpdir : path-like, optional
        Directory of the temporary file (default: the system temporary directory).
    progress : callable, optional
        ``progress("phase", done, total)`` after each chunk; ``done``/``total`` count samples
        summed over the passes.

    Returns
    -------
    PhaseStore
        Close it (or use it as a context manager) to delete a temporary file.
    """
    if input not in ("rate", "increment", "angle"):
        raise ValueError(f"unknown input {input!r}; use 'rate', 'increment' or 'angle'")
    nc = record.n_channels
    zeros = np.zeros(nc)
    passes = 4 if input == "angle" else 3
    known = record.n_samples
    done = 0

    def tick(rows: int, n_total: int | None) -> None:
        nonlocal done
        done += rows
        if progress is not None:
            progress("phase", done, passes * n_total if n_total else max(done, 1))

    def block_values(
        mean: NDArray[np.float64], n_total: int | None
    ) -> tuple[NDArray[np.float64], int]:
        """Block values of x - mean (_core.stream_sums) over the record, and its length."""
        state = np.zeros((nc, _core.SUM_LANES_STATE))
        values: list[NDArray[np.float64]] = [np.zeros((0, nc))]
        k0 = 0
        for chunk in record.chunks(chunk_rows):
            values.append(_core.stream_sums(chunk, k0, state, mean, zeros))
            k0 += chunk.shape[0]
            tick(chunk.shape[0], n_total)
        if k0 % _core.PHASE_BLOCK:  # the last, partial block
            values.append(_core.stream_sums_value(state).reshape(1, nc))
        return np.concatenate(values), k0

    v1, n = block_values(zeros, known)
    if n < 3:
        raise ValueError(f"record too short: need at least 3 samples, got {n}")
    nn = float(n)
    mean1 = _core.stream_block_total(v1) / nn
    v2, _ = block_values(mean1, n)
    corr = _core.stream_block_total(v2) / nn

    rows = n if input == "angle" else n + 1
    in_memory = max_memory_bytes is None or rows * nc * _ITEM <= max_memory_bytes
    store = _allocate(rows, nc, in_memory, tmpdir)
    try:
        writer = _Writer(store)
        out = np.empty((chunk_rows, nc))
        if input == "angle":
            kbar = 0.5 * float(n - 1)
            sxx = nn * (nn * nn - 1.0) / 12.0
            sxy = np.zeros((nc, 2))
            k0 = 0
            for chunk in record.chunks(chunk_rows):
                _core.stream_moment(chunk, k0, kbar, mean1, corr, sxy)
                k0 += chunk.shape[0]
                tick(chunk.shape[0], n)
            slope = _value(sxy) / sxx
            k0 = 0
            for chunk in record.chunks(chunk_rows):
                block = out[: chunk.shape[0]]
                _core.stream_detrend(chunk, k0, kbar, mean1, corr, slope, block)
                writer.write(block)
                k0 += chunk.shape[0]
                tick(chunk.shape[0], n)
        else:
            writer.write(np.zeros((1, nc)))
            bases = _core.stream_block_bases(v2, corr)
            acc = np.zeros((nc, 2))
            k0 = 0
            for chunk in record.chunks(chunk_rows):
                block = out[: chunk.shape[0]]
                _core.stream_prefix(chunk, k0, mean1, corr, bases, acc, block)
                writer.write(block)
                k0 += chunk.shape[0]
                tick(chunk.shape[0], n)
        if writer.row != rows:
            raise OSError(
                f"the record changed while it was read ({writer.row} of {rows} phase rows)"
            )
    except BaseException:
        store.close()
        raise
    return store


def describe_store(store: PhaseStore) -> dict[str, Any]:
    """Where the phase lives, for result metadata."""
    return {"phase_in_memory": store.in_memory, "phase_bytes": store.nbytes}
