"""Figures of what the noise costs: navigation error budget and complementary-filter output.

The budget figure has one log-log panel per quantity (tilt and heading in degrees, velocity in
m/s, position in m): each noise component's exact error growth as a solid line, its
short-interval (free-inertial) and long-interval (Schuler-bounded) closed forms dashed and
dotted in the same colour, and the root-sum-square total in black. A vertical line marks the
Schuler period. The complementary-filter figure shows the Allan deviation of the filter output
with its -1/2 and -1 asymptotes and the break at 1.5 T, optionally over a measured curve.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from allanite.plot.allan import _matplotlib

if TYPE_CHECKING:
    from allanite.impact import ComplementaryFilter, ErrorBudget
    from allanite.variance import AllanResult

__all__ = ["complementary_filter_figure", "error_budget_figure", "plot_error_budget"]

#: display scale and unit of each quantity (SI value * scale)
DISPLAY: dict[str, tuple[float, str, str]] = {
    "vertical": (180.0 / math.pi, "deg", "tilt error"),
    "azimuth": (180.0 / math.pi, "deg", "heading error"),
    "velocity": (1.0, "m/s", "velocity error"),
    "position": (1.0, "m", "position error"),
    "latitude": (1.0, "m", "latitude error (Earth rate)"),
}


def plot_error_budget(
    ax: Any, budget: ErrorBudget, quantity: str, *, asymptotes: bool = True
) -> list[Any]:
    """Draw one quantity of a budget on ``ax`` (log-log, customary units).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Target axes.
    budget : ErrorBudget
        From :func:`allanite.impact.error_budget`.
    quantity : str
        ``vertical``/``tilt``, ``azimuth``/``heading``, ``velocity``, ``position``, ``latitude``.
    asymptotes : bool
        Also draw the short- and long-interval closed forms.

    Returns
    -------
    list
        The solid lines, one per component, then the total.
    """
    from allanite.impact.budget import resolve_quantity

    name = resolve_quantity(quantity)
    scale, unit, title = DISPLAY[name]
    t = budget.t
    lines = []
    exact, short, long_ = (budget.curve(name, w) for w in ("exact", "short", "long"))
    for ci, comp in enumerate(budget.components):
        if not np.any(np.isfinite(exact[ci])):
            continue
        label = f"{comp.sensor} {comp.label}"
        (line,) = ax.plot(t, exact[ci] * scale, lw=1.5, label=label)
        lines.append(line)
        if asymptotes:
            colour = line.get_color()
            ax.plot(t, short[ci] * scale, ls="--", lw=0.8, color=colour)
            ax.plot(t, long_[ci] * scale, ls=":", lw=0.8, color=colour)
    (total,) = ax.plot(t, budget.total(name) * scale, color="black", lw=2.2, label="total")
    lines.append(total)
    ax.axvline(budget.earth.schuler_period, color="0.6", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    finite = budget.total(name)[np.isfinite(budget.total(name))] * scale
    if finite.size and np.max(finite) > 0:
        top = float(np.max(finite))
        ax.set_ylim(top * 1e-6, top * 3.0)
    ax.set_xlabel("time since alignment [s]")
    ax.set_ylabel(f"{title} (1σ) [{unit}]")
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    return lines


def error_budget_figure(
    budget: ErrorBudget,
    *,
    quantities: Sequence[str] = ("vertical", "azimuth", "velocity", "position"),
    asymptotes: bool = True,
    title: str | None = None,
    figsize: tuple[float, float] = (10.0, 7.5),
) -> Any:
    """Build a figure with one panel per quantity of an error budget.

    Parameters
    ----------
    budget : ErrorBudget
        From :func:`allanite.impact.error_budget`.
    quantities : sequence of str
        Panels to draw, in order (2 columns).
    asymptotes : bool
        Draw the closed forms (dashed: short interval, dotted: long interval).
    title : str, optional
        Figure title.
    figsize : tuple of float
        Size in inches.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not quantities:
        raise ValueError("quantities must name at least one quantity")
    fig = _matplotlib()(figsize=figsize, layout="constrained")
    cols = 1 if len(quantities) == 1 else 2
    rows = math.ceil(len(quantities) / cols)
    drawn = []
    for i, q in enumerate(quantities):
        ax = fig.add_subplot(rows, cols, i + 1)
        drawn.append((len(plot_error_budget(ax, budget, q, asymptotes=asymptotes)), i, ax))
    # the legend goes to the first panel that shows every component (gyro and accelerometer)
    _, _, legend_ax = max(drawn, key=lambda item: (item[0], -item[1]))
    legend_ax.legend(fontsize="x-small")
    if title:
        fig.suptitle(title, fontsize="medium")
    return fig


def complementary_filter_figure(
    filt: ComplementaryFilter,
    measured: AllanResult | None = None,
    *,
    tau: Any = None,
    figsize: tuple[float, float] = (7.0, 5.0),
) -> Any:
    """Allan deviation of a complementary filter's output (angle view) with its asymptotes.

    Parameters
    ----------
    filt : ComplementaryFilter
        The filter.
    measured : AllanResult, optional
        Allan result of a recorded or simulated output (``avar(theta, fs, input="angle")``),
        drawn as points, in rad/s.
    tau : array_like, optional
        Averaging times of the model curve (default: from ``dt`` to 1000 T).
    figsize : tuple of float
        Size in inches.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if tau is None:
        m = np.unique(np.round(np.geomspace(1, 1000 * filt.time_constant / filt.dt, 200)))
        tau = m * filt.dt
    tau = np.asarray(tau, dtype=np.float64)
    fig = _matplotlib()(figsize=figsize, layout="constrained")
    ax = fig.add_subplot()
    if measured is not None:
        ax.plot(measured.tau, measured.dev, "o", ms=3, color="0.4", label="output")
    ax.plot(tau, np.sqrt(filt.output_avar(tau)), color="C0", lw=1.8, label="exact")
    ax.plot(tau, np.sqrt(filt.short_asymptote(tau)), "--", color="C1", label="slope −1/2")
    ax.plot(tau, np.sqrt(filt.long_asymptote(tau)), "--", color="C2", label="slope −1")
    ax.axvline(filt.break_tau, color="0.5", lw=0.8, label=f"break 1.5 T = {filt.break_tau:.3g} s")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("τ [s]")
    ax.set_ylabel("Allan deviation of the tilt output [rad/s]")
    ax.legend(fontsize="small")
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    return fig
