"""Exceptions with messages that name the problem and the fix."""

from __future__ import annotations

from typing import Any

__all__ = [
    "FS_RANGE",
    "ImplausibleInputWarning",
    "InputError",
    "MissingExtraError",
    "RecordTooShortError",
    "bounded",
    "check_fs_range",
    "choose_one",
    "parse_json",
]

#: sampling frequencies (Hz) the arithmetic supports: 1/fs, fs*tau and the variances of a
#: record stay far from float64 overflow and underflow (a subnormal 1e-320 Hz gave NaN/inf
#: samples, 1e-300 an OverflowError); gyros sample between about 1 Hz and 100 kHz, and a time
#: column in ns read as seconds gives 1e-7 Hz, which must reach the time-scale note
FS_RANGE = (1e-12, 1e12)


def check_fs_range(value: float) -> float:
    """``value`` (a positive finite fs in Hz) if inside :data:`FS_RANGE`, else a ValueError."""
    low, high = FS_RANGE
    if not low <= value <= high:
        raise ValueError(
            f"fs = {value:.6g} Hz is outside the range allanite computes with ({low:g} to "
            f"{high:g} Hz); give the sampling frequency in Hz (not a period in seconds)"
        )
    return value


#: characters of a message kept: a message never echoes unbounded input (a 3e6-column header
#: listed in full was a 35 MB error line)
MESSAGE_LIMIT = 2000


def bounded(message: str, limit: int = MESSAGE_LIMIT) -> str:
    """``message`` cut in the middle to at most about ``limit`` characters (head and tail kept)."""
    if len(message) <= limit:
        return message
    half = limit // 2
    return f"{message[:half]} ... ({len(message) - 2 * half} characters cut) ... {message[-half:]}"


def parse_json(text: str, what: str) -> Any:
    """``json.loads(text)``; nesting deeper than Python's recursion limit is a ValueError.

    A model or config is a few levels deep; JSON nested 100,000 deep (a few hundred kB) is
    damaged or hostile and ended in a RecursionError traceback. Syntax errors are left to
    the caller (``json.JSONDecodeError``, a ValueError) to word with its line and column.
    """
    import json

    try:
        return json.loads(text)
    except RecursionError:
        raise ValueError(
            f"{what} is nested too deeply to be read (thousands of levels; a model or config "
            "is a few levels deep): the file is damaged or not what it should be"
        ) from None


class InputError(ValueError):
    """A file or record the user supplied cannot be used as it is.

    The message names the file, the line or field, and what to do about it; the CLI prints it
    as a single line and exits with code 2.
    """

    def __init__(self, message: str, *, path: str | None = None, line: int | None = None) -> None:
        where = ""
        if path is not None:
            where = f"{path}"
            if line is not None:
                where += f", line {line}"
            where += ": "
        super().__init__(where + bounded(message))
        self.path = path
        self.line = line


class RecordTooShortError(ValueError):
    """A record too short for an automatic fit (too few usable taus to choose the terms).

    ``reason`` says what is short; the message adds the fix from the Python API (name the
    terms). The CLI, which chooses the terms itself, gives its own fix after ``reason``.
    """

    def __init__(self, reason: str, fix: str) -> None:
        super().__init__(f"{reason}; {fix}")
        self.reason = reason


class ImplausibleInputWarning(UserWarning):
    """A record or its fitted coefficients look like a mistaken input (e.g. a wrong unit).

    Issued by the library (:func:`allanite.fit`) for the findings of
    :mod:`allanite.plausibility`; the CLI prints the same findings as
    ``allanite COMMAND: warning: ...``. Silence it with
    ``warnings.simplefilter("ignore", ImplausibleInputWarning)``.
    """


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message names the extra that installs it.

    Raised by :func:`allanite.extras.require`; the CLI prints it as one line and exits with
    code 2.
    """

    def __init__(self, message: str, *, extra: str) -> None:
        super().__init__(message)
        self.extra = extra


def choose_one(
    given: str | None, available: list[str], *, what: str, option: str, path: str
) -> str:
    """The one of ``available`` the user asked for, or the only one there is.

    Used where a file holds several items (arrays of an .npz, IMU topics of a bag).

    Parameters
    ----------
    given : str or None
        The user's choice (None: take the only item).
    available : list of str
        The items the file holds (at least one).
    what : str
        Their name in messages: ``"array"``, ``"IMU topic"``.
    option : str
        How to choose: ``"key= (CLI: --key NAME)"``.
    path : str
        The file, for the message.

    Raises
    ------
    InputError
        If ``given`` is None and there are several items, or ``given`` is not among them.
    """
    if given is None:
        if len(available) > 1:
            raise InputError(
                f"the file holds several {what}s ({', '.join(available)}); choose one with "
                f"{option}",
                path=path,
            )
        return available[0]
    if given not in available:
        raise InputError(
            f"no {what} {given!r} in the file; available: {', '.join(available)}", path=path
        )
    return given
