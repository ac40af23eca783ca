"""Matplotlib figures of Allan-family results (needs the ``plot`` extra).

Figures are built on :class:`matplotlib.figure.Figure` directly (no pyplot state), so they are
safe in scripts, servers, reports and the GUI alike.
"""

from __future__ import annotations

from allanite.plot.allan import SLOPE_LABELS, allan_figure, model_figure, plot_allan, plot_model
from allanite.plot.export import figure_bytes, save_figure
from allanite.plot.impact import (
    complementary_filter_figure,
    error_budget_figure,
    plot_error_budget,
)

__all__ = [
    "SLOPE_LABELS",
    "allan_figure",
    "complementary_filter_figure",
    "error_budget_figure",
    "figure_bytes",
    "model_figure",
    "plot_allan",
    "plot_error_budget",
    "plot_model",
    "save_figure",
]
