"""Validation shared by the term classes: parameter values and (tau, dt) grids."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from allanite.terms.base import Term

__all__ = ["averaging_factor", "check_parameters", "positive"]


def check_parameters(term: Term, *, positive: tuple[str, ...] = ()) -> None:
    """Raise ValueError unless every parameter is finite and >= 0 (> 0 for ``positive``)."""
    for spec in term.params:
        value = getattr(term, spec.name)
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
            raise TypeError(f"{type(term).__name__}.{spec.name} must be a number, got {value!r}")
        if not math.isfinite(value) or value < 0:
            raise ValueError(
                f"{type(term).__name__}.{spec.name} must be finite and non-negative, got {value!r}"
            )
        if spec.name in positive and value == 0:
            raise ValueError(f"{type(term).__name__}.{spec.name} must be positive, got 0")


def positive(name: str, value: float) -> float:
    """``value`` as float, or ValueError if it is not a positive finite number."""
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a positive, finite number, got {value!r}")
    return v


def averaging_factor(
    tau: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Validate ``tau`` (s) and ``dt`` (s) and return ``(tau, m = tau/dt, dt)``.

    ``m`` is returned as float; the exact sampled forms assume it is a whole number.
    """
    step = positive("dt (the sample period in seconds)", dt)
    t = np.asarray(tau, dtype=np.float64)
    if not np.all(np.isfinite(t)) or np.any(t <= 0):
        raise ValueError("tau must be positive, finite averaging times in seconds")
    return t, t / step, step
