"""Delimited text tables (whitespace, CSV, semicolon, tab), with or without a header line.

The fast path hands the whole file to :func:`numpy.loadtxt` (a C parser). Only when that fails
does a line-by-line scan run, to find the first bad line and field and say what to do about
it, so that a malformed file costs nothing extra when it is well formed.
"""

from __future__ import annotations

import gzip
import io
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from allanite.errors import InputError

__all__ = ["COMMENT_CHARS", "TextTable", "read_text_table"]

#: lines starting with one of these are comments (MATLAB ``%``, shell/Stable32 ``#``)
COMMENT_CHARS: tuple[str, ...] = ("#", "%")
_CANDIDATES: tuple[str, ...] = ("\t", ",", ";", "|")
_SNIFF_LINES = 20
_NAMES = {"\t": "tab", ",": "','", ";": "';'", "|": "'|'", None: "whitespace"}


@dataclass(frozen=True)
class TextTable:
    """Numbers of a text file: ``data`` is ``(rows, columns)`` float64.

    ``names`` holds the header fields (None without a header); ``line_of(row)`` gives the
    1-based file line of a data row, for messages. Columns of ISO 8601 date-times are read as
    seconds since their first value (``datetime_columns``), so they can be time columns.
    """

    data: NDArray[np.float64]
    names: tuple[str, ...] | None
    delimiter: str | None
    line_of: Callable[[int], int]
    datetime_columns: frozenset[int] = frozenset()


def _open(path: Path) -> IO[str]:
    if path.suffix == ".gz":
        return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8", errors="replace")
    return open(path, encoding="utf-8", errors="replace", newline=None)


def _is_comment(stripped: str) -> bool:
    return not stripped or stripped.startswith(COMMENT_CHARS)


def _content_lines(handle: IO[str]) -> Iterator[tuple[int, str]]:
    """(line number, stripped text) of every non-blank, non-comment line."""
    for number, line in enumerate(handle, start=1):
        stripped = line.strip()
        if not _is_comment(stripped):
            yield number, stripped


def _split(line: str, delimiter: str | None) -> list[str]:
    return [f.strip() for f in line.split(delimiter)]


def _is_number(field: str) -> bool:
    try:
        float(field)
    except ValueError:
        return False
    return True


def _sniff(lines: list[str]) -> str | None:
    """Find the delimiter that splits the first data line into several numbers.

    Later lines are not consulted: a ragged or broken row must be reported as such, not make
    the detection fall back to whitespace.
    """
    for cand in _CANDIDATES:
        first = _split(lines[0], cand)
        if len(first) > 1 and all(_is_number(f) or _as_datetime(f) is not None for f in first):
            return cand
    return None


def _looks_like(field: str) -> str | None:
    """Return the name of the delimiter a non-numeric field seems to contain, if any."""
    for cand in (*_CANDIDATES, None):
        parts = _split(field, cand)
        if len(parts) > 1 and all(_is_number(p) for p in parts if p):
            return _NAMES[cand]
    return None


def _as_datetime(field: str) -> np.datetime64 | None:
    """Parse an ISO 8601 date-time (``2024-05-01T12:00:00.010`` or with a space), else None."""
    text = field.strip().strip("\"'")
    if not re.fullmatch(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2}(\.\d*)?)?Z?", text):
        return None
    try:
        return np.datetime64(text.replace(" ", "T").rstrip("Z"), "ns")
    except ValueError:
        return None


def _seconds_since(origin: np.datetime64) -> Callable[[str], float]:
    def convert(field: str) -> float:
        stamp = _as_datetime(field)
        if stamp is None:
            raise ValueError(f"not an ISO date-time: {field!r}")
        return float((stamp - origin) / np.timedelta64(1, "ns")) * 1e-9

    return convert


def _diagnose(
    path: Path,
    delimiter: str | None,
    n_cols: int,
    first_data: int,
    datetime_columns: frozenset[int] = frozenset(),
) -> InputError:
    """Scan the file for the first line that numpy could not read and explain it."""
    shown = _NAMES.get(delimiter, repr(delimiter))
    with _open(path) as handle:
        for number, line in _content_lines(handle):
            if number < first_data:
                continue
            fields = _split(line, delimiter)
            for k, field in enumerate(fields, start=1):
                if k - 1 in datetime_columns:
                    if _as_datetime(field) is None:
                        return InputError(
                            f"field {k} is {field!r}, not an ISO date-time like the rows above; "
                            "correct or remove the row",
                            path=str(path),
                            line=number,
                        )
                    continue
                if _is_number(field):
                    continue
                other = _looks_like(field)
                if other is not None and other != shown:
                    fix = (
                        f"the fields look separated by {other}, not {shown}; give the right "
                        "delimiter (--delimiter) or leave it out to detect it"
                    )
                elif re.fullmatch(r"[-+]?\d+,\d+([eE][-+]?\d+)?", field):
                    fix = "decimal commas are not supported; convert them to points"
                else:
                    fix = "correct or remove the row (write nan only in unused columns)"
                return InputError(
                    f"field {k} is {field!r}, not a number; {fix}", path=str(path), line=number
                )
            if len(fields) != n_cols:
                return InputError(
                    f"{len(fields)} field(s) separated by {shown}, but the table has {n_cols} "
                    "columns; repair the row or check the delimiter",
                    path=str(path),
                    line=number,
                )
    return InputError("the numbers could not be read; check the format", path=str(path))


