"""The Python examples of README.md and docs/ run as written, on records made here.

A notebook user copies the quick start; the names it leaves to the reader (``gyro.npy``,
``gyro.csv``, ``theta``, ``dtheta``, ``accel_x``, a model JSON) are made first, with known
coefficients, so a block that raises or prints wrong numbers fails here.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from allanite.model import NoiseModel
from allanite.terms import Flicker, White

ROOT = Path(__file__).resolve().parents[1]
FS = 100.0
N_DEG_S = 0.2 / 60.0  # white N = 0.2 deg/sqrt(h) in deg/sqrt(s)


def _python_blocks(path: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), re.S)


def _inputs(folder: Path) -> dict[str, Any]:
    """The records and the names the examples leave to the reader, white N = 0.2 deg/sqrt(h)."""
    model = NoiseModel([White(N_DEG_S), Flicker(5e-4)], units={"rate": "deg/s", "time": "s"})
    rate = model.simulate(2**16, fs=FS, output="rate", n_channels=3, seed=4)
    np.save(folder / "gyro.npy", rate)
    t = np.arange(rate.shape[0]) / FS
    np.savetxt(folder / "gyro.csv", np.column_stack([t, rate[:, 0]]), delimiter=",",
               header="t,gz", comments="")  # fmt: skip
    model.save(folder / "sim_model.json")
    model.save(folder / "gyro_model.json")
    rng = np.random.default_rng(5)
    return {
        "theta": np.cumsum(rate[:, 1]) / FS,
        "dtheta": rate[:, 2] / FS,
        "accel_x": rng.normal(0.0, 0.5, 2**16),  # mg: N = 0.05 mg*sqrt(s) = 50 ug/sqrt(Hz)
        "real": rate[:, 0],
    }


def test_readme_quick_start_runs_and_saves_its_figures(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("matplotlib")
    pytest.importorskip("pandas")
    (block,) = _python_blocks(ROOT / "README.md")
    monkeypatch.chdir(tmp_path)
    scope = _inputs(tmp_path)
    exec(compile(block, "README.md quick start", "exec"), scope)
    for name in ("adev.png", "fit.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    fit = scope["f"]
    n = fit.coefficients["N"]
    assert n.unit == "deg/sqrt(s)"
    lo, hi = n.ci(0.999)
    assert lo <= N_DEG_S <= hi
    rows = {r["name"]: r for r in fit.table(units="deg/h")}
    assert rows["N"]["unit"] == "deg/sqrt(h)"
    assert rows["N"]["value"] == pytest.approx(n.value * 60.0, rel=1e-12)
    assert NoiseModel.load(tmp_path / "model.json") == fit.model
    acc = {r["name"]: r for r in scope["acc"].table(units="ug")}
    assert acc["N"]["unit"] == "ug/sqrt(Hz)"
    assert acc["N"]["low"] <= 50.0 <= acc["N"]["high"]


@pytest.mark.parametrize("doc", ["diagnosis.md", "impact.md"])
def test_docs_python_examples_run(
    doc: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("pandas")
    monkeypatch.chdir(tmp_path)
    scope = _inputs(tmp_path)
    blocks = _python_blocks(ROOT / "docs" / doc)
    assert blocks
    for block in blocks:
        exec(compile(block, doc, "exec"), scope)
    if doc == "diagnosis.md":  # the real record is a record of the model itself
        assert not scope["d"].significant
        assert scope["d"].best is None
    else:
        table = scope["budget"].table_frame()
        assert {"gyro", "accel", "all"} <= set(table["sensor"])
        assert (table["sigma"] > 0).all()
