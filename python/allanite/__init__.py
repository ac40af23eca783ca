"""allanite: how noisy is your gyroscope, fast, and why your simulated sensor is not the real one.

Allan-family variances with confidence intervals from a C++ core, IEEE noise-term fits with
honest uncertainty, noise simulation from a model, and a diagnosis of the sim-to-real gap.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
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

#: public name -> the module that defines it; imported on first use (PEP 562) so that
#: ``import allanite.cli`` (``allanite --version``, ``--help``) does not load numpy or scipy
_LAZY: dict[str, str] = {
    "BatchResult": "allanite.batch",
    "batch": "allanite.batch",
    "Diagnosis": "allanite.diagnosis",
    "diagnose": "allanite.diagnosis",
    "Coefficient": "allanite.fit",
    "FitResult": "allanite.fit",
    "fit": "allanite.fit",
    "Record": "allanite.io",
    "read_record": "allanite.io",
    "NoiseModel": "allanite.model",
    **dict.fromkeys(
        [
            "Flicker",
            "GaussMarkov",
            "Quantization",
            "RateRamp",
            "RateRandomWalk",
            "Sine",
            "Term",
            "White",
        ],
        "allanite.terms",
    ),
    **dict.fromkeys(
        [
            "KINDS",
            "AllanResult",
            "adev",
            "avar",
            "hdev",
            "mdev",
            "oadev",
            "ohdev",
            "tdev",
            "totdev",
        ],
        "allanite.variance",
    ),
    "avar_large": "allanite.variance.outofcore",
}


def __getattr__(name: str) -> Any:
    """Import a public name's module on first use (see :data:`_LAZY`)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'allanite' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})


class _Package(types.ModuleType):
    """The package module: ``allanite.fit`` and ``allanite.batch`` stay the functions.

    The subpackages of the same names are set on the package by the import system when they
    are first loaded; as before the lazy imports, the exported functions keep those names.
    """

    def __setattr__(self, name: str, value: Any) -> None:
        if name in _LAZY and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


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
