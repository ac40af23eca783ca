"""Regression tests of a new user's first hour: inputs that failed for the wrong reason."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from allanite.cli import main
from allanite.diagnosis import diagnose
from allanite.model import NoiseModel
from allanite.terms import White

RNG = np.random.default_rng(16)
FS = 100.0


def _one_line_error(capsys: pytest.CaptureFixture[str], command: str) -> str:
    out, err = capsys.readouterr()
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"allanite {command}: error: ")
    return lines[0]


def test_unknown_diagnose_effects_are_refused_with_the_known_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    x = RNG.standard_normal(4000) * 0.01
    model = NoiseModel([White(0.001)], units={"rate": "deg/s", "time": "s"})
    with pytest.raises(ValueError, match=r"unknown effect\(s\) 'bogus'; known effects: white, "):
        diagnose(x, model, FS, effects=["white", "bogus"])
    with pytest.raises(ValueError, match=r"rescale:<term type> \(.*white"):
        diagnose(x, model, FS, effects=["rescale:nonsense"])
    with pytest.raises(ValueError, match="no effect given"):
        diagnose(x, model, FS, effects=[])
    rec = tmp_path / "real.npy"
    np.save(rec, x)
    path = tmp_path / "model.json"
    model.save(path)
    argv = ["diagnose", str(rec), "--fs", "100", "--sim-model", str(path), "--json"]
    assert main([*argv, "--effects", "white,bogus"]) == 2
    line = _one_line_error(capsys, "diagnose")
    assert "unknown effect(s) 'bogus'; known effects: white, quantization, flicker" in line
    # known names, including rescale forms, are accepted
    assert main([*argv, "--effects", "white,rescale:white,rescale", "--n-mc", "20"]) == 0
