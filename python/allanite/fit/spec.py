"""What can be fitted: one :class:`TermSpec` per requested term, built from names or Terms.

Every fittable term is linear in one squared amplitude (``N^2``, ``Q^2``, ``B^2``, ``K^2``,
``R^2``, Gauss-Markov ``sigma^2``, sinusoid ``A^2``) and has at most one nonlinear parameter
(Gauss-Markov ``tau_c``, sinusoid ``frequency``), fitted on a log scale.
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
    Quantization,
    RateRamp,
    RateRandomWalk,
    Sine,
    Term,
    White,
)

__all__ = ["AUTO_CANDIDATES", "TermSpec", "resolve_terms"]

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


def _one(item: Any) -> TermSpec:
    if isinstance(item, Term):
        if not isinstance(item, (*AUTO_CANDIDATES, GaussMarkov, Sine)):
            raise ValueError(f"{type(item).__name__} cannot be fitted to an Allan curve")
        return TermSpec(type(item), item)
    if isinstance(item, type) and issubclass(item, Term):
        return _one(item.type)
    if isinstance(item, str):
        if item in _BY_SYMBOL:
            return TermSpec(_BY_SYMBOL[item])
        if item in TERM_TYPES and TERM_TYPES[item] in (*AUTO_CANDIDATES, GaussMarkov, Sine):
            return TermSpec(TERM_TYPES[item])
        names = sorted(set(_BY_SYMBOL) | {c.type for c in AUTO_CANDIDATES} | {"markov", "sine"})
        raise ValueError(f"unknown term {item!r}; fit one of: {', '.join(names)}")
    raise TypeError(f"terms must be names, Term classes or Term instances, got {item!r}")


def resolve_terms(terms: str | Sequence[Any]) -> tuple[list[TermSpec], bool]:
    """Resolve the ``terms`` argument of :func:`allanite.fit` to specs and an "auto" flag."""
    if isinstance(terms, str):
        if terms == "auto":
            return [TermSpec(c) for c in AUTO_CANDIDATES], True
        return [_one(terms)], False
    if not isinstance(terms, Sequence) or len(terms) == 0:
        raise ValueError("terms must be 'auto' or a non-empty list such as ['white', 'flicker']")
    specs = [_one(t) for t in terms]
    seen = [s.cls for s in specs if s.cls not in (GaussMarkov, Sine)]
    if len(seen) != len(set(seen)):
        raise ValueError(f"a power-law term is listed twice in {list(terms)!r}")
    return specs, False
