"""The bias against temperature: block means of a record and the fitted thermal law."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

from allanite.plot.allan import _matplotlib

if TYPE_CHECKING:
    from allanite.fit.thermal import ThermalFit
    from allanite.io.record import Record

__all__ = ["thermal_figure"]


def thermal_figure(
    record: Record, fit: ThermalFit, channel: int = 0, *, compensated: bool = False
) -> Any:
    """Bias versus temperature: the fit's block means and its law, in customary units.

    Parameters
    ----------
    record : Record
        The record the fit was made on (``compensated=True``: after
        :func:`allanite.fit.thermal.compensate_thermal`).
    fit : ThermalFit
        The channel's thermal fit.
    channel : int
        Column of ``record``.
    compensated : bool
        Whether ``record`` has its thermal bias removed already (it is added back).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from allanite.fit.thermal import bias_blocks

    temperature, bias = bias_blocks(record, fit, channel, compensated=compensated)
    scale, unit = fit.display_scale()
    fig = _matplotlib()(figsize=(6.4, 4.2), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(temperature, bias * scale, ".", ms=3, alpha=0.6, label=f"{fit.n_blocks} block means")
    grid = np.linspace(float(temperature.min()), float(temperature.max()), 200)
    polynomial = dataclasses.replace(fit.model, rate=None)
    label = f"fit, degree {fit.degree}" + ("" if fit.model.rate is None else " (no lag term)")
    # the level through the points (the GLS intercept of a record with a random walk is the
    # walk's level at its start, not the mean bias)
    offset = float(np.mean(bias - polynomial.bias(temperature)))
    law = offset + polynomial.bias(grid)
    ax.plot(grid, law * scale, "k-", lw=1.5, label=label)
    value, low, high, sens_unit = fit.customary_sensitivity()
    ax.set_xlabel("temperature [°C]")
    ax.set_ylabel(f"bias [{unit}]")
    ax.set_title(
        f"{fit.channel}: {value:.3g} {sens_unit} [{low:.3g}, {high:.3g}] ({100 * fit.level:g} %)",
        fontsize=10,
    )
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return fig
