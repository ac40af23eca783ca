"""Argument validation shared by the impact modules (numbers only; strings are a TypeError)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["nonnegative", "positive"]


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    return float(value)


def positive(name: str, value: object) -> float:
    """Return ``value`` as float; TypeError unless a number, ValueError unless > 0 and finite."""
    v = _number(name, value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be positive and finite, got {value}")
    return v


def nonnegative(name: str, value: object) -> float:
    """Return ``value`` as float; TypeError unless a number, ValueError unless >= 0 and finite."""
    v = _number(name, value)
    if not (math.isfinite(v) and v >= 0):
        raise ValueError(f"{name} must be finite and >= 0, got {value}")
    return v
