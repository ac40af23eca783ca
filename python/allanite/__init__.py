"""allanite: how noisy is your gyroscope, fast, and why your simulated sensor is not the real one.

Allan-family variances with confidence intervals from a C++ core, IEEE noise-term fits with
honest uncertainty, noise simulation from a model, and a diagnosis of the sim-to-real gap.
"""

from __future__ import annotations

from allanite.batch import BatchResult, batch
from allanite.diagnosis import Diagnosis, diagnose
from allanite.fit import Coefficient, FitResult, fit
from allanite.io import Record, read_record
from allanite.model import NoiseModel
from allanite.terms import (
    Flicker,
    GaussMarkov,
    Quantization,
    RateRamp,
    RateRandomWalk,
    Sine,
    Term,
    White,
)
from allanite.variance import (
    KINDS,
    AllanResult,
    adev,
    avar,
    hdev,
    mdev,
    oadev,
    ohdev,
    tdev,
    totdev,
)
from allanite.variance.outofcore import avar_large

__version__ = "0.1.0"

__all__ = [
    "KINDS",
    "AllanResult",
    "BatchResult",
    "Coefficient",
    "Diagnosis",
    "FitResult",
    "Flicker",
    "GaussMarkov",
    "NoiseModel",
    "Quantization",
    "RateRamp",
    "RateRandomWalk",
    "Record",
    "Sine",
    "Term",
    "White",
    "__version__",
    "adev",
    "avar",
    "avar_large",
    "batch",
    "diagnose",
    "fit",
    "hdev",
    "mdev",
    "oadev",
    "ohdev",
    "read_record",
    "tdev",
    "totdev",
]
