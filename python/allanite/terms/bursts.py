r"""White noise in bursts: a noise level that changes over the record (non-stationary level)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import averaging_factor, check_parameters
from allanite.terms.base import ParamSpec, Term

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream

__all__ = ["WhiteBursts"]


@dataclass(frozen=True)
class WhiteBursts(Term):
    r"""Extra white noise ``N`` switched on in bursts (a time-varying white-noise scale).

    The bursts come and go as a two-state Markov process: a burst lasts ``burst_s`` seconds on
    average (exponential), a fraction ``duty`` of the time is inside a burst. Switching does
    not correlate the samples, so the Allan variance is that of white noise of power ``duty
    N^2`` (exact):

    .. math:: \sigma^2(\tau) = d\,N^2/\tau,\qquad S(f) = 2\,d\,N^2.

    Only the time series tells it apart from white noise: the short-term noise level changes
    between windows (the time view's ``hf`` statistic) and the sample-to-sample changes are
    heavy-tailed (a scale mixture of Gaussians).
    """

    N: float
    duty: float
    burst_s: float

    type: ClassVar[str] = "white_bursts"
    symbol: ClassVar[str] = "N"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("N", rate=1, time=0.5, description="white noise added during a burst"),
        ParamSpec("duty", rate=0, time=0, description="fraction of the time in bursts"),
        ParamSpec("burst_s", rate=0, time=1, description="mean burst length"),
    )

    def __post_init__(self) -> None:
        check_parameters(self, positive=("duty", "burst_s"))
        if not 0.0 < self.duty < 1.0:
            raise ValueError(f"white_bursts: duty must lie in (0, 1), got {self.duty}")

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """``duty N^2 / tau`` (exact)."""
        t, _, _ = averaging_factor(tau, dt)
        return self.duty * self.N**2 / t

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD ``2 duty N^2`` (the average over the bursts)."""
        return np.full(np.shape(f), 2.0 * self.duty * self.N**2)

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """White stays white after sampling."""
        return self.psd(f)

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Gaussian samples of standard deviation ``N sqrt(fs)`` inside the bursts, 0 outside."""
        from allanite.simulation.streams import TermStream

        term = self

        class BurstStream(TermStream):
            def __init__(self) -> None:
                super().__init__(fs, n_channels, seed)
                self.sigma = term.N * math.sqrt(fs)
                self.mean_on = max(term.burst_s * fs, 1.0)
                self.mean_off = max(term.burst_s * (1.0 - term.duty) / term.duty * fs, 1.0)
                self.on = self.rng.random(self.n_channels) < term.duty
                self.left = np.array([self._run(bool(s)) for s in self.on], dtype=np.int64)

            def _run(self, on: bool) -> int:
                mean = self.mean_on if on else self.mean_off
                return max(1, round(self.rng.exponential(mean)))

            def _generate(self, start: int, n: int) -> NDArray[np.float64]:
                mask = np.zeros((n, self.n_channels), dtype=bool)
                for c in range(self.n_channels):
                    pos = 0
                    while pos < n:
                        take = int(min(self.left[c], n - pos))
                        mask[pos : pos + take, c] = self.on[c]
                        pos += take
                        self.left[c] -= take
                        if self.left[c] == 0:
                            self.on[c] = not self.on[c]
                            self.left[c] = self._run(bool(self.on[c]))
                noise = self.rng.standard_normal((n, self.n_channels)) * self.sigma
                return np.where(mask, noise, 0.0)

        return BurstStream()