def _row_lines(path: Path, first_data: int) -> NDArray[np.int64]:
    with _open(path) as handle:
        return np.fromiter(
            (n for n, _ in _content_lines(handle) if n >= first_data), dtype=np.int64
        )


def read_text_table(
    path: str | Path,
    *,
    delimiter: str | None = None,
    header: bool | None = None,
) -> TextTable:
    """Read a delimited text table of numbers.

    Parameters
    ----------
    path : str or Path
        Text file, optionally gzip-compressed (``.gz``). Blank lines and lines starting with
        ``#`` or ``%`` are skipped.
    delimiter : str, optional
        Field separator; detected when omitted (tab, comma, semicolon, bar, else whitespace).
        ``" "`` or ``"whitespace"`` means any run of spaces/tabs.
    header : bool, optional
        Whether the first content line holds column names; detected when omitted (a first line
        with a non-numeric field is a header).

    Returns
    -------
    TextTable

    Raises
    ------
    InputError
        Empty file, non-numeric cell, wrong delimiter or ragged rows, naming the line and field.
    """
    path = Path(path)
    if delimiter in (" ", "whitespace", "space"):
        delimiter = None
    source = str(path)
    with _open(path) as handle:
        head: list[tuple[int, str]] = []
        for item in _content_lines(handle):
            head.append(item)
            if len(head) > _SNIFF_LINES:
                break
    if not head:
        raise InputError(
            "no data rows (the file is empty or holds only comments); check that the right "
            "file was given",
            path=source,
        )
    first_fields_delim = delimiter if delimiter is not None else _sniff([head[0][1]])
    first_fields = _split(head[0][1], first_fields_delim)
    if header is None:
        # a header has a field that is neither a number nor numbers with another delimiter
        header = any(not _is_number(f) and _looks_like(f) is None for f in first_fields)
    body = head[1:] if header else head
    if not body:
        raise InputError(
            "a header line but no data rows; check that the right file was given", path=source
        )
    detected = delimiter is None
    if delimiter is None:
        delimiter = _sniff([line for _, line in body])
    names: tuple[str, ...] | None = None
    first_data = body[0][0]
    first_row = _split(body[0][1], delimiter)
    if header:
        header_line = head[0][1]
        names = tuple(f.strip().strip("\"'") for f in _split(header_line, delimiter))
        if detected and len(first_row) == 1 and not any(c in header_line for c in _CANDIDATES if c):
            # one column: its name is the whole line, spaces included ("gyro [deg/s]")
            names = (header_line.strip().strip("\"'"),)
    n_cols = len(first_row)
    converters: dict[int | str, Callable[[str], Any]] = {}
    for k, field in enumerate(first_row):
        stamp = None if _is_number(field) else _as_datetime(field)
        if stamp is not None:
            converters[k] = _seconds_since(stamp)
    try:
        with _open(path) as handle:
            data = np.loadtxt(
                handle,
                dtype=np.float64,
                delimiter=delimiter,
                comments=COMMENT_CHARS,
                skiprows=first_data - 1,
                ndmin=2,
                converters=converters or None,
            )
    except ValueError as exc:
        raise _diagnose(
            path, delimiter, n_cols, first_data, frozenset(int(k) for k in converters)
        ) from exc
    if data.shape[0] == 0:
        raise InputError("no data rows; check that the right file was given", path=source)
    if names is not None and len(names) != data.shape[1]:
        raise InputError(
            f"the header names {len(names)} column(s) but the rows have {data.shape[1]}; "
            "repair the header or check the delimiter",
            path=source,
            line=head[0][0],
        )
    cache: dict[str, NDArray[np.int64]] = {}

    def line_of(row: int) -> int:
        if "lines" not in cache:
            cache["lines"] = _row_lines(path, first_data)
        return int(cache["lines"][row])

    return TextTable(
        data=data,
        names=names,
        delimiter=delimiter,
        line_of=line_of,
        datetime_columns=frozenset(int(k) for k in converters),
    )
