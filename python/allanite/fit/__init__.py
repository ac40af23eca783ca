"""Fitting noise terms to Allan curves.

GLS with the estimates' own covariance, automatic term selection, IEEE slope-method readouts
and the original program's fit (``method="seed"``).
"""

from __future__ import annotations

from allanite.fit.api import fit, fit_factors
from allanite.fit.classic import ClassicReadout, classic_readout
from allanite.fit.covariance import avar_covariance
from allanite.fit.result import Coefficient, Comparison, ComparisonRow, FitResult

__all__ = [
    "ClassicReadout",
    "Coefficient",
    "Comparison",
    "ComparisonRow",
    "FitResult",
    "avar_covariance",
    "classic_readout",
    "fit",
    "fit_factors",
]
