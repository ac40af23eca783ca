"""Allan-family variances of records larger than memory, with a memory budget and progress.

:func:`avar_large` is :func:`allanite.variance.avar` for big inputs: the record may be a file
(:func:`allanite.variance.chunked.open_large`: ``.npy``, raw binary, text) read in chunks, the phase
array goes to a temporary file when it exceeds ``memory_limit``, and the variance passes read
it back in windows. The difference estimators need the taps ``x[k], x[k+m], x[k+2m]``
(``x[k+3m]`` for Hadamard): for a chunk of terms ``[j0, j0 + t)`` each tap is one window of
the phase file (one contiguous span when ``m`` is small), and the compiled kernel adds the
chunk's squared differences to carried compensated sums. Chunks start on multiples of the
kernel's summation block (``_core.SUM_BLOCK`` terms), so the result is the in-memory result
bit for bit, for every chunk size and thread count.

Memory: with ``memory_limit=L`` the working set is at most about ``L`` on top of the
interpreter (numpy, scipy, allanite: about 100 MB): the phase is kept in memory only if it
needs at most ``L/2``; otherwise the window buffers take ``L/2`` in total (split between the
worker threads) and the decimated series used for noise identification ``L/16``.
Input files are read with ``pread`` (page cache, not resident memory).

Out of core (phase in a file) the overlapping and standard Allan and Hadamard variances are
available; ``modified``/``time``/``total`` need the phase in memory (raise the limit). Noise
identification (``alpha=None``) then uses at most the first ``L / (16 * 8 * threads *
channels)`` points of the decimated phase ``x[::m]`` at each tau.
"""

from __future__ import annotations

import os
import queue
import re
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite import _core
from allanite._deprecation import keyword_only_fs
from allanite.io.record import Record
from allanite.units import record_rate_unit
from allanite.variance.checks import INPUTS, KINDS, check_threads, given_alpha, resolve_source
from allanite.variance.chunked import ChunkedRecord, as_chunked, open_large
from allanite.variance.edf import (
    cap_few_point_alpha,
    identify_alpha,
    smooth_isolated_alpha,
    wants_identification,
)
from allanite.variance.kernel import (
    ProgressCallback,
    fast_q,
    identify_bounded,
    series_points,
    variances,
)
from allanite.variance.phase_store import PhaseStore, build_phase_store
from allanite.variance.result import AllanResult, assemble_result
from allanite.variance.taus import KERNEL_KIND, TauSpec, averaging_factors

__all__ = ["avar_large", "parse_memory", "variance_from_store"]

_UNITS = {
    "": 1,
    "b": 1,
    "k": 10**3,
    "kb": 10**3,
    "m": 10**6,
    "mb": 10**6,
    "g": 10**9,
    "gb": 10**9,
    "t": 10**12,
    "tb": 10**12,
    "kib": 2**10,
    "mib": 2**20,
    "gib": 2**30,
    "tib": 2**40,
}
#: kernel kinds the windowed (out-of-core) pass supports -> (taps - 1, term stride is m?)
_WINDOWED = {
    "overlapping": (2, False),
    "standard": (2, True),
    "hadamard": (3, False),
    "standard_hadamard": (3, True),
}
_NORM = {2: 2.0, 3: 6.0}
_GATHER_ROWS_LIMIT = 4096  # above this stride, decimated rows are read one by one


def parse_memory(limit: int | float | str | None) -> int | None:
    """Bytes of a memory budget: an integer, or text like ``"1GB"``, ``"512 MiB"``, ``"2e9"``.

    Decimal units (kB, MB, GB, TB) are powers of 1000, binary ones (KiB, MiB, GiB, TiB) of 1024.
    """
    if limit is None:
        return None
    if isinstance(limit, bool):
        raise TypeError("memory_limit must be a number of bytes or text like '1GB', not a bool")
    if isinstance(limit, (int, float, np.integer, np.floating)):
        value = float(limit)
    elif isinstance(limit, str):
        match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", limit)
        if not match or match.group(2).lower() not in _UNITS:
            raise ValueError(
                f"cannot read memory_limit={limit!r}; write e.g. '1GB', '512MiB' or 2e9"
            )
        value = float(match.group(1)) * _UNITS[match.group(2).lower()]
    else:
        raise TypeError(f"memory_limit must be a number of bytes or text like '1GB', got {limit!r}")
    if not np.isfinite(value) or value < 16_000:
        raise ValueError(
            f"memory_limit={limit!r} is below 16 kB; give a budget in bytes or with a unit, "
            "e.g. '256MB' or '1GB'"
        )
    return int(value)


