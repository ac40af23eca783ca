"""Equivalent degrees of freedom and power-law noise identification.

PLACEHOLDER (white-FM EDF only) until the Greenhall & Riley (2003) implementation lands.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["equivalent_dof", "identify_alpha"]


def identify_alpha(phase: NDArray[np.float64], m: NDArray[np.int64], kind: str) -> NDArray[np.int64]:
    """Power-law exponent alpha for each factor and channel (placeholder: white FM, alpha=0)."""
    return np.zeros((m.size, phase.shape[1]), dtype=np.int64)


def equivalent_dof(
    kind: str, alpha: NDArray[np.int64], m: NDArray[np.int64], n_phase: int
) -> NDArray[np.float64]:
    """EDF per factor and channel (placeholder: overlapping white-FM formula for every kind)."""
    n = n_phase - 1
    mm = m.astype(np.float64)[:, None]
    edf = (3.0 * (n - 1) / (2.0 * mm) - 2.0 * (n - 2) / n) * 4.0 * mm**2 / (4.0 * mm**2 + 5.0)
    return np.broadcast_to(edf, alpha.shape).astype(np.float64)
