"""API changes: renamed keywords and arguments that became keyword-only.

A renamed keyword keeps working for a while, with a DeprecationWarning; an argument that
became keyword-only says so when given by position.
"""

from __future__ import annotations

import functools
import inspect
import warnings
from collections.abc import Callable
from typing import ParamSpec, TypeVar

__all__ = ["keyword_only_fs", "renamed"]

T = TypeVar("T")
P = ParamSpec("P")


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


def keyword_only_fs(func: Callable[P, T]) -> Callable[P, T]:
    """Decorate a public function whose ``fs`` became keyword-only.

    A call that gives more positional arguments than the function takes (the old
    ``simulate(model, n, 100.0)``) raises a :class:`TypeError` naming the fix,
    ``fs is keyword-only: simulate(model, n, fs=...)``, instead of Python's bare count of
    positional arguments. Correct calls pass straight through.
    """
    params = list(inspect.signature(func).parameters.values())
    positional = [p.name for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    method = bool(positional) and positional[0] == "self"
    shown = positional[1:] if method else positional
    owner = func.__qualname__.rsplit(".", 1)[0]
    name = f"{owner}.{func.__name__}" if method else func.__name__
    call = f"{name}(" + "".join(f"{p}, " for p in shown) + "fs=...)"

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> T:
        if len(args) > len(positional):
            given = len(args) - method
            raise TypeError(
                f"fs is keyword-only: {call}; {name}() takes {len(shown)} positional "
                f"argument(s) but {given} were given (the other options are keyword-only too)"
            )
        return func(*args, **kwargs)

    return wrapper
