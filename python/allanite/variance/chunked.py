"""Records larger than memory: read in chunks of rows without mapping the whole file.

A *chunked record* knows its channel count and sample type and yields ``(rows, channels)``
blocks in order. The out-of-core variance path (:mod:`allanite.variance.outofcore`) consumes
these chunks, so peak resident memory is set by the chunk size, not by the file size. Files are
read with ``os.pread`` into reusable buffers rather than memory-mapped: mapped pages that have
been touched count towards the resident set size (RSS) until the kernel evicts them, read pages only
occupy the page cache.

Supported sources:

- :class:`ArrayRecord`: an in-memory or memory-mapped numpy array (views, no copies);
- :class:`BinaryRecord`: raw binary samples with a dtype, channel count, byte order, header
  offset and interleaved or planar layout; ``.npy`` files map onto it through
  :func:`npy_record` (header parsed, data read at its offset);
- :class:`TextRecord`: delimited text parsed a block of lines at a time.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite._deprecation import renamed
from allanite.errors import InputError
from allanite.variance.checks import prepare_record

__all__ = [
    "ArrayRecord",
    "BinaryRecord",
    "ChunkedRecord",
    "TextRecord",
    "as_chunked",
    "npy_record",
    "open_large",
]

#: sample types the compiled phase kernel reads directly
SAMPLE_DTYPES: tuple[str, ...] = ("float64", "float32", "int16", "int32", "int64")
_TEXT_SUFFIXES = (".csv", ".txt", ".tsv", ".dat")
_BINARY_SUFFIXES = (".bin", ".raw", ".f32", ".f64", ".i16", ".i32")


@runtime_checkable
class ChunkedRecord(Protocol):
    """What the out-of-core path needs from a record: channels, dtype and ordered chunks."""

    @property
    def n_channels(self) -> int:
        """Number of channels (columns)."""
        ...

    @property
    def dtype(self) -> np.dtype[Any]:
        """Native-endian sample type of the chunks."""
        ...

    @property
    def n_samples(self) -> int | None:
        """Number of samples, or None when unknown before a full pass (text)."""
        ...

    def chunks(self, rows: int) -> Iterator[NDArray[Any]]:
        """Yield consecutive ``(<= rows, n_channels)`` blocks from the first sample to the last.

        A yielded block may be a reused buffer: use it before asking for the next one.
        """
        ...


def _check_rows(rows: int) -> int:
    if isinstance(rows, bool) or not isinstance(rows, (int, np.integer)) or rows < 1:
        raise ValueError(f"chunk rows must be a positive integer, got {rows!r}")
    return int(rows)


def _sample_dtype(dtype: Any) -> np.dtype[Any]:
    try:
        dt: np.dtype[Any] = np.dtype(dtype)
    except TypeError as exc:
        raise TypeError(
            f"dtype {dtype!r} is not a numpy dtype; use one of {SAMPLE_DTYPES}"
        ) from exc
    if dt.newbyteorder("=").name not in SAMPLE_DTYPES:
        raise TypeError(
            f"dtype {dt} is not supported for large records; use one of {SAMPLE_DTYPES}"
        )
    return dt


@dataclass(frozen=True)
class ArrayRecord:
    """An in-memory (or memory-mapped) record as a chunked record; chunks are views.

    Parameters
    ----------
    array : numpy.ndarray
        Samples, shape ``(N,)`` or ``(N, C)``, one of the supported dtypes in native order.
    """

    array: NDArray[Any]

    def __post_init__(self) -> None:
        arr = self.array
        if arr.ndim == 1:
            object.__setattr__(self, "array", arr.reshape(-1, 1))
        elif arr.ndim != 2:
            raise ValueError(
                f"record must be 1-D or 2-D (samples, channels), got shape {arr.shape}"
            )
        _sample_dtype(arr.dtype)
        if not arr.dtype.isnative:
            raise TypeError(
                "array has non-native byte order; convert it with "
                "arr.astype(arr.dtype.newbyteorder('='))"
            )

    @property
    def n_channels(self) -> int:
        """Number of channels."""
        return int(self.array.shape[1])

    @property
    def dtype(self) -> np.dtype[Any]:
        """Sample type."""
        return self.array.dtype

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.array.shape[0])

    def chunks(self, rows: int) -> Iterator[NDArray[Any]]:
        """Yield views of consecutive blocks of ``rows`` samples."""
        step = _check_rows(rows)
        for start in range(0, self.n_samples, step):
            yield self.array[start : start + step]


@dataclass(frozen=True)
class BinaryRecord:
    """Raw binary samples in a file, read in chunks with ``os.pread``.

    Parameters
    ----------
    path : path-like
        The file.
    dtype : str or numpy.dtype
        Sample type, e.g. ``"float32"``, ``"<i2"`` (one of float64, float32, int16, int32,
        int64).
    n_channels : int
        Number of channels (``channels=`` is its deprecated name).
    byteorder : {"<", ">", "=", "little", "big", "native"}, optional
        Byte order of the file; overrides any order in ``dtype``. Default: that of ``dtype``.
    offset : int
        Bytes to skip at the start (a header).
    layout : {"interleaved", "planar"}
        ``interleaved``: sample 0 of every channel, then sample 1 (row-major, the usual logger
        format); ``planar``: all samples of channel 0, then channel 1 (column-major).

    Raises
    ------
    InputError
        If the file is missing or its data length is not a whole number of samples.
    """

    path: Path
    dtype_in_file: np.dtype[Any]
    channels: int
    offset: int
    layout: Literal["interleaved", "planar"]
    n_samples: int

    @classmethod
    def open(
        cls,
        path: str | os.PathLike[str],
        dtype: Any,
        *,
        n_channels: int = 1,
        byteorder: str | None = None,
        offset: int = 0,
        layout: Literal["interleaved", "planar"] = "interleaved",
        channels: int | None = None,
    ) -> BinaryRecord:
        """Describe a raw file; validates its size against dtype, channels and offset."""
        channels = renamed(n_channels, channels, new="n_channels", old="channels", default=1)
        p = Path(path)
        dt = _sample_dtype(dtype)
        if byteorder is not None:
            orders = {"<": "<", "little": "<", ">": ">", "big": ">", "=": "=", "native": "="}
            if byteorder not in orders:
                raise ValueError(
                    f"byteorder must be '<', '>', '=' (or little/big/native), got {byteorder!r}"
                )
            dt = dt.newbyteorder(orders[byteorder])  # type: ignore[arg-type]
        if (
            isinstance(channels, bool)
            or not isinstance(channels, (int, np.integer))
            or channels < 1
        ):
            raise ValueError(f"n_channels must be a positive integer, got {channels!r}")
        if isinstance(offset, bool) or not isinstance(offset, (int, np.integer)) or offset < 0:
            raise ValueError(f"offset must be a non-negative number of bytes, got {offset!r}")
        if layout not in ("interleaved", "planar"):
            raise ValueError(f"layout must be 'interleaved' or 'planar', got {layout!r}")
        try:
            size = p.stat().st_size
        except FileNotFoundError as exc:
            raise InputError("file not found; check the path", path=str(p)) from exc
        data = size - int(offset)
        row = dt.itemsize * int(channels)
        if data < 0 or data % row:
            raise InputError(
                f"{data} data bytes after the {offset}-byte offset are not a whole number of "
                f"{channels}-channel {dt.name} samples ({row} bytes each); check dtype, channels "
                "and offset",
                path=str(p),
            )
        return cls(p, dt, int(channels), int(offset), layout, data // row)

    @property
    def n_channels(self) -> int:
        """Number of channels."""
        return self.channels

    @property
    def dtype(self) -> np.dtype[Any]:
        """Native-endian sample type of the chunks."""
        native: np.dtype[Any] = self.dtype_in_file.newbyteorder("=")
        return native

    def _read_into(self, fd: int, buf: NDArray[Any], byte_offset: int) -> None:
        view = memoryview(buf).cast("B")  # type: ignore[arg-type]
        done = 0
        while done < view.nbytes:
            got = os.preadv(fd, [view[done:]], byte_offset + done)
            if got == 0:
                raise InputError(
                    "file ended early (was it truncated while reading?)", path=str(self.path)
                )
            done += got

    def chunks(self, rows: int) -> Iterator[NDArray[Any]]:
        """Yield consecutive blocks of ``rows`` samples (a reused native-endian buffer)."""
        step = _check_rows(rows)
        c = self.channels
        item = self.dtype_in_file.itemsize
        buffer = np.empty((min(step, max(self.n_samples, 1)), c), dtype=self.dtype_in_file)
        planar = (
            np.empty(buffer.shape[0], dtype=self.dtype_in_file) if self.layout == "planar" else None
        )
        swap = not self.dtype_in_file.isnative
        fd = os.open(self.path, os.O_RDONLY)
        try:
            for start in range(0, self.n_samples, step):
                n = min(step, self.n_samples - start)
                block = buffer[:n]
                if planar is None:
                    self._read_into(fd, block, self.offset + start * c * item)
                else:
                    for ch in range(c):
                        self._read_into(
                            fd, planar[:n], self.offset + (ch * self.n_samples + start) * item
                        )
                        block[:, ch] = planar[:n]
                if swap:
                    yield block.byteswap().view(self.dtype)
                else:
                    yield block
        finally:
            os.close(fd)


def npy_record(path: str | os.PathLike[str]) -> BinaryRecord:
    """Open a ``.npy`` file as a :class:`BinaryRecord` (header parsed, data read in chunks).

    Parameters
    ----------
    path : path-like
        ``.npy`` file holding a 1-D ``(N,)`` or 2-D ``(N, C)`` array of a supported dtype, in C
        or Fortran order.
    """
    p = Path(path)
    try:
        with p.open("rb") as handle:
            version = np.lib.format.read_magic(handle)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(handle)
            else:
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(handle)
            offset = handle.tell()
    except FileNotFoundError as exc:
        raise InputError("file not found; check the path", path=str(p)) from exc
    except ValueError as exc:
        raise InputError(f"not a valid .npy file ({exc})", path=str(p)) from exc
    if len(shape) not in (1, 2):
        raise InputError(
            f"array has shape {shape}; need (samples,) or (samples, channels)", path=str(p)
        )
    channels = 1 if len(shape) == 1 else int(shape[1])
    layout: Literal["interleaved", "planar"] = (
        "planar" if fortran and channels > 1 else "interleaved"
    )
    rec = BinaryRecord.open(p, dtype, n_channels=channels, offset=offset, layout=layout)
    if rec.n_samples != shape[0]:
        raise InputError(
            f"header says {shape[0]} samples but the file holds {rec.n_samples}; the file is "
            "truncated or has trailing data",
            path=str(p),
        )
    return rec


@dataclass(frozen=True)
class TextRecord:
    """Delimited text read ``rows`` lines at a time (the sample count is found by reading).

    Parameters
    ----------
    path : path-like
        Text file, one sample per line.
    delimiter : str, optional
        Column separator; default: any whitespace (commas are accepted too, see below).
    columns : sequence of int, optional
        Zero-based columns holding the channels (e.g. ``(1, 2, 3)`` to skip a time column).
        Default: every column.
    skiprows : int
        Lines to skip at the top (a header).
    comments : str
        Lines starting with this are ignored.
    """

    path: Path
    delimiter: str | None = None
    columns: tuple[int, ...] | None = None
    skiprows: int = 0
    comments: str = "#"

    @classmethod
    def open(
        cls,
        path: str | os.PathLike[str],
        *,
        delimiter: str | None = None,
        columns: Sequence[int] | None = None,
        skiprows: int = 0,
        comments: str = "#",
    ) -> TextRecord:
        """Describe a text file; reads its first data line to learn the channel count."""
        p = Path(path)
        if not p.is_file():
            raise InputError("file not found; check the path", path=str(p))
        if delimiter is None and p.suffix.lower() == ".csv":
            delimiter = ","
        cols = None if columns is None else tuple(int(c) for c in columns)
        rec = cls(p, delimiter, cols, int(skiprows), comments)
        rec._first_row()  # validates early
        return rec

    def _lines(self) -> Iterator[tuple[int, str]]:
        with self.path.open("r", encoding="utf-8", errors="strict") as handle:
            for number, line in enumerate(handle, start=1):
                if number <= self.skiprows:
                    continue
                stripped = line.strip()
                if not stripped or stripped.startswith(self.comments):
                    continue
                yield number, stripped

    def _parse(self, lines: list[tuple[int, str]]) -> NDArray[np.float64]:
        try:
            block = np.loadtxt(
                [text for _, text in lines],
                delimiter=self.delimiter,
                usecols=self.columns,
                ndmin=2,
                dtype=np.float64,
            )
        except ValueError as exc:
            for number, text in lines:  # find the offending line for the message
                try:
                    np.loadtxt([text], delimiter=self.delimiter, usecols=self.columns, ndmin=2)
                except ValueError:
                    raise InputError(
                        f"cannot parse {text[:60]!r} as numbers ({exc}); check delimiter, "
                        "columns and skiprows",
                        path=str(self.path),
                        line=number,
                    ) from exc
            raise InputError(f"cannot parse the text ({exc})", path=str(self.path)) from exc
        return block

    def _first_row(self) -> NDArray[np.float64]:
        first = next(self._lines(), None)
        if first is None:
            raise InputError("no data lines; check skiprows and comments", path=str(self.path))
        return self._parse([first])

    @property
    def n_channels(self) -> int:
        """Number of channels (columns read)."""
        return int(self._first_row().shape[1])

    @property
    def dtype(self) -> np.dtype[Any]:
        """Text is parsed as float64."""
        return np.dtype(np.float64)

    @property
    def n_samples(self) -> int | None:
        """Unknown until a full pass: None."""
        return None

    def chunks(self, rows: int) -> Iterator[NDArray[Any]]:
        """Yield float64 blocks of up to ``rows`` parsed lines."""
        step = _check_rows(rows)
        lines = self._lines()
        width: int | None = None
        while True:
            batch = list(itertools.islice(lines, step))
            if not batch:
                return
            block = self._parse(batch)
            if width is None:
                width = block.shape[1]
            elif block.shape[1] != width:
                raise InputError(
                    f"rows have {block.shape[1]} columns, earlier rows {width}", path=str(self.path)
                )
            yield block


def as_chunked(source: ArrayLike | ChunkedRecord) -> ChunkedRecord:
    """Wrap an array as an :class:`ArrayRecord`; pass chunked records through unchanged."""
    if isinstance(source, (ArrayRecord, BinaryRecord, TextRecord)):
        return source
    if isinstance(source, ChunkedRecord) and not isinstance(source, np.ndarray):
        return source
    arr, _ = prepare_record(source)
    return ArrayRecord(arr)


def open_large(
    path: str | os.PathLike[str],
    *,
    dtype: Any = None,
    n_channels: int = 1,
    byteorder: str | None = None,
    offset: int = 0,
    layout: Literal["interleaved", "planar"] = "interleaved",
    delimiter: str | None = None,
    columns: Sequence[int] | None = None,
    skiprows: int = 0,
    channels: int | None = None,
) -> ChunkedRecord:
    """Open a file as a chunked record, choosing the reader from the suffix.

    ``.npy`` -> :func:`npy_record`; text suffixes (``.csv .txt .tsv .dat``) -> :class:`TextRecord`
    unless ``dtype`` is given; anything else, or any file with ``dtype`` -> :class:`BinaryRecord`.

    Parameters
    ----------
    path : path-like
        The file.
    dtype, n_channels, byteorder, offset, layout
        Raw binary description (see :class:`BinaryRecord`); ``dtype`` is required for raw files.
        ``channels=`` is the deprecated name of ``n_channels``.
    delimiter, columns, skiprows
        Text description (see :class:`TextRecord`).
    """
    n_channels = renamed(n_channels, channels, new="n_channels", old="channels", default=1)
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix == ".npy":
        return npy_record(p)
    if dtype is None:
        if suffix in _TEXT_SUFFIXES:
            return TextRecord.open(p, delimiter=delimiter, columns=columns, skiprows=skiprows)
        raise ValueError(
            f"{p}: raw binary needs dtype= (e.g. 'float32'), n_channels= and byteorder=; "
            f"or use .npy or a text file ({', '.join(_TEXT_SUFFIXES)})"
        )
    return BinaryRecord.open(
        p, dtype, n_channels=n_channels, byteorder=byteorder, offset=offset, layout=layout
    )
