r"""White noise whose level changes over the record (a drifting or stepping noise level)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import check_parameters
from allanite.terms.base import ParamSpec, Term
from allanite.terms.white import WhiteLaws

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream

__all__ = ["WhiteDrift", "ramp_fraction", "ramp_window_mean"]


def ramp_fraction(t: ArrayLike, t_start: float, t_end: float) -> NDArray[np.float64]:
    """How far the change has gone at time ``t``: 0 before ``t_start``, 1 after ``t_end``.

    Linear in between (``t_end == t_start``: a step at ``t_start``).
    """
    t = np.asarray(t, dtype=np.float64)
    width = t_end - t_start
    if width <= 0:
        return np.asarray((t >= t_start).astype(np.float64))
    return np.asarray(np.clip((t - t_start) / width, 0.0, 1.0))


def _ramp_integral(t: NDArray[np.float64], t_start: float, t_end: float) -> NDArray[np.float64]:
    """``integral_0^t ramp_fraction``."""
    width = max(t_end - t_start, 0.0)
    inside = np.clip(t - t_start, 0.0, width)
    after = np.maximum(t - t_end, 0.0) if width > 0 else np.maximum(t - t_start, 0.0)
    return np.asarray((inside**2 / (2.0 * width) if width > 0 else 0.0 * t) + after)


def ramp_window_mean(
    a: ArrayLike, b: ArrayLike, t_start: float, t_end: float
) -> NDArray[np.float64]:
    """Mean of :func:`ramp_fraction` over the intervals ``[a, b]`` (exact, ``b > a``)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    diff = _ramp_integral(b, t_start, t_end) - _ramp_integral(a, t_start, t_end)
    return np.asarray(diff / (b - a), dtype=np.float64)


@dataclass(frozen=True)
class WhiteDrift(WhiteLaws, Term):
    r"""White noise of rms level ``N`` whose variance moves linearly from one level to another.

    The variance (per unit ``N^2``) is ``v0`` before ``t_start``, ``ratio^2 v0`` after
    ``t_end`` and linear in time in between (``t_end == t_start``: one step), with ``v0`` chosen
    so that its mean over the record ``[0, duration]`` is ``N^2``:

    .. math:: N^2(t) = N^2 \frac{1 + \beta\,g(t)}{1 + \beta\,\bar g},\quad
              \beta = \mathrm{ratio}^2 - 1,

    ``g`` = :func:`ramp_fraction`, ``\bar g`` its record mean. A drift with temperature, a
    noise level that settles or steps once. Samples stay uncorrelated, so the Allan variance of
    the record is that of white noise of the mean power, ``N^2/tau`` (exact for the
    non-overlapping estimator over blocks tiling the record; the overlapping one weights the
    first and last ``tau`` less). Only the time series shows the change (the time view's
    ``hf``). ``psd`` is the record average ``2 N^2``.
    """

    N: float
    ratio: float
    t_start: float
    t_end: float
    duration: float

    type: ClassVar[str] = "white_drift"
    symbol: ClassVar[str] = "N"
    stationary: ClassVar[bool] = False
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("N", rate=1, time=0.5, description="rms white-noise level over the record"),
        ParamSpec("ratio", rate=0, time=0, description="final over initial noise level"),
        ParamSpec("t_start", rate=0, time=1, description="start of the change"),
        ParamSpec("t_end", rate=0, time=1, description="end of the change"),
        ParamSpec("duration", rate=0, time=1, description="record length"),
    )

    def __post_init__(self) -> None:
        check_parameters(self, positive=("ratio", "duration"))
        if self.t_end < self.t_start:
            raise ValueError(
                f"white_drift: t_end ({self.t_end}) must not precede t_start ({self.t_start})"
            )

    def variance_scale(self, t: ArrayLike) -> NDArray[np.float64]:
        """``N(t)^2 / N^2`` at times ``t`` in seconds (mean 1 over the record)."""
        beta = self.ratio**2 - 1.0
        mean = ramp_window_mean(0.0, self.duration, self.t_start, self.t_end)
        return (1.0 + beta * ramp_fraction(t, self.t_start, self.t_end)) / (1.0 + beta * mean)

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Gaussian samples of standard deviation ``N(t) sqrt(fs)``, ``t = k / fs``."""
        from allanite.simulation.streams import TermStream

        term = self

        class DriftStream(TermStream):
            def _generate(self, start: int, n: int) -> NDArray[np.float64]:
                t = (start + np.arange(n)) / fs
                sd = term.N * math.sqrt(fs) * np.sqrt(term.variance_scale(t))
                noise = self.rng.standard_normal((n, self.n_channels))
                return np.asarray(noise * sd[:, None])

        return DriftStream(fs, n_channels, seed)
