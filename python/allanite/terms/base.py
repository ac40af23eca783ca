"""The one abstraction: a noise Term.

Every effect the library knows is one :class:`Term` subclass, and fitting, simulation,
diagnosis, reports and unit conversion all go through it. A Term is a frozen dataclass whose
fields are its parameters (in the model's rate unit and seconds); the class declares the JSON
``type``, the IEEE symbol, the unit of each parameter and whether the effect is stationary.

Adding an effect = adding one subclass (it registers itself under its ``type``) and its tests.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from allanite.simulation.streams import TermStream
    from allanite.variance import AllanResult

__all__ = ["TERM_TYPES", "ParamSpec", "Term", "term_from_dict"]


@dataclass(frozen=True)
class ParamSpec:
    """Unit of a parameter as powers of the model's rate unit and of seconds.

    ``N`` (rate * sqrt(s)) is ``ParamSpec("N", rate=1, time=0.5)``; a correlation time is
    ``ParamSpec("tau_c", rate=0, time=1)``. The rate is the sensor's output (an angular rate
    or an acceleration, see :func:`allanite.units.sensor_kind`), so the dimension of the
    parameter follows from these powers (:func:`allanite.units.coefficient_unit`).
    ``description`` names the quantity for a gyroscope, ``accel_description`` for an
    accelerometer where the customary name differs (velocity random walk for N, ...).
    """

    name: str
    rate: float
    time: float
    description: str = ""
    accel_description: str = ""

    def describe(self, sensor: str = "gyro") -> str:
        """Customary name of the parameter for a ``"gyro"`` or an ``"accelerometer"``.

        For an ``"unknown"`` sensor (a record without a unit) both names are given where
        they differ (``angle random walk / velocity random walk``).
        """
        if sensor == "accelerometer" and self.accel_description:
            return self.accel_description
        if sensor == "unknown" and self.accel_description:
            return f"{self.description} / {self.accel_description}"
        return self.description


#: registry of every Term subclass by its JSON ``type``
TERM_TYPES: dict[str, type[Term]] = {}


class Term(ABC):
    """Base class of all noise terms (subclasses are frozen dataclasses).

    Class attributes
    ----------------
    type : str
        JSON ``"type"`` of the term (``white``, ``quantization``, ``flicker``, ...).
    symbol : str
        IEEE symbol of the principal coefficient (``N``, ``Q``, ``B``, ``K``, ``R``, ...).
    params : tuple of ParamSpec
        The parameters, in field order, with their units.
    stationary : bool
        Whether the effect is wide-sense stationary (then :meth:`psd` exists).
    """

    type: ClassVar[str]
    symbol: ClassVar[str]
    params: ClassVar[tuple[ParamSpec, ...]]
    stationary: ClassVar[bool] = True
    #: parameters that may be omitted from JSON (then None, meaning "use the default")
    optional: ClassVar[tuple[ParamSpec, ...]] = ()
    #: text settings (not parameters): name -> allowed values, the first the default
    settings: ClassVar[dict[str, tuple[str, ...]]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        term_type = cls.__dict__.get("type")
        if isinstance(term_type, str):
            TERM_TYPES[term_type] = cls

    # --- parameters -------------------------------------------------------------------------
    def values(self) -> dict[str, float]:
        """Parameter values by name, in the model's units."""
        return {p.name: float(getattr(self, p.name)) for p in self.params}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary ``{"type": ..., <param>: value, ...}``."""
        extra = {
            p.name: float(getattr(self, p.name))
            for p in self.optional
            if getattr(self, p.name) is not None
        }
        text = {
            name: getattr(self, name)
            for name, allowed in self.settings.items()
            if getattr(self, name) != allowed[0]
        }
        return {"type": self.type, **self.values(), **extra, **text}

    def with_values(self, **values: float) -> Term:
        """A copy with some parameters replaced."""
        return dataclasses.replace(self, **values)  # type: ignore[type-var]

    # --- statistics -------------------------------------------------------------------------
    @abstractmethod
    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact Allan variance of this effect for a record sampled at period ``dt``.

        Parameters
        ----------
        tau : array_like
            Averaging times in seconds (multiples of ``dt``).
        dt : float
            Sample period in seconds.

        Returns
        -------
        numpy.ndarray
            Allan variance in squared rate units.
        """

    def avar_excess_variance(self, tau: ArrayLike, dt: float, n: int) -> NDArray[np.float64]:
        r"""Non-Gaussian part of the variance of the overlapping AVAR estimate (rate^4).

        The overlapping estimate of a record of ``n`` samples is a quadratic form in the
        record; its variance is that of a Gaussian process with the same covariance (what the
        Greenhall-Riley EDF describes) plus this excess, which the fourth cumulants of the
        effect cause (:mod:`allanite.terms._estimator_kurtosis`). Use it through
        :meth:`allanite.variance.AllanResult.with_excess_variance`:
        :math:`1/\nu = 1/\nu_\text{Gauss} + \text{excess}/(2\,\sigma^4)`.

        Zero here: exact for Gaussian terms; deterministic terms (and a random-phase sine) are
        treated like Gaussian noise. Heavy-tailed effects (spikes, bias steps, telegraph
        noise) override it.

        Parameters
        ----------
        tau : array_like
            Averaging times in seconds (whole multiples of ``dt``).
        dt : float
            Sample period in seconds.
        n : int
            Record length in samples.

        Returns
        -------
        numpy.ndarray
            Excess variance of the estimate in squared rate units squared, shaped like ``tau``.
        """
        return np.zeros(np.shape(tau))

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided power spectral density of the rate in rate^2/Hz (stationary terms only)."""
        raise NotImplementedError(f"{type(self).__name__} is not stationary and has no PSD")

    def psd_sampled(self, f: ArrayLike, dt: float) -> NDArray[np.float64]:
        """One-sided PSD of the sampled rate on ``0 < f <= 1/(2 dt)`` (aliasing included).

        Consistent with :meth:`avar`: ``avar(m dt) = integral_0^{1/(2dt)} |H_m(f)|^2 S(f) df``
        with ``|H_m(f)|^2 = 2 sin^4(pi f m dt) / (m sin(pi f dt))^2``. The default treats each
        sample as the average of the continuous rate over its period (``psd(f) sinc^2(f dt)``),
        which is exact for band-limited terms.
        """
        f = np.asarray(f, dtype=np.float64)
        return self.psd(f) * np.sinc(f * dt) ** 2

    # --- simulation -------------------------------------------------------------------------
    def stream(
        self, fs: float, n_channels: int, seed: Any, *, n_samples: int | None = None
    ) -> TermStream:
        """Return a streaming generator of this effect's rate samples (see allanite.simulation).

        Parameters
        ----------
        fs : float
            Sampling frequency in Hz.
        n_channels : int
            Independent channels generated side by side.
        seed : None, int or numpy.random.SeedSequence
            Seed of the stream (a model spawns one child per term).
        n_samples : int, optional
            Length of the record, when known (lets flicker use exact spectral synthesis).
        """
        raise NotImplementedError(f"{type(self).__name__} cannot be simulated yet")

    # --- fitting ----------------------------------------------------------------------------
    @classmethod
    def guess(cls, result: AllanResult) -> Term | None:
        """A starting value from an Allan curve, or None if the curve shows no sign of it."""
        return None


def term_from_dict(data: dict[str, Any]) -> Term:
    """Build a Term from its JSON dictionary, with a clear error for unknown types or fields."""
    if not isinstance(data, dict) or "type" not in data:
        raise ValueError(f"a term must be an object with a 'type' field, got {data!r}")
    kind = data["type"]
    if kind not in TERM_TYPES:
        known = ", ".join(sorted(TERM_TYPES))
        raise ValueError(f"unknown term type {kind!r}; known types: {known}")
    cls = TERM_TYPES[kind]
    names = [p.name for p in cls.params]
    optional = [p.name for p in cls.optional]
    missing = [n for n in names if n not in data]
    extra = [
        k
        for k in data
        if k != "type" and k not in names and k not in optional and k not in cls.settings
    ]
    if missing or extra:
        raise ValueError(
            f"term {kind!r} needs fields {names}; missing {missing or 'none'}, unexpected "
            f"{extra or 'none'}"
        )
    values: dict[str, float | str | None] = {}
    for name, allowed in cls.settings.items():
        if name in data:
            if data[name] not in allowed:
                raise ValueError(
                    f"field {name!r} of term {kind!r} must be one of {', '.join(allowed)}, "
                    f"got {data[name]!r}"
                )
            values[name] = data[name]
    for n in names + [o for o in optional if o in data]:
        value = data[n]
        if value is None and n in optional:
            values[n] = None
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError(f"field {n!r} of term {kind!r} must be a number, got {value!r}")
        values[n] = float(value)
    return cls(**values)
