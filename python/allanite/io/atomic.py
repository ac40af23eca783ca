"""Atomic output files: written to a temporary sibling and renamed only on success.

What sits at the output path is never destroyed by accident:

* a symbolic link is followed (its target is written, the link stays);
* a character device, FIFO or socket is written through (opened and written, never replaced);
* ``-`` is standard output;
* an output that is one of the command's input files (same device and inode, also through a
  link) is refused while :func:`guard_inputs` is active (the command line keeps it active for
  every command);
* SIGTERM, like SIGINT, removes the temporary file before the process ends.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import signal
import stat
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = ["STDOUT", "atomic_output", "check_output_path", "guard_inputs", "note_input"]

#: the output name that means standard output
STDOUT = "-"

#: (device, inode) of the files read while a command runs; None outside :func:`guard_inputs`
_INPUTS: dict[tuple[int, int], str] | None = None


@contextlib.contextmanager
def guard_inputs() -> Iterator[None]:
    """Refuse, inside the block, an output that is a file read inside it (same inode)."""
    global _INPUTS
    previous, _INPUTS = _INPUTS, {}
    try:
        yield
    finally:
        _INPUTS = previous


def note_input(path: str | os.PathLike[str]) -> None:
    """Remember ``path`` as an input of the running command (see :func:`guard_inputs`)."""
    if _INPUTS is None:
        return
    with contextlib.suppress(OSError):
        info = os.stat(path)
        _INPUTS[(info.st_dev, info.st_ino)] = str(path)


def _resolved(final: Path) -> Path:
    """The output path with symbolic links followed (a loop or a dangling link explained)."""
    if not final.is_symlink():
        return final
    try:
        return Path(os.path.realpath(final, strict=True))
    except FileNotFoundError:
        # a dangling link: write its target, as the shell's `>` would
        return Path(os.path.realpath(final))
    except OSError as exc:
        if exc.errno == errno.ELOOP or "loop" in str(exc).lower():
            raise OSError(f"cannot write {final}: it is a symbolic link loop") from exc
        raise OSError(f"cannot write {final}: {_reason(exc, final.parent)}") from exc


def check_output_path(path: str | os.PathLike[str], suffix: str | None = None) -> None:
    """Raise :class:`OSError` (a message with the fix) if ``path`` cannot be an output.

    The checks :func:`atomic_output` makes before writing, for commands that want to refuse a
    bad output before a long computation: a directory, a missing directory, an input file, a
    read-only existing file, a symbolic link loop.
    """
    if str(path) == STDOUT:
        return
    given = Path(path)
    final = _resolved(given)
    _check_not_input(given, final)
    if final.is_dir():
        raise OSError(
            f"cannot write {given}: it is a directory; give a file name, e.g. "
            f"{given / ('output' + (suffix or final.suffix))}"
        )
    directory = final.parent if str(final.parent) else Path(".")
    if _special(final):
        if not os.access(final, os.W_OK):
            raise OSError(f"cannot write {given}: no permission to write to it")
        return
    if not directory.is_dir():
        raise OSError(
            f"cannot write {given}: directory {directory} does not exist; create it first"
        )
    if final.exists() and not os.access(final, os.W_OK) and os.geteuid() != 0:
        raise OSError(
            f"cannot write {given}: the file is read-only (no write permission); "
            "make it writable (chmod u+w) or choose another name"
        )
    if not os.access(directory, os.W_OK | os.X_OK):
        raise OSError(f"cannot write {given}: no permission to write in {directory}")


def input_source(path: str | os.PathLike[str]) -> str | None:
    """The input of the running command that ``path`` names (same device and inode), if any.

    Symbolic links are followed; None outside :func:`guard_inputs` or for a new file.
    """
    if not _INPUTS:
        return None
    try:
        info = os.stat(_resolved(Path(path)))
    except OSError:
        return None
    return _INPUTS.get((info.st_dev, info.st_ino))


def _check_not_input(given: Path, final: Path) -> None:
    """Refuse an output that is one of the command's inputs (same device and inode)."""
    source = input_source(final)
    if source is not None:
        raise OSError(
            f"cannot write {given}: it is the input file {source}; writing it would destroy "
            "the input; give another output name"
        )


def _special(final: Path) -> bool:
    """Whether ``final`` exists and is not a regular file (a device, FIFO or socket)."""
    try:
        mode = os.stat(final).st_mode
    except OSError:
        return False
    return not stat.S_ISREG(mode) and not stat.S_ISDIR(mode)


@contextlib.contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """Inside the block, SIGTERM ends the process through Python (so cleanups run).

    Only in the main thread and only where SIGTERM has its default action (a handler the
    program installed itself is left alone). The process then exits with 128 + 15.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    try:
        previous = signal.getsignal(signal.SIGTERM)
    except (ValueError, OSError):  # pragma: no cover - no signals here
        yield
        return
    if previous is not signal.SIG_DFL:
        yield
        return

    def terminate(signum: int, frame: Any) -> None:
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str], suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it to ``path`` only if the block succeeds.

    If the block raises (or the process gets SIGINT or SIGTERM), the temporary file is removed
    and ``path`` is left untouched, so a failed run never leaves a half-written output behind.
    A symbolic link is followed (its target is replaced, the link kept); a device, FIFO or
    socket is written through once the block succeeds; ``-`` writes to standard output.

    Parameters
    ----------
    path : path-like
        Final output path, or ``-`` for standard output.
    suffix : str, optional
        Suffix of the temporary file (defaults to that of ``path``, so writers that look at
        the extension, like ``numpy.save``, behave the same).
    """
    check_output_path(path, suffix)
    given = Path(path)
    through = str(path) == STDOUT or _special(_resolved(given))
    final = given if through else _resolved(given)
    directory = final.parent if str(final.parent) else Path(".")
    if through:  # the temporary file goes to the temporary directory, never beside a device
        directory = Path(tempfile.gettempdir())
    with _terminate_as_interrupt():
        try:
            fd, tmp_name = tempfile.mkstemp(
                prefix=f".{final.name if not through else 'allanite'}.",
                suffix=suffix if suffix is not None else final.suffix,
                dir=directory,
            )
        except OSError as exc:
            raise OSError(f"cannot write {given}: {_reason(exc, directory)}") from exc
        os.close(fd)
        tmp = Path(tmp_name)
        try:
            # mkstemp creates 0600; give the output the mode an ordinary file (or the one it
            # replaces) has
            os.chmod(tmp, final.stat().st_mode & 0o777 if final.exists() and not through else 0o644)
            yield tmp
            if through:
                _write_through(tmp, given)
                tmp.unlink()
            else:
                os.replace(tmp, final)
        except BaseException as exc:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
            if isinstance(exc, OSError) and _mentions(exc, tmp):
                # a write error of the temporary file: name the output, not the temporary
                raise OSError(f"cannot write {given}: {_reason(exc, directory)}") from exc
            raise


def _write_through(tmp: Path, given: Path) -> None:
    """Copy the finished temporary file to standard output or into a device/FIFO."""
    with open(tmp, "rb") as source:
        if str(given) == STDOUT:
            sys.stdout.flush()
            shutil.copyfileobj(source, sys.stdout.buffer)
            sys.stdout.buffer.flush()
            return
        try:
            with open(given, "wb") as target:
                shutil.copyfileobj(source, target)
        except OSError as exc:
            raise OSError(f"cannot write {given}: {_reason(exc, given.parent)}") from exc


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
