"""What can be fitted: one :class:`TermSpec` per requested term, built from names or Terms.

Every fittable term is linear in one squared amplitude (``N^2``, ``Q^2``, ``B^2``, ``K^2``,
``R^2``, Gauss-Markov ``sigma^2``, sinusoid ``A^2``, the filtered white noise's ``N^2``) and
has at most one nonlinear parameter (Gauss-Markov ``tau_c``, sinusoid ``frequency``, the
sensor filter's ``bandwidth``), fitted on a log scale.

``terms`` is ``"auto"``, ``"auto+<name>[+<name>...]"`` (the automatic search with more
candidates: ``markov``, ``sine``, ``filter`` or a filter kind), or a list of names.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.terms import (
    TERM_TYPES,
    Flicker,
    GaussMarkov,
    LowPassWhite,
    Quantization,
    RateRamp,
    RateRandomWalk,
    Sine,
    Term,
    White,
)

__all__ = ["AUTO_CANDIDATES", "FILTER_CANDIDATES", "Resolved", "TermSpec", "resolve_terms"]

_BY_SYMBOL: dict[str, type[Term]] = {
    "Q": Quantization,
    "N": White,
    "B": Flicker,
    "K": RateRandomWalk,
    "R": RateRamp,
    "gm": GaussMarkov,
    "sigma": GaussMarkov,
    "sine": Sine,
}
#: classes that take part in ``terms="auto"``
AUTO_CANDIDATES: tuple[type[Term], ...] = (Quantization, White, Flicker, RateRandomWalk, RateRamp)
#: the sensor output filters a fit can name: name -> (filter kind, Butterworth order)
_FILTERS: dict[str, tuple[str, float | None]] = {
    "lowpass": ("rc", None),
    "lowpass_white": ("rc", None),
    "rc": ("rc", None),
    "one_pole": ("one_pole", None),
    "moving_average": ("moving_average", None),
    "bartlett": ("bartlett", None),
    **{f"butterworth{n}": ("butterworth", float(n)) for n in range(1, 9)},
    "butterworth": ("butterworth", 2.0),
}
#: the filters the automatic search tries (in place of white noise) when the curve asks
#: (cheapest law first: the search stops at the first one the test accepts; plain "auto"
#: tries the first AUTO_FILTERS of them)
FILTER_CANDIDATES: tuple[LowPassWhite, ...] = (
    LowPassWhite(1.0, 1.0, "one_pole"),
    LowPassWhite(1.0, 1.0, "moving_average"),
    LowPassWhite(1.0, 1.0, "butterworth", 2.0),
    LowPassWhite(1.0, 1.0, "butterworth", 4.0),
)
#: how many of FILTER_CANDIDATES plain "auto" tries (one-pole and moving average)
AUTO_FILTERS = 2
_EXTRAS: dict[str, type[Term]] = {"markov": GaussMarkov, "gm": GaussMarkov, "sine": Sine}


@dataclass(frozen=True)
class TermSpec:
    """A term to fit: its class, a template instance (fixed settings such as flicker ``f0``)."""

    cls: type[Term]
    template: Term | None = None

    @property
    def amplitude_name(self) -> str:
        """Name of the parameter whose square enters linearly."""
        return self.cls.params[0].name

    @property
    def nonlinear_name(self) -> str | None:
        """Name of the nonlinear parameter (``tau_c``, ``frequency``) or None."""
        return self.cls.params[1].name if len(self.cls.params) > 1 else None

    def build(self, amplitude: float, nonlinear: float | None = None) -> Term:
        """The term with the given amplitude (and nonlinear parameter)."""
        values: dict[str, Any] = {self.amplitude_name: float(amplitude)}
        if self.nonlinear_name is not None:
            values[self.nonlinear_name] = float(nonlinear)  # type: ignore[arg-type]
        if self.template is not None:
            return self.template.with_values(**values)
        return self.cls(**values)

    def shape(
        self, tau: NDArray[np.float64], dt: float, nonlinear: float | None
    ) -> NDArray[np.float64]:
        """Allan variance of the term with unit amplitude."""
        return self.build(1.0, nonlinear).avar(tau, dt)

    def start(self, nonlinear_default: float) -> float | None:
        """Starting value of the nonlinear parameter (from the template if given)."""
        if self.nonlinear_name is None:
            return None
        if self.template is not None:
            value = float(getattr(self.template, self.nonlinear_name))
            if math.isfinite(value) and value > 0:
                return value
        return nonlinear_default


_FITTABLE: tuple[type[Term], ...] = (*AUTO_CANDIDATES, GaussMarkov, Sine, LowPassWhite)


def known_names() -> list[str]:
    """Every term name :func:`resolve_terms` accepts (symbols, types, filter kinds)."""
    return sorted(
        set(_BY_SYMBOL) | {c.type for c in AUTO_CANDIDATES} | {"markov", "sine"} | set(_FILTERS)
    )


def _one(item: Any) -> TermSpec:
    if isinstance(item, Term):
        if not isinstance(item, _FITTABLE):
            raise ValueError(f"{type(item).__name__} cannot be fitted to an Allan curve")
        return TermSpec(type(item), item)
    if isinstance(item, type) and issubclass(item, Term):
        return _one(item.type)
    if isinstance(item, str):
        name = item.strip()
        if name in _FILTERS:
            kind, order = _FILTERS[name]
            return TermSpec(LowPassWhite, LowPassWhite(1.0, 1.0, kind, order))
        if name in _BY_SYMBOL:
            return TermSpec(_BY_SYMBOL[name])
        if name in TERM_TYPES and TERM_TYPES[name] in _FITTABLE:
            return TermSpec(TERM_TYPES[name])
        raise ValueError(f"unknown term {item!r}; fit one of: {', '.join(known_names())}")
    raise TypeError(f"terms must be names, Term classes or Term instances, got {item!r}")


@dataclass(frozen=True)
class Resolved:
    """The ``terms`` argument resolved.

    ``specs`` are the terms of a list, or the automatic candidates (plus the extras of
    ``auto+...``); ``filters`` the sensor filters the automatic search tries in place of
    white noise; ``force_filters`` whether it tries them on every curve (``auto+filter``)
    rather than only on one the filterless fit misses at its short taus.
    """

    specs: list[TermSpec]
    auto: bool
    filters: tuple[TermSpec, ...] = ()
    force_filters: bool = False


def _auto(text: str) -> Resolved:
    specs = [TermSpec(c) for c in AUTO_CANDIDATES]
    filters = tuple(TermSpec(LowPassWhite, t) for t in FILTER_CANDIDATES)
    extras = [e.strip() for e in text.split("+")[1:]]
    if any(not e for e in extras):
        raise ValueError(f"terms {text!r}: write 'auto+markov', 'auto+filter', ...")
    chosen: list[TermSpec] = []
    for extra in extras:
        if extra == "filter":
            chosen.extend(filters)
        elif extra in _FILTERS:
            chosen.append(_one(extra))
        elif extra in _EXTRAS:
            specs.append(TermSpec(_EXTRAS[extra]))
        else:
            raise ValueError(
                f"terms {text!r}: auto+ adds markov, sine, filter or a filter kind "
                f"({', '.join(sorted(_FILTERS))}), got {extra!r}"
            )
    if chosen:
        return Resolved(specs, True, tuple(dict.fromkeys(chosen)), True)
    # plain "auto" tries the cheap laws (one-pole, moving average) only where the curve
    # asks for a filter (allanite.fit.filters.filter_demanded); a Butterworth search costs
    # 20-30 s on a 1e6-sample record
    return Resolved(specs, True, filters[:AUTO_FILTERS], False)


def resolve_terms(terms: str | Sequence[Any]) -> Resolved:
    """Resolve the ``terms`` argument of :func:`allanite.fit` (see :class:`Resolved`).

    A comma-separated string (``"N,B,K"``) is a list.
    """
    if isinstance(terms, str):
        if terms.strip() == "auto" or terms.strip().startswith("auto+"):
            return _auto(terms.strip())
        if "," in terms:
            return resolve_terms([t for t in terms.split(",") if t.strip()])
        return Resolved([_one(terms)], False)
    if not isinstance(terms, Sequence) or len(terms) == 0:
        raise ValueError("terms must be 'auto' or a non-empty list such as ['white', 'flicker']")
    specs = [_one(t) for t in terms]
    seen = [s.cls for s in specs if s.cls not in (GaussMarkov, Sine)]
    if len(seen) != len(set(seen)):
        raise ValueError(f"a power-law term is listed twice in {list(terms)!r}")
    if White in seen and LowPassWhite in seen:
        raise ValueError(
            f"terms {list(terms)!r} list white noise and a sensor filter: the filter term "
            "carries the white noise N (the unfiltered sensor's), list it instead of 'N'"
        )
    return Resolved(specs, False)
