"""Sim-to-real gap diagnosis: where a simulated sensor differs from a real one, and why.

:func:`diagnose` compares a real record with a simulated sensor (a NoiseModel or a simulated
record) in three views -- averaging time, frequency, time -- calibrated by Monte Carlo
replicates of the simulated sensor, and attributes a significant gap to candidate effects
(every :class:`~allanite.terms.Term` type plus ``rescale:<type>``). See docs/diagnosis.md.
"""

from __future__ import annotations

from allanite.diagnosis.attribution import Attribution
from allanite.diagnosis.candidates import EFFECTS
from allanite.diagnosis.engine import diagnose
from allanite.diagnosis.frequency_view import FrequencyView, SpectralLine
from allanite.diagnosis.result import Diagnosis, Holdout
from allanite.diagnosis.tau_view import TauView
from allanite.diagnosis.time_view import TimeView

__all__ = [
    "EFFECTS",
    "Attribution",
    "Diagnosis",
    "FrequencyView",
    "Holdout",
    "SpectralLine",
    "TauView",
    "TimeView",
    "diagnose",
]
