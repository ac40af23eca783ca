"""Notebook display: AllanResult, FitResult and Diagnosis as a compact table with the plot."""

from __future__ import annotations

import base64
import dataclasses
import re
import sys

import numpy as np
import pytest

import allanite
from allanite.model import NoiseModel
from allanite.terms import White

RNG = np.random.default_rng(21)
FS = 100.0


def _png_of(html: str) -> bytes:
    match = re.search(r'src="data:image/png;base64,([^"]+)"', html)
    assert match is not None, "no inline plot"
    return base64.b64decode(match.group(1))


def test_allan_result_table_and_plot() -> None:
    x = RNG.standard_normal((20_000, 2)) * 0.01
    result = allanite.avar(x, fs=FS, units="deg/s")
    html = result._repr_html_()
    assert html.startswith('<div class="allanite-result">')
    assert "AllanResult: overlapping deviation of 20000 rate samples at 100 Hz" in html
    assert "<th>deviation 0 [deg/s]</th>" in html
    assert "<th>deviation 1 [deg/s]</th>" in html
    # the first row holds the first tau and both channels' deviations (4 significant digits)
    first = re.search(r"<tbody><tr>(.*?)</tr>", html)
    assert first is not None
    cells = re.findall(r"<td>(.*?)</td>", first.group(1))
    assert float(cells[0]) == pytest.approx(result.tau[0])
    assert float(cells[1]) == pytest.approx(result.dev[0, 0], rel=1e-3)
    assert float(cells[3]) == pytest.approx(result.dev[0, 1], rel=1e-3)
    # 80-odd taus: the middle is elided, the last tau is still shown
    assert f"… {result.tau.size - 12} more rows …" in html
    assert f"<td>{result.tau[-1]:.4g}</td>" in html
    assert _png_of(html)[:8] == b"\x89PNG\r\n\x1a\n"


def test_fit_result_table_with_goodness_of_fit() -> None:
    x = RNG.standard_normal(40_000) * 0.01
    fitted = allanite.fit(allanite.avar(x, fs=FS, units="deg/s"))
    html = fitted._repr_html_()
    assert "FitResult (gls): white" in html
    row = fitted.table("customary", 0.95)[0]  # as allanite fit prints it
    assert row["unit"] == "deg/sqrt(h)"
    assert f"<td>N</td><td>{row['value']:.4g}</td>" in html
    assert "<td>deg/sqrt(h)</td>" in html
    assert f"{row['low']:.4g} – {row['high']:.4g}" in html
    assert f"chi² = {fitted.chi2:.4g} for {fitted.dof} dof" in html
    assert "model not rejected" in html
    assert _png_of(html)[:4] == b"\x89PNG"


def test_diagnosis_table_with_attribution() -> None:
    t = np.arange(8000) / FS
    real = RNG.standard_normal(t.size) * 0.01 + 0.01 * np.sin(2 * np.pi * 3.0 * t)
    model = NoiseModel([White(0.001)], units={"rate": "deg/s", "time": "s"})
    diagnosis = allanite.diagnose(real, model, fs=FS, n_mc=20, seed=1)
    html = diagnosis._repr_html_()
    assert "<strong>Diagnosis</strong>" in html
    assert f"<td>p-value</td><td>{diagnosis.p_value:.4g}</td>" in html
    verdict = "differ beyond chance" if diagnosis.significant else "agree within chance"
    assert verdict in html
    if diagnosis.attribution:
        assert "<caption>attribution, best first</caption>" in html
        assert f"<td>{diagnosis.attribution[0].effect}</td>" in html
    assert _png_of(html)[:4] == b"\x89PNG"


def test_without_matplotlib_the_table_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    result = allanite.avar(RNG.standard_normal(5000), fs=FS)
    for name in [n for n in sys.modules if n == "matplotlib" or n.startswith("matplotlib.")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    html = result._repr_html_()
    assert "<table" in html
    assert "<img" not in html


def test_text_is_escaped() -> None:
    # avar refuses such a unit; a result built by hand (or unpickled) may still carry markup
    result = dataclasses.replace(
        allanite.avar(RNG.standard_normal(5000), fs=FS, units="deg/s"), units="<b>deg/s</b>"
    )
    html = result._repr_html_()
    assert "<b>deg/s</b>" not in html
    assert "&lt;b&gt;deg/s&lt;/b&gt;" in html
