r"""Allan deviation plots: data with confidence error bars, overlays, fitted model and terms.

On a log-log Allan-deviation plot each standard noise term is a straight line whose slope
names it (IEEE Std 952-1997, Annex C): quantization :math:`\sqrt{3}Q/\tau` (slope -1), angle
random walk :math:`N/\sqrt{\tau}` (-1/2), bias instability :math:`0.664B` (0), rate random walk
:math:`K\sqrt{\tau/3}` (+1/2) and rate ramp :math:`R\tau/\sqrt{2}` (+1). The term curves drawn
here are each term's exact Allan deviation for the record's sample period
(:meth:`allanite.terms.base.Term.avar`), and the slope label is measured from that curve.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import NDArray

from allanite.confidence import DEFAULT_LEVEL
from allanite.extras import require

if TYPE_CHECKING:
    from allanite.variance import AllanResult

__all__ = ["SLOPE_LABELS", "allan_figure", "model_figure", "plot_allan", "plot_model", "slope_of"]


def _as_list(results: AllanResult | Sequence[AllanResult]) -> list[AllanResult]:
    """The results as a list: one result (it has ``tau``) or a sequence of them.

    Duck-typed so that plotting does not import :mod:`allanite.variance` (which sits below).
    """
    if hasattr(results, "tau"):
        return [cast("AllanResult", results)]
    return list(results)


#: canonical log-log slopes of the Allan deviation and their labels
SLOPE_LABELS: dict[float, str] = {-1.0: "−1", -0.5: "−1/2", 0.0: "0", 0.5: "+1/2", 1.0: "+1"}
_SLOPE_TOLERANCE = 0.06

_DEV_LABELS = {
    "overlapping": "Allan deviation (overlapping)",
    "standard": "Allan deviation",
    "modified": "modified Allan deviation",
    "hadamard": "Hadamard deviation (overlapping)",
    "standard_hadamard": "Hadamard deviation",
    "total": "total deviation",
    "time": "time deviation",
}


def _matplotlib() -> Any:
    return require("matplotlib.figure", extra="plot", purpose="plotting").Figure


def _ylabel(result: AllanResult) -> str:
    name = _DEV_LABELS.get(result.kind, result.kind)
    return f"{name} [{result.units}]" if result.units else name


def plot_allan(
    ax: Any,
    results: AllanResult | Sequence[AllanResult],
    *,
    labels: Sequence[str] | None = None,
    level: float = DEFAULT_LEVEL,
    errorbars: bool = True,
) -> list[Any]:
    """Draw deviations with confidence error bars on ``ax`` (every channel of every result).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Target axes (set to log-log).
    results : AllanResult or sequence of AllanResult
        One result (all its channels are drawn) or several (overlaid, e.g. several devices).
    labels : sequence of str, optional
        One legend label per drawn curve (channels of the first result first).
    level : float
        Confidence level of the error bars (chi-square intervals from the EDF).
    errorbars : bool
        Draw the intervals as error bars.

    Returns
    -------
    list
        The drawn artists, one per curve.
    """
    items = _as_list(results)
    if not items:
        raise ValueError("nothing to plot: give at least one AllanResult")
    curves: list[tuple[AllanResult, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]]
    curves = []
    for result in items:
        dev = result.dev.reshape(result.tau.size, -1)
        lo, hi = (a.reshape(dev.shape) for a in result.ci(level))
        for c in range(dev.shape[1]):
            curves.append((result, dev[:, c], lo[:, c], hi[:, c]))
    if labels is not None and len(labels) != len(curves):
        raise ValueError(f"{len(labels)} labels for {len(curves)} curves; give one per curve")
    artists = []
    for k, (result, dev, lo, hi) in enumerate(curves):
        label = labels[k] if labels is not None else (f"channel {k}" if len(curves) > 1 else None)
        if errorbars:
            yerr = np.vstack([dev - lo, hi - dev])
            artist = ax.errorbar(
                result.tau,
                dev,
                yerr=yerr,
                fmt="o-",
                ms=3,
                lw=1.2,
                elinewidth=0.8,
                capsize=2,
                label=label,
            )
        else:
            (artist,) = ax.plot(result.tau, dev, "o-", ms=3, lw=1.2, label=label)
        artists.append(artist)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("averaging time τ [s]")
    ax.set_ylabel(_ylabel(items[0]))
    ax.grid(True, which="major", alpha=0.5)
    ax.grid(True, which="minor", alpha=0.15)
    if any(label is not None for label in (labels or [])) or len(curves) > 1:
        ax.legend(fontsize="small")
    return artists


def slope_of(tau: NDArray[np.float64], dev: NDArray[np.float64]) -> str | None:
    """Label of the canonical log-log slope of a curve, or None when it is not straight.

    A curve is labelled with a canonical value (-1, -1/2, 0, +1/2, +1) when its median local
    log-log slope lies within 0.06 of it and at least 80 % of the local slopes do (an exact
    sampled term bends near ``tau = dt``, e.g. rate random walk, without changing its name).
    """
    good = (dev > 0) & np.isfinite(dev)
    if good.sum() < 3:
        return None
    lt, ld = np.log(tau[good]), np.log(dev[good])
    local = np.diff(ld) / np.diff(lt)
    median = float(np.median(local))
    for value, label in SLOPE_LABELS.items():
        close = np.abs(local - value) < _SLOPE_TOLERANCE
        if abs(median - value) < _SLOPE_TOLERANCE and close.mean() >= 0.8:
            return label
    return None


def _terms_of(model: Any) -> list[Any]:
    inner = getattr(model, "model", model)
    terms = getattr(inner, "terms", inner)
    return list(terms)


def _term_name(term: Any) -> str:
    symbol = getattr(term, "symbol", "")
    kind = getattr(term, "type", type(term).__name__)
    return f"{kind} ({symbol})" if symbol else str(kind)


def plot_model(
    ax: Any,
    model: Any,
    tau: NDArray[np.float64],
    dt: float,
    *,
    terms: bool = True,
    ylim: tuple[float, float] | None = None,
) -> None:
    """Draw a noise model's Allan deviation and (optionally) each term with its slope label.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Target axes.
    model : NoiseModel, FitResult or sequence of Term
        Anything with ``terms`` (a FitResult's ``model`` is used).
    tau : numpy.ndarray
        Averaging times to draw over, in seconds (multiples of ``dt``).
    dt : float
        Sample period of the record in seconds.
    terms : bool
        Draw each term's own curve, dashed, with its slope label.
    ylim : tuple of float, optional
        Visible deviation range; labels are placed inside it.
    """
    items = _terms_of(model)
    if not items:
        raise ValueError("the model has no terms to draw")
    curves = [np.asarray(t.avar(tau, dt), dtype=np.float64) for t in items]
    total = np.sum(curves, axis=0)
    ax.plot(tau, np.sqrt(np.clip(total, 0, None)), "-", color="black", lw=2.0, label="fitted model")
    if not terms:
        return
    for term, var in zip(items, curves, strict=True):
        dev = np.sqrt(np.clip(var, 0, None))
        (line,) = ax.plot(tau, dev, "--", lw=1.1, label=_term_name(term))
        slope = slope_of(tau, dev)
        visible = dev > 0
        if ylim is not None:
            visible &= (dev > ylim[0]) & (dev < ylim[1])
        if slope is None or not visible.any():
            continue
        share = np.where(visible, var / np.where(total > 0, total, 1.0), -1.0)
        k = int(np.argmax(share))
        right = k > 0.8 * (tau.size - 1)  # keep labels near the right edge inside the axes
        ax.annotate(
            f"slope {slope}",
            (tau[k], dev[k]),
            xytext=(-6 if right else 4, 6),
            textcoords="offset points",
            ha="right" if right else "left",
            fontsize="small",
            color=line.get_color(),
            bbox={
                "boxstyle": "round,pad=0.2",
                "fc": "white",
                "ec": line.get_color(),
                "alpha": 0.85,
            },
        )


def _model_tau(result: AllanResult, n: int = 200) -> NDArray[np.float64]:
    dt = 1.0 / result.fs
    m = np.unique(np.rint(np.geomspace(result.m.min(), result.m.max(), n)).astype(np.int64))
    return np.asarray(m * dt, dtype=np.float64)


def allan_figure(
    results: AllanResult | Sequence[AllanResult],
    *,
    labels: Sequence[str] | None = None,
    level: float = DEFAULT_LEVEL,
    title: str | None = None,
    model: Any = None,
    channel: int = 0,
    figsize: tuple[float, float] = (7.5, 5.0),
    layout: str | None = "constrained",
) -> Any:
    """Build a figure of Allan deviations with error bars, optionally with a fitted model.

    Parameters
    ----------
    results : AllanResult or sequence of AllanResult
        What to draw (multi-channel results and several results are overlaid).
    labels : sequence of str, optional
        Legend labels, one per curve.
    level : float
        Confidence level of the error bars.
    title : str, optional
        Axes title.
    model : NoiseModel or FitResult, optional
        Fitted model of ``results`` channel ``channel``; draws the model and each term's curve
        with its slope label (only that channel's data are drawn then).
    channel : int
        Channel the model belongs to.
    figsize : tuple of float
        Figure size in inches.
    layout : str or None
        Matplotlib layout engine; None uses fixed margins (much faster to redraw, for GUIs).

    Returns
    -------
    matplotlib.figure.Figure
    """
    figure_class = _matplotlib()
    fig = figure_class(figsize=figsize, layout=layout)
    if layout is None:
        fig.subplots_adjust(left=0.1, right=0.98, top=0.93, bottom=0.1)
    ax = fig.add_subplot()
    if model is None:
        plot_allan(ax, results, labels=labels, level=level)
    else:
        first = _as_list(results)[0]
        data = first.channel(channel)
        label = labels[channel] if labels is not None and len(labels) > channel else "data"
        plot_allan(ax, data, labels=[label], level=level)
        lo, hi = data.ci(level)
        ylim = (float(np.min(lo)) / 3.0, float(np.max(hi)) * 3.0)
        plot_model(ax, model, _model_tau(data), 1.0 / data.fs, ylim=ylim)
        ax.set_ylim(*ylim)
        ax.legend(fontsize="small")
    if title:
        ax.set_title(title, fontsize="medium")
    return fig


def model_figure(result: AllanResult, model: Any, **kwargs: Any) -> Any:
    """Shorthand for :func:`allan_figure` with a fitted model (data, model and its terms)."""
    return allan_figure(result, model=model, **kwargs)
