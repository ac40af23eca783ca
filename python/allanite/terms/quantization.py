"""Angle quantization noise, IEEE symbol Q."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite.terms._checks import averaging_factor, check_parameters
from allanite.terms._guess import curve_bound
from allanite.terms.base import ParamSpec, Term

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream
    from allanite.variance import AllanResult

__all__ = ["Quantization"]


@dataclass(frozen=True)
class Quantization(Term):
    r"""Angle quantization noise, coefficient ``Q`` (rate * s, i.e. an angle).

    Sampled model: the measured angle carries an error :math:`e_k` of variance :math:`Q^2`
    (uniform on :math:`\pm\sqrt{3}Q`), independent between samples, so the rate is
    :math:`(e_k - e_{k-1})/\Delta t`. The block means over :math:`\tau = m\Delta t` differ by
    :math:`(e_{k+2m} - 2e_{k+m} + e_k)/\tau`, hence exactly, for every integer ``m``:

    .. math:: \sigma^2(\tau) = 3 Q^2 / \tau^2

    One-sided PSD of the sampled rate: :math:`8 Q^2 \sin^2(\pi f \Delta t)/\Delta t`, whose
    low-frequency limit is :math:`2 (2\pi f)^2 Q^2 \Delta t` (IEEE 952 two-sided
    :math:`(2\pi f)^2 Q^2 T_s`). The continuous-time :meth:`psd` is that limit and needs the
    sample period, so it is only defined through :meth:`psd_sampled`.

    References
    ----------
    IEEE Std 952-1997, Annex C.
    """

    Q: float

    type: ClassVar[str] = "quantization"
    symbol: ClassVar[str] = "Q"
    params: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec(
            "Q",
            rate=1,
            time=1,
            description="angle quantization",
            accel_description="velocity quantization",
        ),
    )

    def __post_init__(self) -> None:
        check_parameters(self)

    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Allan variance ``3 Q^2 / tau^2`` (exact for whole averaging factors)."""
        t, _, _ = averaging_factor(tau, dt)
        return 3.0 * self.Q**2 / t**2

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """Quantization noise depends on the sample period: use :meth:`psd_sampled`."""
        raise NotImplementedError(
            "the quantization PSD depends on the sample period; call psd_sampled(f, dt)"
        )

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """One-sided PSD of the sampled rate, ``8 Q^2 sin^2(pi f dt) / dt``."""
        f = np.asarray(f, dtype=np.float64)
        return 8.0 * self.Q**2 * np.sin(np.pi * f * dt) ** 2 / dt

    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Differenced uniform angle error ``(e[k] - e[k-1]) fs``, ``e`` on ``+-sqrt(3) Q``."""
        from allanite.simulation.gaussian import QuantizationStream

        return QuantizationStream(self.Q, fs, n_channels, seed)

    @classmethod
    def guess(cls, result: AllanResult) -> Quantization | None:
        """Largest ``Q`` the curve allows: ``sqrt(min(var * tau^2) / 3)``."""
        bound = curve_bound(result, 2.0)
        return None if bound is None else cls(Q=float(np.sqrt(bound / 3.0)))
