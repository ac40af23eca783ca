"""NoiseModel: a sum of noise Terms with units and a JSON round trip.

The JSON schema is part of the public contract::

    {"units": {"rate": "deg/s", "time": "s"},
     "terms": [{"type": "white", "N": 0.006}, {"type": "flicker", "B": 6.6e-5}, ...]}

Coefficients are in the model's rate unit and seconds (N in rate*sqrt(s), K in rate/sqrt(s),
Q in rate*s, R in rate/s, B and Gauss-Markov sigma in rate, tau_c in s, frequency in Hz).

``units.rate`` is the unit of the sensor's output and says which sensor the model describes
(:func:`allanite.units.sensor_kind`): an angular rate for a gyroscope (``deg/s``, ``deg/h``,
``rad/s``, ...), an acceleration for an accelerometer (``m/s^2``, ``g``, ``mg``, ``ug``,
``ft/s^2``, ``gal``), or ``unit`` for a record whose unit was not known. ``units.time`` is
always ``s``. An accelerometer model therefore reads::

    {"units": {"rate": "m/s^2", "time": "s"},
     "terms": [{"type": "white", "N": 6.0e-4}, {"type": "flicker", "B": 2.0e-4}]}

with N (velocity random walk) in m/s^2*sqrt(s) = m/s/sqrt(s), B in m/s^2.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from allanite._deprecation import keyword_only_fs, renamed
from allanite.errors import parse_json
from allanite.terms import TERM_TYPES, Term, term_from_dict
from allanite.units import Unit, coefficient_unit, convert, rate_unit, sensor_kind

#: file signatures of sample files a model path is sometimes confused with
_SAMPLE_FILES = (
    (b"\x93NUMPY", "a NumPy .npy array"),
    (b"PK\x03\x04", "a NumPy .npz archive (or another zip file)"),
    (b"\x89HDF", "an HDF5 file"),
    (b"PAR1", "a Parquet file"),
)

__all__ = ["NoiseModel", "json_schema", "read_text_file"]


def read_text_file(path: str | Path, what: str) -> str:
    """The UTF-8 text of a model or config file, or an InputError saying what it is instead.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    what : str
        What the file should be, for the message (``"a noise model is JSON text, ..."``).

    Raises
    ------
    allanite.errors.InputError
        If the file is missing, is a directory, holds samples (.npy, .npz, HDF5, Parquet) or is
        not UTF-8 text; the message names the file and ``what``.
    """
    from allanite.errors import InputError

    p = Path(path)
    if not p.exists():
        raise InputError(f"no such model file; check the path ({what})", path=str(p))
    if p.is_dir():
        raise InputError(f"is a directory, not a model file ({what})", path=str(p))
    raw = p.read_bytes()
    for magic, kind in _SAMPLE_FILES:
        if raw.startswith(magic):
            raise InputError(
                f"this is {kind} (recorded or simulated samples), not a noise model; {what}",
                path=str(p),
            )
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"not a text file, so not a noise model; {what}", path=str(p)) from None


def _check_units(units: dict[str, str] | str) -> dict[str, str]:
    if isinstance(units, str):  # the rate unit alone: coefficients are per second
        units = {"rate": units, "time": "s"}
    if not isinstance(units, dict):
        raise TypeError(
            f"units must be a rate unit such as 'deg/s' or a dict like "
            f"{{'rate': 'deg/s', 'time': 's'}}, got {units!r}"
        )
    missing = [k for k in ("rate", "time") if k not in units]
    extra = [k for k in units if k not in ("rate", "time")]
    if missing or extra:
        raise ValueError(
            f"units needs the fields 'rate' and 'time'; missing {missing or 'none'}, unexpected "
            f"{extra or 'none'}"
        )
    if units["time"] != "s":
        raise ValueError(
            f"units.time must be 's' (coefficients are per second), got {units['time']!r}"
        )
    rate_unit(units["rate"])  # raises with a clear message
    return {"rate": units["rate"], "time": "s"}


@dataclass(frozen=True)
class NoiseModel:
    """A sensor noise model: the sum of independent :class:`~allanite.terms.base.Term` s.

    Parameters
    ----------
    terms : sequence of Term
        The effects; their Allan variances and PSDs add.
    units : dict or str
        ``{"rate": <rate unit>, "time": "s"}``; the rate unit of every coefficient. A
        string is the rate unit alone (``"deg/s"`` is ``{"rate": "deg/s", "time": "s"}``).
    """

    terms: tuple[Term, ...]
    units: dict[str, str] = field(default_factory=lambda: {"rate": "deg/s", "time": "s"})

    def __post_init__(self) -> None:
        terms = tuple(self.terms)
        for term in terms:
            if not isinstance(term, Term):
                raise TypeError(f"NoiseModel terms must be Term instances, got {term!r}")
        object.__setattr__(self, "terms", terms)
        object.__setattr__(self, "units", _check_units(self.units))

    # --- statistics -------------------------------------------------------------------------
    def avar(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Exact Allan variance of the sampled model: the sum of the terms' variances."""
        t = np.asarray(tau, dtype=np.float64)
        total = np.zeros(t.shape)
        for term in self.terms:
            total = total + term.avar(t, dt)
        return total

    def avar_excess_variance(self, tau: ArrayLike, dt: float, n: int) -> NDArray[np.float64]:
        """Non-Gaussian part of the variance of the overlapping AVAR estimate of ``n`` samples.

        The sum of the terms' :meth:`~allanite.terms.base.Term.avar_excess_variance`: the
        fourth cumulants of independent effects add. With :meth:`avar` it corrects the EDF of
        an estimate, see :meth:`allanite.variance.AllanResult.with_excess_variance`.
        """
        t = np.asarray(tau, dtype=np.float64)
        total = np.zeros(t.shape)
        for term in self.terms:
            total = total + term.avar_excess_variance(t, dt, n)
        return total

    def avar_gaussian_variance(self, tau: ArrayLike, dt: float, n: int) -> NDArray[np.float64]:
        """Variance of the overlapping AVAR estimate of ``n`` samples if the model were Gaussian.

        Exact for the model's covariance (its sampled PSD, the sum of the terms'
        ``psd_sampled``), not only for power laws
        (:func:`~allanite.terms._estimator_kurtosis.gaussian_estimate_variance`); with
        :meth:`avar_excess_variance` it gives the full variance of the estimate.

        Raises
        ------
        ValueError
            If a term has no sampled spectrum (warm-up, ramp, turn-on bias).
        """
        from allanite.terms._estimator_kurtosis import gaussian_estimate_variance

        def spectrum(f: NDArray[np.float64]) -> NDArray[np.float64]:
            total = np.zeros(f.shape)
            for term in self.terms:
                try:
                    total = total + term.psd_sampled(f, dt)
                except NotImplementedError:
                    raise ValueError(
                        f"term {term.type!r} has no sampled spectrum, so the Gaussian variance "
                        "of the estimate is not defined for this model; leave it out "
                        f"(model.without({term.type!r}))"
                    ) from None
            return total

        return gaussian_estimate_variance(spectrum, tau, dt, n)

    def adev(self, tau: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Allan deviation, the square root of :meth:`avar`."""
        return np.sqrt(self.avar(tau, dt))

    def psd(self, f: ArrayLike) -> NDArray[np.float64]:
        """One-sided PSD of the rate in rate^2/Hz (needs every term to be stationary)."""
        f = np.asarray(f, dtype=np.float64)
        total = np.zeros(f.shape)
        for term in self.terms:
            if not term.stationary:
                raise ValueError(
                    f"term {term.type!r} is not stationary and has no PSD; drop it from the model "
                    f"(model.without({term.type!r})) before asking for a PSD"
                )
            try:
                total = total + term.psd(f)
            except NotImplementedError as exc:
                raise ValueError(f"{exc}; use NoiseModel.psd_sampled(f, dt)") from None
        return total

    def psd_sampled(
        self, f: ArrayLike, dt: float, *, skip_nonstationary: bool = False
    ) -> NDArray[np.float64]:
        """One-sided PSD of the sampled rate on ``(0, 1/(2 dt)]`` (aliasing included)."""
        f = np.asarray(f, dtype=np.float64)
        total = np.zeros(f.shape)
        for term in self.terms:
            if not term.stationary:
                if skip_nonstationary:
                    continue
                raise ValueError(f"term {term.type!r} is not stationary and has no PSD")
            total = total + term.psd_sampled(f, dt)
        return total

    # --- access -----------------------------------------------------------------------------
    def terms_of_type(self, kind: str | type[Term]) -> tuple[Term, ...]:
        """Return the terms of one JSON ``type`` (e.g. ``"markov"``) or one Term class."""
        if isinstance(kind, str):
            if kind not in TERM_TYPES:
                raise ValueError(
                    f"unknown term type {kind!r}; known: {', '.join(sorted(TERM_TYPES))}"
                )
            return tuple(t for t in self.terms if t.type == kind)
        return tuple(t for t in self.terms if isinstance(t, kind))

    def without(self, *kinds: str) -> NoiseModel:
        """Return a copy without the terms of the given types."""
        return NoiseModel(tuple(t for t in self.terms if t.type not in kinds), self.units)

    def plus(self, *terms: Term) -> NoiseModel:
        """Return a copy with more terms."""
        return NoiseModel(self.terms + tuple(terms), self.units)

    def coefficients(self) -> dict[str, float]:
        """Return the parameter values by label, in the model's units.

        Labels are the symbols (``N``, ``B``, ...) with ``_1``, ``_2`` suffixes for repeated
        types (``sigma_1``, ``tau_c_1``, ...).
        """
        out: dict[str, float] = {}
        for label, term, spec in self.labelled_parameters():
            out[label] = float(getattr(term, spec.name))
        return out

    def labelled_parameters(self) -> list[tuple[str, Term, Any]]:
        """``(label, term, ParamSpec)`` for every parameter; labels are unique.

        A parameter is labelled by its name (``N``, ``sigma``, ``tau_c``); when a type occurs
        more than once its parameters get a suffix ``_1``, ``_2`` in model order.
        """
        counts: dict[str, int] = {}
        for term in self.terms:
            counts[term.type] = counts.get(term.type, 0) + 1
        seen: dict[str, int] = {}
        out = []
        for term in self.terms:
            seen[term.type] = seen.get(term.type, 0) + 1
            suffix = f"_{seen[term.type]}" if counts[term.type] > 1 else ""
            for spec in term.params:
                out.append((spec.name + suffix, term, spec))
        return out

    @property
    def sensor(self) -> str:
        """``"gyro"``, ``"accelerometer"`` or ``"unknown"`` (from the dimension of the rate)."""
        return sensor_kind(self.units["rate"])

    def coefficient_units(self) -> dict[str, Unit]:
        """Unit of every parameter by label: the rate unit and seconds to the term's powers."""
        rate = self.units["rate"]
        return {
            label: coefficient_unit(rate, spec.rate, spec.time)
            for label, _, spec in self.labelled_parameters()
        }

    def in_units(self, rate: str) -> NoiseModel:
        """Return the same model with coefficients expressed in another rate unit.

        Raises
        ------
        ValueError
            If ``rate`` measures another quantity (a gyro model cannot be put in m/s^2).
        """
        target = rate_unit(rate)
        factor = convert(1.0, self.units["rate"], target)
        terms = []
        for term in self.terms:
            values = {p.name: getattr(term, p.name) * factor**p.rate for p in term.params}
            terms.append(term.with_values(**values))
        return NoiseModel(tuple(terms), {"rate": rate, "time": "s"})

    # --- JSON -------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Return the JSON-ready dictionary of the public schema."""
        return {"units": dict(self.units), "terms": [t.to_dict() for t in self.terms]}

    def to_json(self, **kwargs: Any) -> str:
        """JSON text of :meth:`to_dict` (keyword arguments go to :func:`json.dumps`)."""
        kwargs.setdefault("indent", 2)
        return json.dumps(self.to_dict(), **kwargs)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> NoiseModel:
        """Build a model from the JSON schema, with a clear error for any deviation."""
        if not isinstance(data, dict):
            raise ValueError(f"a noise model must be a JSON object, got {type(data).__name__}")
        missing = [k for k in ("units", "terms") if k not in data]
        extra = [k for k in data if k not in ("units", "terms")]
        if missing or extra:
            raise ValueError(
                "a noise model needs the fields 'units' and 'terms'; missing "
                f"{missing or 'none'}, unexpected {extra or 'none'}"
            )
        terms = data["terms"]
        if not isinstance(terms, list):
            raise ValueError(f"'terms' must be a list of term objects, got {terms!r}")
        built = []
        for i, item in enumerate(terms):
            try:
                built.append(term_from_dict(item))
            except (ValueError, TypeError) as exc:
                raise type(exc)(f"terms[{i}]: {exc}") from None
        return cls(tuple(built), data["units"])

    @classmethod
    def from_json(cls, text: str) -> NoiseModel:
        """Parse JSON text (see :meth:`from_dict`)."""
        try:
            data = parse_json(text, "the noise model")
        except json.JSONDecodeError as exc:
            raise ValueError(f"the noise model is not valid JSON: {exc}") from None
        return cls.from_dict(data)

    def save(self, path: str | Path) -> None:
        """Write the JSON model to ``path`` atomically."""
        from allanite.io.atomic import atomic_output

        with atomic_output(path) as tmp:
            Path(tmp).write_text(self.to_json() + "\n", encoding="utf-8")

    @classmethod
    def load(cls, path: str | Path) -> NoiseModel:
        """Read a JSON model written by :meth:`save` (or by hand).

        Raises
        ------
        allanite.errors.InputError
            If the file is missing, is a directory, holds samples (.npy, .npz, HDF5) or is
            not UTF-8 JSON text; the message names the file and what a model file is.
        """
        p = Path(path)
        text = read_text_file(
            p, "a noise model is JSON text, as written by 'allanite fit -o model.json'"
        )
        try:
            return cls.from_json(text)
        except (ValueError, TypeError) as exc:
            raise type(exc)(f"{p}: {exc}") from None

    # --- simulation -------------------------------------------------------------------------
    @keyword_only_fs
    def simulate(
        self,
        n: int | None = None,
        *,
        fs: float | None = None,
        duration: str | float | None = None,
        output: str = "rate",
        n_channels: int = 1,
        seed: Any = None,
        allow_aliasing: bool = False,
        flicker_method: str = "auto",
        channels: int | None = None,
    ) -> NDArray[np.float64]:
        """Simulate ``n`` samples (or ``duration``, e.g. ``"30min"``) at ``fs`` Hz (keyword).

        Rate samples in the model's rate unit, angle increments or angle
        (``output="rate"|"increment"|"angle"``); shape ``(n,)`` or ``(n, n_channels)``
        (``channels=`` is the deprecated name of ``n_channels``). The same
        seed gives the same samples. ``flicker_method`` = ``"auto"|"spectral"|"kasdin"|"bank"``
        chooses how flicker terms are simulated. See :func:`allanite.simulation.simulate`, and
        :func:`allanite.simulation.simulate_chunks` for records that do not fit in memory.
        """
        from allanite.simulation import simulate

        if fs is None:
            raise TypeError("simulate() needs the sampling frequency fs in Hz, e.g. fs=100.0")
        return simulate(
            self,
            n,
            fs=fs,
            duration=duration,
            output=output,  # type: ignore[arg-type]
            n_channels=renamed(n_channels, channels, new="n_channels", old="channels", default=1),
            seed=seed,
            allow_aliasing=allow_aliasing,
            flicker_method=flicker_method,
        )

    def __iter__(self) -> Iterator[Term]:
        return iter(self.terms)

    def __len__(self) -> int:
        return len(self.terms)


def json_schema() -> dict[str, Any]:
    """JSON Schema (draft 2020-12) of the noise-model file, built from the Term registry.

    ``docs/noise-model.schema.json`` is this schema; every term type, its parameters and
    their units come from the :class:`~allanite.terms.base.Term` classes, so the schema
    cannot drift from the code. The unit strings themselves are checked by
    :func:`allanite.units.rate_unit` when a model is read (a schema cannot express the unit
    grammar).
    """
    from allanite.units import RATE_UNITS

    variants = []
    for kind in sorted(TERM_TYPES):
        cls = TERM_TYPES[kind]
        props: dict[str, Any] = {"type": {"const": kind}}
        for spec in (*cls.params, *cls.optional):
            unit = _power_text(spec.rate, spec.time)
            text = spec.description or spec.name
            if spec.accel_description:
                text += f" (accelerometer: {spec.accel_description})"
            number: dict[str, Any] = {"type": "number", "description": f"{text}; unit {unit}"}
            if spec in cls.optional:
                number = {"type": ["number", "null"], "description": number["description"]}
            props[spec.name] = number
        for name, allowed in cls.settings.items():
            props[name] = {"enum": list(allowed), "description": f"{name} (default {allowed[0]})"}
        variants.append(
            {
                "title": f"{kind} ({cls.symbol})",
                "type": "object",
                "properties": props,
                "required": ["type", *[p.name for p in cls.params]],
                "additionalProperties": False,
            }
        )
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://allanite.readthedocs.io/noise-model.schema.json",
        "title": "allanite noise model",
        "description": (
            "A sensor noise model: the sum of independent terms. Coefficients are in the "
            "model's rate unit and seconds, to the powers given per parameter (rate = "
            "units.rate). units.rate says which sensor the model describes: an angular rate "
            "for a gyroscope, an acceleration for an accelerometer (g = 9.80665 m/s^2), or "
            "'unit' for a record whose unit was not known."
        ),
        "type": "object",
        "properties": {
            "units": {
                "type": "object",
                "properties": {
                    "rate": {
                        "type": "string",
                        "description": "unit of the sensor output, e.g. "
                        + ", ".join(RATE_UNITS)
                        + " (grammar: allanite.units)",
                    },
                    "time": {"const": "s"},
                },
                "required": ["rate", "time"],
                "additionalProperties": False,
            },
            "terms": {"type": "array", "items": {"oneOf": variants}},
        },
        "required": ["units", "terms"],
        "additionalProperties": False,
    }


def _power_text(rate: float, time: float) -> str:
    """``rate*s^0.5``-style text of a parameter's powers."""
    parts = []
    if rate:
        parts.append("rate" if rate == 1 else f"rate^{rate:g}")
    if time:
        parts.append("s" if time == 1 else f"s^{time:g}")
    return "*".join(parts) if parts else "1"
