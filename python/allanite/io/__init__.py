"""Reading records from files and writing outputs safely."""

from __future__ import annotations

from allanite.io.options import ReadOptions
from allanite.io.readers import FORMATS, detect_format, from_frame, make_record, read_record
from allanite.io.record import Record, Segment, Timing

__all__ = [
    "FORMATS",
    "ReadOptions",
    "Record",
    "Segment",
    "Timing",
    "detect_format",
    "from_frame",
    "make_record",
    "read_record",
]
