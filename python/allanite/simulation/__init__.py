"""Noise simulation from a model: exact discretisations, streaming in bounded memory.

Entry points: :func:`simulate` (a whole record), :func:`simulate_chunks` (a generator of
pieces for records of any length) and :func:`write_record` (straight to .npy/.csv/raw
binary). Each :class:`~allanite.terms.base.Term` builds its own :class:`TermStream`.
"""

from __future__ import annotations

from allanite.simulation.record import (
    OUTPUTS,
    parse_duration,
    record_length,
    simulate,
    simulate_chunks,
)
from allanite.simulation.streams import BLOCK, SumStream, TermStream
from allanite.simulation.writers import write_record

__all__ = [
    "BLOCK",
    "OUTPUTS",
    "SumStream",
    "TermStream",
    "parse_duration",
    "record_length",
    "simulate",
    "simulate_chunks",
    "write_record",
]
