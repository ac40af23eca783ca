"""Atomic output files: written to a temporary sibling and renamed only on success."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_output"]


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str], suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it to ``path`` only if the block succeeds.

    If the block raises, the temporary file is removed and ``path`` is left untouched, so a
    failed run never leaves a half-written output behind.

    Parameters
    ----------
    path : path-like
        Final output path.
    suffix : str, optional
        Suffix of the temporary file (defaults to that of ``path``, so writers that look at
        the extension, like ``numpy.save``, behave the same).
    """
    final = Path(path)
    directory = final.parent if str(final.parent) else Path(".")
    if not directory.is_dir():
        raise OSError(
            f"cannot write {final}: directory {directory} does not exist; create it first"
        )
    fd, tmp_name = tempfile.mkstemp(
        prefix=f".{final.name}.",
        suffix=suffix if suffix is not None else final.suffix,
        dir=directory,
    )
    os.close(fd)
    tmp = Path(tmp_name)
    # mkstemp creates 0600; give the output the mode an ordinary file (or the one it replaces) has
    os.chmod(tmp, final.stat().st_mode & 0o777 if final.exists() else 0o644)
    try:
        yield tmp
        os.replace(tmp, final)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise
