"""Figures of a :class:`allanite.diagnosis.Diagnosis`: the tau, frequency and time views.

Each function draws on a given axes; :func:`diagnosis_figure` builds a three-panel
:class:`matplotlib.figure.Figure` (no pyplot state) for reports and the GUI.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from allanite.extras import require

__all__ = ["diagnosis_figure", "plot_frequency_view", "plot_tau_view", "plot_time_view"]


def _figure_class() -> Any:
    return require("matplotlib.figure", extra="plot", purpose="plotting").Figure


def plot_tau_view(ax: Any, diagnosis: Any) -> None:
    """Real vs simulated Allan deviation with the simulation's band and significant taus."""
    v = diagnosis.tau
    ax.fill_between(
        v.tau,
        np.sqrt(v.sim_low),
        np.sqrt(v.sim_high),
        color="C0",
        alpha=0.2,
        label="simulated, chance band",
    )
    ax.loglog(v.tau, np.sqrt(v.sim_avar), "C0-", label="simulated")
    ax.loglog(v.tau, np.sqrt(v.real_avar), "C3o-", ms=3, label="real")
    best = diagnosis.best
    if best is not None:
        ax.loglog(v.tau, np.sqrt(best.sim_avar_after), "C2--", label=f"simulated + {best.effect}")
    for lo, hi in v.bands_s:
        ax.axvspan(lo, hi, color="C3", alpha=0.08)
    units = diagnosis.meta.get("units")
    ax.set_xlabel("averaging time tau [s]")
    ax.set_ylabel(f"Allan deviation [{units}]" if units else "Allan deviation")
    ax.set_title(f"tau view: G = {v.gap:.3g}, p = {v.p_value:.2g}")
    ax.legend(fontsize="small")


def plot_frequency_view(ax: Any, diagnosis: Any) -> None:
    """PSD ratio real/sim with its chance band and the detected lines."""
    v = diagnosis.frequency
    ax.fill_between(v.f, v.ratio_low, v.ratio_high, color="C0", alpha=0.2, label="chance band")
    ax.loglog(v.f, v.ratio, "C3-", lw=0.8, label="PSD real / sim")
    ax.axhline(1.0, color="k", lw=0.5)
    for line in v.lines:
        ax.axvline(line.frequency_hz, color="C1", ls=":", lw=1)
        ax.annotate(
            f"{line.frequency_hz:.4g} Hz",
            (line.frequency_hz, ax.get_ylim()[1]),
            fontsize="x-small",
            rotation=90,
            va="top",
        )
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("PSD ratio")
    ax.set_title(f"frequency view: p = {v.p_value:.2g}")
    ax.legend(fontsize="small")


def plot_time_view(ax: Any, diagnosis: Any) -> None:
    """Normalised per-window residuals with their thresholds and the flagged segments."""
    v = diagnosis.time
    for i, fam in enumerate(("level", "hf", "dyn")):
        ax.plot(v.t_s, v.z[fam], f"C{i}.-", lw=0.8, label=fam)
    edges = v.t_s[:-1] + v.window_s / 2
    ax.plot(edges, v.z["jump"], "C3.-", lw=0.8, label="jump")
    thr = max(v.thresholds.values())
    ax.axhline(thr, color="k", ls=":", lw=0.6)
    ax.axhline(-thr, color="k", ls=":", lw=0.6)
    for a, b in v.segments_s:
        ax.axvspan(a, max(b, a + v.window_s / 20), color="C3", alpha=0.1)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("normalised residual z")
    ax.set_title(f"time view: p = {v.p_value:.2g}")
    ax.legend(fontsize="small", ncol=4)


def diagnosis_figure(diagnosis: Any, *, figsize: tuple[float, float] = (8.0, 10.0)) -> Any:
    """Build a three-panel figure (tau, frequency, time views) of a diagnosis."""
    fig = _figure_class()(figsize=figsize, layout="constrained")
    axes = fig.subplots(3, 1)
    plot_tau_view(axes[0], diagnosis)
    plot_frequency_view(axes[1], diagnosis)
    plot_time_view(axes[2], diagnosis)
    return fig
