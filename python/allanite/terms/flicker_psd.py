r"""The PSD of sampled flicker noise: one formula for the Flicker term and its generators.

:meth:`allanite.terms.Flicker.psd_sampled` and the generators of
:mod:`allanite.simulation.flicker` (which design their AR(1) bank and FIR filter against it,
at ``B = 1``, ``dt = 1``) share it. It lives in its own module, below both: the Flicker
term streams from :mod:`allanite.simulation.flicker`, so that module cannot import the term.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["flicker_psd_sampled"]


def flicker_psd_sampled(f: ArrayLike, B: float, dt: float, cutoff: float) -> NDArray[np.float64]:
    r"""One-sided PSD of flicker rate noise sampled as interval averages.

    .. math:: S(f) = \frac{B^2}{\pi f}\,\mathrm{sinc}^2(f\,dt) \quad (0 < f \le f_c),
              \qquad 0 \text{ above}

    Parameters
    ----------
    f : array_like
        Frequencies in Hz (``0 < f <= 1/(2 dt)``).
    B : float
        Bias instability coefficient (rate).
    dt : float
        Sample period in s.
    cutoff : float
        The flicker's high cutoff :math:`f_c` in Hz (``1/(2 dt)`` for none below Nyquist).

    Returns
    -------
    numpy.ndarray
        The PSD in rate^2/Hz.

    References
    ----------
    IEEE Std 952-1997, Annex C (flicker PSD :math:`B^2/(2\pi f)` two-sided); the
    :math:`\mathrm{sinc}^2` factor is the transfer of averaging over one sample period.
    """
    f = np.asarray(f, dtype=np.float64)
    out = B**2 / (np.pi * f) * np.sinc(f * dt) ** 2
    return np.where(f <= cutoff, out, 0.0)
