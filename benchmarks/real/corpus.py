"""Loader of the real-data corpus listed in ``benchmarks/real/manifest.json`` (issue #27).

Every record is read from where its manifest entry says: ``shared`` records from
``../shared/data`` (beside the repository, never copied into it), ``fetch`` records from the
folder named by the environment variable ``ALLANITE_REAL_DATA`` (files a user exports by the
entry's ``fetch`` step). A record that is not there is skipped with its reason.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

HERE = Path(__file__).resolve().parent
MANIFEST = HERE / "manifest.json"
REPO = HERE.parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
FETCH_ENV = "ALLANITE_REAL_DATA"


@dataclass(frozen=True)
class Channel:
    """One channel of a corpus record, in its physical unit."""

    record: str
    name: str
    kind: str  # "gyro" or "accel"
    units: str
    fs: float
    classes: tuple[str, ...]
    samples: NDArray[np.float64]

    @property
    def label(self) -> str:
        """``record/channel``."""
        return f"{self.record}/{self.name}"


def manifest() -> dict[str, Any]:
    """The corpus manifest (records, classes, provenance, licences, units)."""
    with MANIFEST.open(encoding="utf-8") as fh:
        data: dict[str, Any] = json.load(fh)
    return data


def record_path(entry: dict[str, Any], shared: Path = SHARED_DATA) -> Path | None:
    """Where a record's file is, or None when its folder is not configured."""
    if entry["where"] == "shared":
        return shared / entry["path"]
    folder = os.environ.get(FETCH_ENV)
    return Path(folder) / entry["path"] if folder else None


def missing_reason(entry: dict[str, Any], shared: Path = SHARED_DATA) -> str | None:
    """Why a record cannot be read here (None when it can)."""
    path = record_path(entry, shared)
    if path is None:
        return f"not fetched (set {FETCH_ENV}; {entry.get('fetch', 'no fetch step')})"
    if not path.is_file():
        return f"{path} not found ({entry.get('fetch', 'the shared data folder is absent')})"
    return None


def _column(path: Path, spec: dict[str, Any]) -> NDArray[np.float64]:
    if path.suffix == ".npy":
        raw = np.load(path)
    else:
        with np.load(path) as data:
            raw = data[spec["key"]]
    if spec["column"] is not None:
        raw = raw[:, spec["column"]]
    return np.asarray(raw, dtype=np.float64).ravel() * float(spec["scale"])


def channels(
    shared: Path = SHARED_DATA, skipped: list[tuple[str, str]] | None = None
) -> Iterator[Channel]:
    """Every readable channel of the corpus; unreadable records go to ``skipped`` (id, reason)."""
    for entry in manifest()["records"]:
        reason = missing_reason(entry, shared)
        if reason is not None:
            if skipped is not None:
                skipped.append((entry["id"], reason))
            continue
        path = record_path(entry, shared)
        assert path is not None
        for spec in entry["channels"]:
            yield Channel(
                record=entry["id"],
                name=spec["name"],
                kind=spec["kind"],
                units=spec["units"],
                fs=float(entry["fs"]),
                classes=tuple(entry["classes"]),
                samples=_column(path, spec),
            )
