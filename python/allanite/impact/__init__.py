"""What the noise costs: navigation error budget, complementary filter, synchronous error.

- :func:`error_budget`: attitude, velocity, position and latitude error growth of a strapdown
  INS per sensor noise component (exact single-channel model plus the short-interval
  free-inertial and long-interval Schuler-bounded closed forms), curves and a table;
- :func:`error_change`: the change of one navigation error between two noise models (for the
  diagnosis report);
- :func:`optimal_complementary_filter`: the gyro-vertical complementary filter and the Allan
  deviation of its output;
- :func:`synchronous_error`: synchronous error and dry-friction harmonics of a platform on an
  oscillating stand.

All quantities are SI (rad, rad/s, m, m/s, m/s^2, s). See docs/impact.md for the formulas
and where the source's tabulated coefficients differ from the derivation.
"""

from __future__ import annotations

from allanite.impact.budget import ALL_QUANTITIES, BudgetComponent, ErrorBudget, error_budget
from allanite.impact.complementary_filter import (
    ComplementaryFilter,
    complementary_filter_sigma,
    optimal_complementary_filter,
)
from allanite.impact.cost import ErrorChange, error_change
from allanite.impact.earth import EARTH_RATE, STANDARD_GRAVITY, Earth
from allanite.impact.ins_errors import (
    error_model,
    latitude_error_sigma,
    long_interval_sigma,
    short_interval_sigma,
)
from allanite.impact.linear_model import LinearErrorModel
from allanite.impact.sensor import MarkovNoise, SensorNoise
from allanite.impact.synchronous import HarmonicAmplitude, SynchronousError, synchronous_error

__all__ = [
    "ALL_QUANTITIES",
    "EARTH_RATE",
    "STANDARD_GRAVITY",
    "BudgetComponent",
    "ComplementaryFilter",
    "Earth",
    "ErrorBudget",
    "ErrorChange",
    "HarmonicAmplitude",
    "LinearErrorModel",
    "MarkovNoise",
    "SensorNoise",
    "SynchronousError",
    "complementary_filter_sigma",
    "error_budget",
    "error_change",
    "error_model",
    "latitude_error_sigma",
    "long_interval_sigma",
    "optimal_complementary_filter",
    "short_interval_sigma",
    "synchronous_error",
]
