"""Write a simulated record to .npy, .csv or raw binary chunk by chunk (bounded memory).

The file is written through :func:`allanite.io.atomic.atomic_output`: a failed or interrupted
run never leaves a partial file. ``.npy`` gets its header first (the shape is known in
advance) and then the raw little-endian float64 rows; ``.csv`` one row per sample with
``%.17g``; ``.bin``/``.raw``/``.f64`` bare little-endian float64 rows (samples x channels).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite._deprecation import keyword_only_fs, renamed
from allanite.io.atomic import atomic_output
from allanite.simulation.record import record_length, simulate_chunks

__all__ = [
    "FORMATS",
    "check_free_space",
    "format_of",
    "format_size",
    "output_size",
    "write_chunks",
    "write_record",
]

#: file suffix -> format name
FORMATS = {".npy": "npy", ".csv": "csv", ".bin": "raw", ".raw": "raw", ".f64": "raw"}


def format_of(path: str | os.PathLike[str]) -> str:
    """Return the output format (npy, csv, raw) chosen by the file suffix."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(
            f"cannot tell the output format of {os.fspath(path)!r}; use a .npy, .csv or "
            ".bin/.raw/.f64 (raw float64) file name"
        )
    return FORMATS[suffix]


#: bytes per value of a CSV row at most: '%.17g' (up to 24 characters) and a separator
CSV_BYTES_PER_VALUE = 25


def output_size(path: str | os.PathLike[str], n_samples: int, n_channels: int) -> int:
    """Size in bytes of the file :func:`write_chunks` writes.

    Exact for .npy and raw binary, an upper bound for CSV.
    """
    kind = format_of(path)
    values = n_samples * n_channels
    if kind == "csv":
        return values * CSV_BYTES_PER_VALUE + 64 * n_channels
    if kind == "npy":
        return values * 8 + 128  # the format pads the header to a multiple of 64 bytes
    return values * 8


def format_size(size: float) -> str:
    """Bytes in words: ``2.9 MB``, ``8.0 TB`` (decimal units, as disk sizes are quoted)."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(size) < 1000 or unit == "TB":
            return f"{size:.0f} {unit}" if unit == "B" else f"{size:.3g} {unit}"
        size /= 1000
    raise AssertionError("unreachable")  # pragma: no cover


def check_free_space(path: str | os.PathLike[str], size: int) -> None:
    """Raise an OSError before writing when ``size`` bytes do not fit beside ``path``.

    The output is written to a temporary sibling and renamed, so the free space of its
    directory is what counts (an existing file of that name is only replaced at the end).
    """
    import shutil

    directory = Path(path).parent if str(Path(path).parent) else Path(".")
    if not directory.is_dir():
        return  # atomic_output names the missing directory
    free = shutil.disk_usage(directory).free
    if size > free:
        raise OSError(
            f"cannot write {os.fspath(path)}: the record needs {format_size(size)} but "
            f"{directory} has {format_size(free)} free; write fewer samples (-n, --duration) "
            "or choose another disk"
        )


def write_chunks(
    path: str | os.PathLike[str],
    chunks: Iterable[NDArray[np.float64]],
    n_samples: int,
    n_channels: int,
    *,
    header: str | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> Path:
    """Write ``chunks`` (arrays of shape ``(k, n_channels)``) as one record of ``n_samples``.

    Parameters
    ----------
    path : path-like
        Output file; the suffix picks the format (see :data:`FORMATS`).
    chunks : iterable of numpy.ndarray
        The record in pieces, in order.
    n_samples, n_channels : int
        Final shape (written into the .npy header before the data).
    header : str, optional
        Column header line for CSV.
    progress : callable, optional
        ``progress("simulate", samples_written, n_samples)`` after each chunk (the library's
        progress protocol, see :mod:`allanite.cli.progress`).

    Returns
    -------
    pathlib.Path
        The written file.
    """
    kind = format_of(path)
    shape = (n_samples,) if n_channels == 1 else (n_samples, n_channels)
    written = 0
    with atomic_output(path) as tmp, open(tmp, "wb") as handle:
        if kind == "npy":
            np.lib.format.write_array_header_1_0(
                handle, {"descr": "<f8", "fortran_order": False, "shape": shape}
            )
        elif kind == "csv" and header:
            handle.write((header + "\n").encode())
        for chunk in chunks:
            block = np.ascontiguousarray(chunk, dtype="<f8")
            if kind == "csv":
                np.savetxt(handle, block, delimiter=",", fmt="%.17g")
            else:
                handle.write(block.tobytes())
            written += block.shape[0]
            if progress is not None:
                progress("simulate", written, n_samples)
        if written != n_samples:
            raise ValueError(f"expected {n_samples} samples, got {written}")
    return Path(path)


@keyword_only_fs
def write_record(
    path: str | os.PathLike[str],
    model: Any,
    n: int | None = None,
    *,
    fs: float,
    duration: str | float | None = None,
    output: str = "rate",
    n_channels: int = 1,
    seed: Any = None,
    allow_aliasing: bool = False,
    flicker_method: str = "auto",
    units: str = "rate",
    progress: Callable[[str, int, int], None] | None = None,
    channels: int | None = None,
) -> Path:
    """Simulate a record from ``model`` straight into a file, in bounded memory.

    Parameters as in :func:`allanite.simulation.simulate`; ``path`` picks the format
    (:data:`FORMATS`), ``units`` labels the CSV columns, ``progress("simulate", done, total)``
    is called after each written chunk. The file appears only when complete; an output that
    would not fit on its disk (:func:`output_size`, :func:`check_free_space`) is refused
    before anything is simulated.
    """
    format_of(path)  # fail on a bad suffix before any work
    n_channels = renamed(n_channels, channels, new="n_channels", old="channels", default=1)
    total = record_length(n, duration, fs=fs)
    if (
        isinstance(n_channels, bool)
        or not isinstance(n_channels, (int, np.integer))
        or n_channels < 1
    ):
        raise ValueError(f"n_channels must be a positive integer, got {n_channels!r}")
    check_free_space(path, output_size(path, total, int(n_channels)))
    chunks = simulate_chunks(
        model,
        total,
        fs=fs,
        output=output,  # type: ignore[arg-type]
        n_channels=n_channels,
        seed=seed,
        allow_aliasing=allow_aliasing,
        flicker_method=flicker_method,
    )
    names = ",".join(f"{output}_{c}[{units}]" for c in range(n_channels))
    return write_chunks(path, chunks, total, n_channels, header=names, progress=progress)
