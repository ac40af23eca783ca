"""Saving figures: to files atomically, or to bytes for embedding in a report."""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any

from allanite.io.atomic import atomic_output

__all__ = ["FIGURE_FORMATS", "figure_bytes", "save_figure"]

#: file suffixes matplotlib writes without extra dependencies
FIGURE_FORMATS: tuple[str, ...] = ("png", "svg", "pdf")


def _format(path: str | os.PathLike[str]) -> str:
    fmt = Path(path).suffix.lower().lstrip(".")
    if fmt not in FIGURE_FORMATS:
        raise ValueError(
            f"figure {path}: unsupported format {fmt or '(none)'!r}; use a .png, .svg or .pdf name"
        )
    return fmt


def save_figure(fig: Any, path: str | os.PathLike[str], *, dpi: int = 150) -> None:
    """Write ``fig`` to ``path`` (PNG, SVG or PDF by suffix); no partial file on failure."""
    fmt = _format(path)
    with atomic_output(path) as tmp:
        fig.savefig(tmp, format=fmt, dpi=dpi, bbox_inches="tight")


def figure_bytes(fig: Any, fmt: str = "png", *, dpi: int = 110) -> bytes:
    """Return ``fig`` rendered as PNG or SVG bytes."""
    if fmt not in FIGURE_FORMATS:
        raise ValueError(f"unsupported figure format {fmt!r}; use png, svg or pdf")
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, dpi=dpi, bbox_inches="tight")
    return buffer.getvalue()
