"""Figures of the impact module (matplotlib, Agg canvas)."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("matplotlib")

import allanite
from allanite.impact import MarkovNoise, SensorNoise, error_budget, optimal_complementary_filter
from allanite.plot.impact import complementary_filter_figure, error_budget_figure


def test_error_budget_figure_draws_every_component(tmp_path):
    gyro = SensorNoise(constant=1e-6, white=2e-6, markov=(MarkovNoise(5e-6, 300.0),))
    accel = SensorNoise(white=5e-4)
    budget = error_budget(gyro, accel, t=np.geomspace(1, 1e5, 40))
    fig = error_budget_figure(budget, title="budget")
    axes = fig.get_axes()
    assert len(axes) == 4
    # tilt panel: 3 gyro components x (exact, short, long) + total, in degrees
    tilt = axes[0]
    assert len(tilt.get_lines()) == 3 * 3 + 1 + 1  # + Schuler-period marker
    total = tilt.get_lines()[-2]
    np.testing.assert_allclose(total.get_ydata(), budget.total("vertical") * 180 / math.pi)
    # the velocity panel also holds the accelerometer row
    assert len(axes[2].get_lines()) == 4 * 3 + 1 + 1
    out = tmp_path / "budget.png"
    fig.savefig(out)
    assert out.stat().st_size > 10_000


def test_complementary_filter_figure(tmp_path):
    filt = optimal_complementary_filter(2e-3, 2e-2, dt=0.01)
    rng = np.random.default_rng(3)
    out = filt.apply(rng.standard_normal(20_000) * 0.02, rng.standard_normal(20_000) * 0.2)
    res = allanite.avar(out, fs=100.0, input="angle", taus="octave", alpha=0)
    fig = complementary_filter_figure(filt, res)
    ax = fig.get_axes()[0]
    labels = [line.get_label() for line in ax.get_lines()]
    assert labels[:4] == ["output", "exact", "slope −1/2", "slope −1"]
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), res.dev)
    fig.savefig(tmp_path / "cf.png")


def test_bad_quantity():
    budget = error_budget(SensorNoise(white=1e-6), t=[1.0, 10.0])
    with pytest.raises(ValueError, match="quantity"):
        error_budget_figure(budget, quantities=("altitude",))
    with pytest.raises(ValueError, match="at least one"):
        error_budget_figure(budget, quantities=())
