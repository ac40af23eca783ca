"""Renamed keywords: the old name keeps working for a while, with a DeprecationWarning."""

from __future__ import annotations

import warnings
from typing import TypeVar

__all__ = ["renamed"]

T = TypeVar("T")


def renamed(
    new_value: T,
    old_value: T | None,
    *,
    new: str,
    old: str,
    default: T,
    why: str = "a count; 'channels' now always means channel names",
) -> T:
    """The value of a keyword renamed from ``old`` to ``new``.

    Parameters
    ----------
    new_value, old_value
        What the caller passed under each name (``old_value`` None when not given).
    new, old : str
        The two names, for the messages.
    default
        The default of ``new``: giving ``old`` together with a non-default ``new`` is an error.
    why : str
        Why the name changed, for the warning.

    Returns
    -------
    object
        ``old_value`` (with a :class:`DeprecationWarning`) when given, else ``new_value``.

    Raises
    ------
    TypeError
        When both names are given.
    """
    if old_value is None:
        return new_value
    if new_value != default:
        raise TypeError(f"give {new}= only ({old}= is its old name)")
    warnings.warn(
        f"{old}= is renamed {new}= ({why}); write {new}={old_value!r}",
        DeprecationWarning,
        stacklevel=3,
    )
    return old_value
