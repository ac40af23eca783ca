"""Plots: error bars are the CI, overlays, model terms with their slope labels, export."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")

import allanite
from allanite.model import NoiseModel
from allanite.plot import allan_figure, figure_bytes, model_figure, save_figure
from allanite.plot.allan import slope_of
from allanite.terms import TERM_TYPES

RNG = np.random.default_rng(9)
FS = 100.0
X = RNG.normal(size=(5000, 2))


def test_error_bars_are_the_confidence_interval() -> None:
    result = allanite.avar(X, fs=FS, points=15, units="deg/s")
    fig = allan_figure(result, labels=["gx", "gy"], level=0.95)
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["gx", "gy"]
    assert ax.get_xscale() == "log"
    assert "[deg/s]" in ax.get_ylabel()
    container = ax.containers[0]
    segments = container.lines[2][0].get_segments()
    lo, hi = result.channel(0).ci(0.95)
    np.testing.assert_allclose([s[0][1] for s in segments], lo, rtol=1e-12)
    np.testing.assert_allclose([s[1][1] for s in segments], hi, rtol=1e-12)


def test_overlay_of_several_results_and_label_check() -> None:
    a = allanite.avar(X[:, 0], fs=FS, points=10)
    b = allanite.avar(X[:, 1] * 2, fs=FS, points=10)
    fig = allan_figure([a, b], labels=["device", "reference"])
    assert len(fig.axes[0].containers) == 2
    with pytest.raises(ValueError, match="3 labels for 2 curves"):
        allan_figure([a, b], labels=["x", "y", "z"])


@pytest.mark.parametrize(
    ("exponent", "label"),
    [(-1.0, "−1"), (-0.5, "−1/2"), (0.0, "0"), (0.5, "+1/2"), (1.0, "+1"), (0.25, None)],
)
def test_slope_labels(exponent: float, label: str | None) -> None:
    tau = np.geomspace(0.01, 100, 30)
    assert slope_of(tau, 3.0 * tau**exponent) == label


def test_model_figure_draws_each_term_with_its_slope() -> None:
    model = NoiseModel(
        terms=(
            TERM_TYPES["quantization"](Q=2e-3),
            TERM_TYPES["white"](N=5e-3),
            TERM_TYPES["rrw"](K=2e-4),
        ),
        units={"rate": "deg/s", "time": "s"},
    )
    dt = 1.0 / FS
    x = RNG.normal(size=50_000) * model.terms[1].N / np.sqrt(dt)
    result = allanite.avar(x, fs=FS, points=40, units="deg/s")
    fig = model_figure(result, model, labels=["gx"])
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.texts]
    assert sorted(labels) == sorted(["slope −1", "slope −1/2", "slope +1/2"])
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "fitted model" in legend
    assert any(entry.startswith("white") for entry in legend)
    # the black model curve is the square root of the summed exact term variances
    model_line = next(line for line in ax.lines if line.get_label() == "fitted model")
    tau = model_line.get_xdata()
    np.testing.assert_allclose(model_line.get_ydata(), np.sqrt(model.avar(tau, dt)), rtol=1e-12)


def test_export_formats_and_atomicity(tmp_path: Path) -> None:
    fig = allan_figure(allanite.avar(X[:, 0], fs=FS, points=8))
    for suffix, magic in ((".png", b"\x89PNG"), (".svg", b"<?xml"), (".pdf", b"%PDF")):
        path = tmp_path / f"adev{suffix}"
        save_figure(fig, path)
        assert path.read_bytes()[: len(magic)] == magic
    with pytest.raises(ValueError, match=r"use a \.png, \.svg or \.pdf"):
        save_figure(fig, tmp_path / "adev.jpg")
    assert not (tmp_path / "adev.jpg").exists()
    assert figure_bytes(fig)[:4] == b"\x89PNG"
