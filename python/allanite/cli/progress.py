"""Progress bars of the command line: one tqdm bar per stage on stderr, on a terminal only.

One helper for every subcommand. :func:`progress_bars` yields the ``progress(stage, done,
total)`` callback that the library's long-running functions accept
(:func:`allanite.variance.outofcore.avar_large`, :func:`allanite.batch`); :func:`progress` wraps an
iterable with the same bars for loops in the CLI itself. When stderr is not a terminal nothing
is drawn; without tqdm (the ``progress`` extra) nothing is drawn either, unless bars were asked
for explicitly, which is an error naming the extra.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Iterator, Sized
from contextlib import contextmanager
from typing import Any, TypeVar

from allanite.extras import require

__all__ = ["ProgressCallback", "progress", "progress_bars"]

T = TypeVar("T")

#: ``progress(stage, done, total)``
ProgressCallback = Callable[[str, int, int], None]


def _tqdm(enabled: bool | None) -> Any:
    """The tqdm class when bars are wanted, else None.

    Asked for explicitly (``enabled=True``, e.g. ``--progress``) without tqdm installed is a
    :class:`~allanite.errors.MissingExtraError`; by default (a terminal) no bar is drawn.
    """
    if not (sys.stderr.isatty() if enabled is None else enabled):
        return None
    if enabled:
        return require("tqdm", extra="progress", purpose="--progress").tqdm
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm


@contextmanager
def progress_bars(enabled: bool | None = None) -> Iterator[ProgressCallback]:
    """Yield a ``progress(stage, done, total)`` callback drawing one tqdm bar per stage.

    A new stage closes the previous stage's bar; every bar is closed (and cleared,
    ``leave=False``) on exit.

    Parameters
    ----------
    enabled : bool, optional
        Draw the bars; default (None): when stderr is a terminal. Without tqdm the callback
        does nothing.
    """
    tqdm = _tqdm(enabled)
    bars: dict[str, Any] = {}

    def callback(stage: str, done: int, total: int) -> None:
        if tqdm is None:
            return
        bar = bars.get(stage)
        if bar is None:
            for other in bars.values():
                other.close()
            bars.clear()
            bar = bars[stage] = tqdm(total=total, desc=stage, file=sys.stderr, leave=False)
        bar.total = total
        bar.update(done - bar.n)

    try:
        yield callback
    finally:
        for bar in bars.values():
            bar.close()


def progress(
    items: Iterable[T], *, desc: str, total: int | None = None, enabled: bool | None = None
) -> Iterator[T]:
    """Iterate over ``items`` with a progress bar named ``desc`` (see :func:`progress_bars`).

    ``total`` defaults to ``len(items)`` when items has a length.
    """
    if total is None and isinstance(items, Sized):
        total = len(items)
    with progress_bars(enabled) as bar:
        bar(desc, 0, total or 0)
        for done, item in enumerate(items, start=1):
            yield item
            bar(desc, done, max(total or 0, done))
