r"""A vibration line whose frequency drifts linearly over the record."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import averaging_factor, check_parameters
from allanite.terms.base import ParamSpec, Term
from allanite.terms.sine import Sine

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream

__all__ = ["DriftingLine"]


@lru_cache(maxsize=16)
def _gauss_legendre(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss-Legendre nodes and weights of order ``n``, cached.

    An eigenvalue problem of size ``n`` (0.5 s and more at the orders of a diagnosis), asked
    again by every Allan variance of the same line's fit.
    """
    x, w = np.polynomial.legendre.leggauss(n)
    x.setflags(write=False)
    w.setflags(write=False)
    return x, w


@dataclass(frozen=True)
class DriftingLine(Term):
    r"""A sinusoid of amplitude ``A`` whose frequency moves linearly from ``f_start`` to ``f_end``.

    Over a record of ``duration`` seconds the instantaneous frequency is
    :math:`f(t) = f_s + (f_e - f_s)\,t/D` (a motor speeding up, a thermal drift of a
    vibration), the phase its integral plus a random start. The frequency spends the same time
    at every value of :math:`[f_s, f_e]`, so the record's Allan variance and spectrum are the
    averages over that interval of a fixed sinusoid's (:class:`~allanite.terms.Sine`, its exact
    sampled form, aliasing included):

    .. math:: \sigma^2(\tau) = \frac{1}{f_e - f_s}\int_{f_s}^{f_e}
              \sigma^2_{\rm sine}(\tau; A, f)\,df,\qquad
              S(f) = \frac{A^2}{2|f_e - f_s|}\ \text{on}\ [f_s, f_e].

    This is exact in the quasi-static limit (the frequency changes by much less than
    :math:`1/\tau` within one averaging time, :math:`|f_e - f_s|\tau^2/D \ll 1`) and the
    integral is evaluated by Gauss-Legendre quadrature fine enough for the oscillation of the
    integrand in ``f``. The spectrum is a flat band, not a line: the line detector does not
    see it, the frequency view's band excess and the time view's moving peak do.

    Parameters
    ----------
    amplitude : float
        Amplitude ``A`` in the model's rate unit.
    f_start, f_end : float
        Frequencies in Hz at the start and the end of the record (distinct).
    duration : float
        Record length ``D`` in seconds over which the frequency moves.
    """

    amplitude: float
    f_start: float
    f_end: float
    duration: float

    type: ClassVar[str] = "drifting_line"
    symbol: ClassVar[str] = "amplitude"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("amplitude", rate=1, time=0, description="amplitude"),
        ParamSpec("f_start", rate=0, time=-1, description="frequency at the start in Hz"),
        ParamSpec("f_end", rate=0, time=-1, description="frequency at the end in Hz"),
        ParamSpec("duration", rate=0, time=1, description="record length of the drift"),
    )

    def __post_init__(self) -> None:
        check_parameters(self, positive=("f_start", "f_end", "duration"))
        if self.f_start == self.f_end:
            raise ValueError(
                "drifting_line: f_start equals f_end; a line that does not drift is a 'sine'"
            )

    def _nodes(self, tau_max: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        span = abs(self.f_end - self.f_start)
        n = int(min(max(64, 16 * span * tau_max), 20000))
        x, w = _gauss_legendre(n)
        lo = min(self.f_start, self.f_end)
        return lo + 0.5 * span * (x + 1.0), 0.5 * w

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Frequency-averaged exact sampled-sine Allan variance (see the class docstring)."""
        t, _, step = averaging_factor(tau, dt)
        flat = t.reshape(-1)
        out = np.zeros(flat.shape)
        if flat.size:
            freqs, weights = self._nodes(float(flat.max()))
            for f, w in zip(freqs, weights, strict=True):
                out += w * Sine(amplitude=self.amplitude, frequency=float(f)).avar(flat, step)
        return out.reshape(t.shape)

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD ``A^2 / (2 |f_end - f_start|)`` inside the swept band, 0 outside."""
        f = np.asarray(f, dtype=np.float64)
        lo, hi = sorted((self.f_start, self.f_end))
        return np.where((f >= lo) & (f <= hi), self.amplitude**2 / (2.0 * (hi - lo)), 0.0)

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Point samples: the swept band folded into ``[0, 1/(2 dt)]`` (aliasing included)."""
        f = np.asarray(f, dtype=np.float64)
        fs = 1.0 / dt
        lo, hi = sorted((self.f_start, self.f_end))
        out = np.zeros(f.shape)
        level = self.amplitude**2 / (2.0 * (hi - lo))
        for k in range(int(hi // fs) + 2):
            for g in (k * fs + f, k * fs - f):
                out += np.where((g >= lo) & (g <= hi) & (g >= 0), level, 0.0)
        return out

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Point samples of the chirp with a random phase per channel."""
        from allanite.simulation.streams import TermStream

        term = self
        rate = (self.f_end - self.f_start) / self.duration

        class ChirpStream(TermStream):
            def __init__(self) -> None:
                super().__init__(fs, n_channels, seed)
                self.phase = self.rng.uniform(0.0, 2.0 * math.pi, self.n_channels)

            def _generate(self, start: int, n: int) -> NDArray[np.float64]:
                t = (start + np.arange(n)) * self.dt
                ph = 2.0 * math.pi * (term.f_start * t + 0.5 * rate * t * t)
                return term.amplitude * np.sin(ph[:, None] + self.phase[None, :])

        return ChirpStream()
