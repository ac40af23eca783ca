"""Atomic output files: written to a temporary sibling and renamed only on success."""

from __future__ import annotations

import contextlib
import errno
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
    if final.is_dir():
        raise OSError(
            f"cannot write {final}: it is a directory; give a file name, e.g. "
            f"{final / ('output' + (suffix or final.suffix))}"
        )
    if not directory.is_dir():
        raise OSError(
            f"cannot write {final}: directory {directory} does not exist; create it first"
        )
    try:
        fd, tmp_name = tempfile.mkstemp(
            prefix=f".{final.name}.",
            suffix=suffix if suffix is not None else final.suffix,
            dir=directory,
        )
    except OSError as exc:
        raise OSError(f"cannot write {final}: {_reason(exc, directory)}") from exc
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        # mkstemp creates 0600; give the output the mode an ordinary file (or the one it
        # replaces) has
        os.chmod(tmp, final.stat().st_mode & 0o777 if final.exists() else 0o644)
        yield tmp
        os.replace(tmp, final)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        if isinstance(exc, OSError) and _mentions(exc, tmp):
            # a write error of the temporary file: name the output, not the temporary
            raise OSError(f"cannot write {final}: {_reason(exc, directory)}") from exc
        raise


#: errno -> what it means for an output file, in words
_REASONS = {
    errno.EACCES: "no permission to write in {directory}",
    errno.EPERM: "no permission to write in {directory}",
    errno.EROFS: "{directory} is on a read-only file system",
    errno.ENOSPC: "no space left on the device of {directory}",
    errno.EDQUOT: "the disk quota of {directory} is exhausted",
    errno.EISDIR: "it is a directory; give a file name",
    errno.ENAMETOOLONG: "the file name is too long",
    errno.EFBIG: "the file is too large for the file system",
}


def _reason(exc: OSError, directory: Path) -> str:
    """Why an output could not be written, in words (no errno number, no temporary name)."""
    text = _REASONS.get(exc.errno or -1)
    if text is not None:
        return text.format(directory=directory)
    return (exc.strerror or str(exc)).lower()


#: errors of writing data (file.write carries no file name): the output's, inside the block
_CAPACITY = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


def _mentions(exc: OSError, tmp: Path) -> bool:
    """Whether an error is about the temporary file (its message would show the temp name)."""
    if str(tmp) in {str(exc.filename), str(exc.filename2)} or tmp.name in str(exc):
        return True
    return exc.filename is None and exc.errno in _CAPACITY