def _block_floor(n: int) -> int:
    block = int(_core.SUM_BLOCK)
    return max(block, n // block * block)


class _WindowReader:
    """One worker's buffer and the windowed sums of one averaging factor."""

    def __init__(self, store: PhaseStore, order: int, chunk_terms: int, alpha_rows: int) -> None:
        self.store = store
        self.order = order
        self.chunk_terms = chunk_terms
        self.alpha_rows = alpha_rows
        self.buffer = np.empty(((order + 1) * chunk_terms, store.channels))

    def _gather(
        self, first: int, step: int, count: int, out: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Rows first, first + step, ... (count of them) of the phase into out[:count]."""
        if step == 1:
            return self.store.read(first, out[:count])
        if step > _GATHER_ROWS_LIMIT:
            return self.store.read_rows(first + step * np.arange(count, dtype=np.int64))
        span_rows = max(1, out.shape[0] // step)  # decimated rows per contiguous read
        # a contiguous span of step * span_rows rows must fit: read it in the tail of the buffer
        dst = out[:count]
        done = 0
        scratch = np.empty((min(span_rows, count) * step, self.store.channels))
        while done < count:
            take = min(span_rows, count - done)
            rows = (take - 1) * step + 1
            block = self.store.read(first + done * step, scratch[:rows])
            dst[done : done + take] = block[::step]
            done += take
        return dst

    def sums(
        self, m: int, n_terms: int, strided: bool
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Compensated sums of squared differences (C, 2) and the decimated phase for alpha."""
        nc = self.store.channels
        state = np.zeros((nc, 2))
        t = self.chunk_terms
        buf = self.buffer
        decimated: list[NDArray[np.float64]] = []
        kept = 0
        for j0 in range(0, n_terms, t):
            count = min(t, n_terms - j0)
            if strided:
                # taps of term j are rows (j + i) m: a decimated span of count + order rows
                span = self._gather(j0 * m, m, count + self.order, buf)
                windows = [span[i : i + count] for i in range(self.order + 1)]
                _core.diff_square_sums(windows, 1, count, state)
                first_keep = span[:count]
                dec = first_keep
            else:
                if count + self.order * m <= buf.shape[0]:
                    span = self.store.read(j0, buf[: count + self.order * m])
                    windows = [span[i * m : i * m + count] for i in range(self.order + 1)]
                else:
                    windows = [
                        self.store.read(j0 + i * m, buf[i * t : i * t + count])
                        for i in range(self.order + 1)
                    ]
                _core.diff_square_sums(windows, 1, count, state)
                dec = windows[0][(-j0) % m :: m]
            if kept < self.alpha_rows:
                part = np.array(dec[: self.alpha_rows - kept])
                decimated.append(part)
                kept += part.shape[0]
        first_missing = (kept * m) if kept else 0
        if kept < self.alpha_rows and first_missing < self.store.rows:
            rest = np.arange(first_missing, self.store.rows, m, dtype=np.int64)[
                : self.alpha_rows - kept
            ]
            decimated.append(self.store.read_rows(rest))
        return state, np.concatenate(decimated, axis=0)


def variance_from_store(
    store: PhaseStore,
    factors: NDArray[np.int64],
    kernel_kind: str,
    *,
    threads: int,
    window_bytes: int | None = None,
    alpha_rows: int | None = None,
    identify: str | None = None,
    progress: ProgressCallback | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int64] | None]:
    """Variances in sample units (tau0 = 1) for each factor and channel, from a phase store.

    In memory this calls the compiled kernel (in groups of factors when reporting progress);
    from a file it runs the windowed pass of this module, threads over factors.

    Parameters
    ----------
    store : PhaseStore
        The phase array.
    factors : numpy.ndarray
        Averaging factors.
    kernel_kind : str
        Kernel kind (see :data:`allanite.variance.taus.KERNEL_KIND`).
    threads : int
        Worker threads (0: all cores).
    window_bytes : int, optional
        Total window buffer memory over all workers (file store only); default 256 MiB.
    alpha_rows : int, optional
        Largest decimated series kept per factor for noise identification (None: all of it,
        only possible in memory).
    identify : {"frequency", "phase"} or None
        Identify alpha (the data argument of :func:`allanite.variance.edf.identify_alpha`) or not.
    progress : callable, optional
        ``progress("variance", done, total)`` as factors complete.

    Returns
    -------
    tuple
        ``(var (T, C), alpha (T, C) or None)``.
    """
    nt = factors.size
    nc = store.channels
    if store.array is not None:
        phase = store.array
        var = variances(phase, factors, kernel_kind, threads=threads, progress=progress)
        return var, _identify(phase, factors, kernel_kind, identify, alpha_rows)
    if kernel_kind not in _WINDOWED:
        raise ValueError(
            f"kind {kernel_kind!r} needs the whole phase array in memory "
            f"({store.nbytes / 1e6:.0f} MB); "
            "raise memory_limit above that, or use kind='overlapping', 'standard', 'hadamard' or "
            "'standard_hadamard'"
        )
    order, strided = _WINDOWED[kernel_kind]
    workers = min(max(1, threads or (os.cpu_count() or 1)), nt)
    budget = window_bytes if window_bytes is not None else 256 * 2**20
    chunk_terms = _block_floor(budget // (workers * (order + 1) * nc * 8))
    m_top = int(factors.max())
    var = np.empty((nt, nc))
    alphas = np.empty((nt, nc), dtype=np.int64) if identify is not None else None
    points = np.zeros(nt, dtype=np.int64)

    def one(i: int, reader: _WindowReader) -> None:
        m = int(factors[i])
        n = int(_core.n_terms(kernel_kind, store.rows, m))
        if m > m_top or n < 1:  # pragma: no cover - factors were validated by the caller
            raise ValueError(f"averaging factor {m} is not admissible")
        state, decimated = reader.sums(m, n, strided)
        md, nd = float(m), float(n)
        var[i] = (state[:, 0] + state[:, 1]) / (_NORM[order] * md * md * nd)
        if alphas is not None and identify is not None:
            alphas[i] = identify_alpha(decimated, np.array([1]), kernel_kind, data=identify)[0]
            points[i] = series_points(decimated.shape[0], identify)

    rows = alpha_rows if alpha_rows is not None else 1 << 22
    readers = [_WindowReader(store, order, chunk_terms, rows) for _ in range(workers)]
    _run_factors(nt, readers, one, progress)
    return var, _capped(alphas, factors, points)


def _run_factors(
    nt: int,
    readers: list[_WindowReader],
    one: Callable[[int, _WindowReader], None],
    progress: ProgressCallback | None,
) -> None:
    """Call ``one(i, reader)`` for every factor index, one worker thread per reader.

    Each worker owns one reader and takes factors from a shared queue; progress is reported
    on the calling thread as factors complete, and a failed worker ends the wait at once
    (its exception is raised here).
    """
    if len(readers) == 1:
        for done, i in enumerate(range(nt), start=1):
            one(i, readers[0])
            if progress is not None:
                progress("variance", done, nt)
        return
    todo: queue.SimpleQueue[int] = queue.SimpleQueue()
    for i in range(nt):
        todo.put(i)
    finished: queue.SimpleQueue[int] = queue.SimpleQueue()

    def worker(reader: _WindowReader) -> None:
        while True:
            try:
                i = todo.get_nowait()
            except queue.Empty:
                return
            one(i, reader)
            finished.put(i)

    with ThreadPoolExecutor(max_workers=len(readers)) as pool:
        futures = [pool.submit(worker, r) for r in readers]
        done = 0
        while done < nt and not any(f.done() and f.exception() for f in futures):
            try:
                finished.get(timeout=0.2)
            except queue.Empty:
                if all(f.done() for f in futures):
                    break
                continue
            done += 1
            if progress is not None:
                progress("variance", done, nt)
        for fut in futures:
            fut.result()


def _capped(
    alphas: NDArray[np.int64] | None, factors: NDArray[np.int64], points: NDArray[np.int64]
) -> NDArray[np.int64] | None:
    return None if alphas is None else cap_few_point_alpha(alphas, factors, points)


@keyword_only_fs
def avar_large(
    source: ArrayLike | Record | ChunkedRecord | str | os.PathLike[str],
    *,
    fs: float | None = None,
    input: str | None = None,
    kind: str = "overlapping",
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    chunk_rows: int | None = None,
    tmpdir: str | os.PathLike[str] | None = None,
    progress: ProgressCallback | None = None,
    fast: bool | int = False,
    **open_options: Any,
) -> AllanResult:
    r"""Allan-family variance of a record that may not fit in memory.

    Same estimators, tau grid, EDF and result as :func:`allanite.variance.avar` (for the same phase
    the variances are identical bit for bit); the record is read in chunks and the phase
    array is kept in a temporary file when it needs more than half of ``memory_limit``.

    Parameters
    ----------
    source : array_like, Record, ChunkedRecord or path
        Samples ``(N,)``/``(N, C)``, a :class:`~allanite.io.Record` (its own ``fs``, ``input``
        and unit), a record from :mod:`allanite.variance.chunked`, or a file path
        opened with :func:`allanite.variance.chunked.open_large` and ``open_options`` (e.g.
        ``dtype="float32", n_channels=3, byteorder="<"`` for raw binary).
    fs, input, kind, taus, m, points, alpha, threads, units
        As for :func:`allanite.variance.avar`.
    memory_limit : int, float or str, optional
        Working-memory budget in bytes or as text (``"1GB"``); default: no limit (phase in
        memory). Peak RSS is about this plus the interpreter's ~100 MB.
    chunk_rows : int, optional
        Rows per chunk when reading the input (default from the budget, else 2^20).
    tmpdir : path-like, optional
        Directory of the temporary phase file.
    progress : callable, optional
        ``progress(stage, done, total)``, stage ``"phase"`` (samples x passes read) then
        ``"variance"`` (taus done), called on the calling thread.
    fast : bool or int
        Fast mode (:mod:`allanite.variance.fast`): at ``m >= 2q`` use every ``m // q``-th term
        (``q = 16`` for ``True``, or the integer given); overlapping and hadamard kinds,
        phase in memory. The deviation from the exact result is at most ``1.2/q`` of the
        estimator's own standard deviation for white rate noise (see :mod:`allanite.variance.fast`).
        The strides used are in ``meta["fast_stride"]``. Exact is the default.

    Returns
    -------
    AllanResult
        With ``meta`` holding ``phase_in_memory`` and ``phase_bytes``.

    References
    ----------
    W. J. Riley, *Handbook of Frequency Stability Analysis*, NIST SP1065 (2008), eq. 11-20.
    """
    source, rate, input, units, meta = resolve_source(source, fs, input, units)
    if kind not in KERNEL_KIND:
        raise ValueError(f"unknown kind {kind!r}; use one of {', '.join(KINDS)}")
    if input not in INPUTS:
        raise ValueError(f"unknown input {input!r}; use 'rate', 'increment' or 'angle'")
    units = record_rate_unit(units, input)  # the same check as avar's
    nthreads = check_threads(threads)
    limit = parse_memory(memory_limit)
    record = _chunked(source, open_options)
    nc = record.n_channels
    workers = max(1, nthreads or (os.cpu_count() or 1))
    if chunk_rows is None:
        per_row = nc * (record.dtype.itemsize + 8 + 8)
        chunk_rows = 1 << 20 if limit is None else max(1024, min(1 << 22, limit // (8 * per_row)))
    kernel_kind = KERNEL_KIND[kind]
    with build_phase_store(
        record,
        input,
        chunk_rows=int(chunk_rows),
        max_memory_bytes=None if limit is None else limit // 2,
        tmpdir=tmpdir,
        progress=progress,
    ) as store:
        n_phase = store.rows
        n_samples = n_phase if input == "angle" else n_phase - 1
        factors = averaging_factors(
            taus, fs=rate, n_samples=n_samples, n_phase=n_phase, kind=kind, m=m, points=points
        )
        identify = (
            ("phase" if input == "angle" else "frequency") if wants_identification(alpha) else None
        )
        meta.update(phase_in_memory=store.in_memory, phase_bytes=store.nbytes)
        var, alphas = _store_variances(
            store,
            factors,
            kernel_kind,
            q=fast_q(fast),
            threads=nthreads,
            identify=identify,
            alpha_rows=None if limit is None else max(1024, limit // (16 * 8 * workers * nc)),
            window_bytes=None if limit is None else limit // 2,
            progress=progress,
            meta=meta,
        )
    if alphas is None:
        if identify is not None:  # pragma: no cover - identify was requested above
            raise RuntimeError("noise identification returned nothing")
        alphas = given_alpha(alpha, var.shape)
    elif alpha is None:  # identified: isolated flips smoothed as in allanite.avar
        alphas = smooth_isolated_alpha(alphas, factors)
    return assemble_result(
        var,
        factors,
        alphas,
        rate=rate,
        input=input,
        kind=kind,
        n_phase=n_phase,
        n_samples=n_samples,
        units=units,
        was_1d=nc == 1 and _was_1d(source, record),
        meta=meta,
    )


def _chunked(source: Any, open_options: dict[str, Any]) -> ChunkedRecord:
    """A chunked record of a path (opened with ``open_options``), array or chunked record."""
    if isinstance(source, (str, Path, os.PathLike)):
        return open_large(source, **open_options)
    if open_options:
        raise TypeError(f"file options {sorted(open_options)} apply only when source is a path")
    return as_chunked(source)


def _store_variances(
    store: PhaseStore,
    factors: NDArray[np.int64],
    kernel_kind: str,
    *,
    q: int | None,
    threads: int,
    identify: str | None,
    alpha_rows: int | None,
    window_bytes: int | None,
    progress: ProgressCallback | None,
    meta: dict[str, Any],
) -> tuple[NDArray[np.float64], NDArray[np.int64] | None]:
    """Variances and identified exponents from a phase store: fast mode (in memory) or exact."""
    if q is None:
        return variance_from_store(
            store,
            factors,
            kernel_kind,
            threads=threads,
            window_bytes=window_bytes,
            alpha_rows=alpha_rows,
            identify=identify,
            progress=progress,
        )
    if store.array is None:
        raise ValueError(
            "fast=True needs the phase array in memory; raise memory_limit or drop fast"
        )
    var = variances(store.array, factors, kernel_kind, threads=threads, q=q, meta=meta)
    return var, _identify(store.array, factors, kernel_kind, identify, alpha_rows)


def _identify(
    phase: NDArray[np.float64],
    factors: NDArray[np.int64],
    kernel_kind: str,
    identify: str | None,
    alpha_rows: int | None,
) -> NDArray[np.int64] | None:
    """Identification on an in-memory phase: all of it, or ``alpha_rows`` points per tau."""
    if identify is None:
        return None
    if alpha_rows is None:
        return identify_alpha(phase, factors, kernel_kind, data=identify)
    return identify_bounded(phase, factors, kernel_kind, identify, alpha_rows)


def _was_1d(source: Any, record: ChunkedRecord) -> bool:
    """Single-channel sources give 1-D results, like :func:`allanite.avar` on a 1-D array."""
    if isinstance(source, np.ndarray):
        return source.ndim == 1
    if isinstance(source, (list, tuple)):
        return np.ndim(source) == 1
    return record.n_channels == 1
