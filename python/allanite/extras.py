"""Optional dependencies: import one lazily or say, in one line, which extra installs it.

Every optional import of the package goes through :func:`require`, so a missing dependency is
always the same :class:`~allanite.errors.MissingExtraError` (an :class:`ImportError`) whose
message names the extra, e.g. ``reading HDF5 needs h5py: pip install "allanite[hdf5]"``; the
command line prints it as one line and exits with code 2.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from allanite.errors import MissingExtraError

__all__ = ["install_hint", "require"]


def install_hint(extra: str) -> str:
    """The pip command that installs ``extra`` (double quotes work in every shell)."""
    return f'pip install "allanite[{extra}]"'


def require(module: str, *, extra: str, purpose: str, package: str | None = None) -> ModuleType:
    """Import ``module`` or raise :class:`MissingExtraError` naming ``extra``.

    Parameters
    ----------
    module : str
        Dotted module name, e.g. ``"h5py"`` or ``"matplotlib.figure"``.
    extra : str
        The allanite extra that provides it (``hdf5``, ``parquet``, ``plot``, ``gui``,
        ``dask``, ``progress``, ``pandas``, ``yaml``).
    purpose : str
        What needs it, as the start of a sentence: ``"reading HDF5"``.
    package : str, optional
        The distribution name when it differs from the module's (``pyyaml`` for ``yaml``).

    Returns
    -------
    module
        The imported module.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        package = package or module.split(".", 1)[0]
        raise MissingExtraError(
            f"{purpose} needs {package}, which is not installed: {install_hint(extra)}",
            extra=extra,
        ) from exc
