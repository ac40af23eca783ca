"""Exceptions with messages that name the problem and the fix."""

from __future__ import annotations

__all__ = ["InputError", "MissingExtraError"]


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
        super().__init__(where + message)
        self.path = path
        self.line = line


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message names the extra that installs it.

    Raised by :func:`allanite.extras.require`; the CLI prints it as one line and exits with
    code 2.
    """

    def __init__(self, message: str, *, extra: str) -> None:
        super().__init__(message)
        self.extra = extra
