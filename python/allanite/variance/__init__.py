"""Allan-family variances: estimators, tau grids, EDF and noise identification, large records.

Modules, each importing only those above it in this list:

- :mod:`~allanite.variance.taus`: tau grids and averaging factors;
- :mod:`~allanite.variance.edf`: equivalent degrees of freedom and noise identification;
- :mod:`~allanite.variance.transfer`: the power transfer function of the overlapping AVAR;
- :mod:`~allanite.variance.checks`: validation of records, ``fs``, threads and ``alpha``;
- :mod:`~allanite.variance.fast`: strided sums at large averaging factors (fast mode);
- :mod:`~allanite.variance.kernel`: the in-memory variance passes (exact, progress, fast);
- :mod:`~allanite.variance.result`: :class:`AllanResult` and its assembly from kernel sums;
- :mod:`~allanite.variance.chunked`: records read in chunks (arrays, raw binary, ``.npy``, text);
- :mod:`~allanite.variance.phase_store`: the phase array in memory or in a temporary file;
- :mod:`~allanite.variance.outofcore`: :func:`avar_large`, the windowed pass over a phase file;
- :mod:`~allanite.variance.estimate`: :func:`avar` and the named deviations;
- :mod:`~allanite.variance.oracle`: the slow numpy oracle of every kernel (tests only).
"""

from __future__ import annotations

from allanite.variance.checks import INPUTS, KINDS, prepare_record
from allanite.variance.estimate import adev, avar, hdev, mdev, oadev, ohdev, tdev, totdev
from allanite.variance.outofcore import avar_large, parse_memory
from allanite.variance.result import AllanResult, assemble_result

__all__ = [
    "INPUTS",
    "KINDS",
    "AllanResult",
    "adev",
    "assemble_result",
    "avar",
    "avar_large",
    "hdev",
    "mdev",
    "oadev",
    "ohdev",
    "parse_memory",
    "prepare_record",
    "tdev",
    "totdev",
]
