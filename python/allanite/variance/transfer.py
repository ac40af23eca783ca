r"""Power transfer function of the overlapping Allan variance.

The overlapping Allan variance at :math:`\tau = m\Delta t` of a sampled rate with one-sided
PSD :math:`S(f)` is :math:`\int_0^{f_s/2} S(f)\,|H_m(f)|^2\,df` with

.. math:: |H_m(f)|^2 = \frac{2\sin^4(\pi f m\Delta t)}{m^2\sin^2(\pi f\Delta t)}

(NIST SP1065 eq. 65, for sample means). The fit's covariance between taus, the expected Allan
variance of spectrally synthesised records and the Gaussian variance of the estimate all use
this one function.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["avar_transfer"]


def avar_transfer(f: ArrayLike, m: ArrayLike, dt: float) -> NDArray[np.float64]:
    """Power transfer ``|H_m(f)|^2`` of the overlapping AVAR, shape ``(len(m), len(f))``.

    Parameters
    ----------
    f : array_like
        Frequencies in Hz, ``0 < f <= 1/(2 dt)``.
    m : array_like
        Averaging factors.
    dt : float
        Sample period in seconds.
    """
    f = np.asarray(f, dtype=np.float64)
    mm = np.asarray(m, dtype=np.float64).reshape(-1)[:, None]
    return np.asarray(2.0 * np.sin(np.pi * f * mm * dt) ** 4 / (mm * np.sin(np.pi * f * dt)) ** 2)
