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
        diagnose(x, model, fs=FS, effects=["white", "bogus"])
    with pytest.raises(ValueError, match=r"rescale:<term type> \(.*white"):
        diagnose(x, model, fs=FS, effects=["rescale:nonsense"])
    with pytest.raises(ValueError, match="no effect given"):
        diagnose(x, model, fs=FS, effects=[])
    rec = tmp_path / "real.npy"
    np.save(rec, x)
    path = tmp_path / "model.json"
    model.save(path)
    argv = ["diagnose", str(rec), "--fs", "100", "--units", "deg/s", "--sim-model", str(path)]
    argv.append("--json")
    assert main([*argv, "--effects", "white,bogus"]) == 2
    line = _one_line_error(capsys, "diagnose")
    assert "unknown effect(s) 'bogus'; known effects: white, quantization, flicker" in line
    # known names, including rescale forms, are accepted
    assert main([*argv, "--effects", "white,rescale:white,rescale", "--n-mc", "20"]) == 0


def test_datasheet_unknown_quantity_is_refused_not_missing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: a typo in a limit's quantity was reported as MISSING with exit code 0."""
    from allanite.datasheet import Datasheet
    from allanite.errors import InputError

    sheet = tmp_path / "limits.json"
    sheet.write_text(
        '{"limits": [{"quantity": "N", "max": 1, "unit": "deg/sqrt(h)"},'
        ' {"quantity": "Bias", "max": 10, "unit": "deg/h"}]}'
    )
    match = r"limits\[1\]: unknown quantity 'Bias' \(did you mean 'B'"
    with pytest.raises(InputError, match=match):
        Datasheet.load(sheet)
    rec = tmp_path / "rec.npy"
    np.save(rec, RNG.standard_normal(20_000) * 0.01)
    argv = ["fit", str(rec), "--fs", "100", "--units", "deg/s", "--datasheet", str(sheet)]
    assert main(argv) == 2
    line = _one_line_error(capsys, "fit")
    assert "unknown quantity 'Bias'" in line
    assert "use adev or a noise coefficient: B, K, N, Q, R," in line
    # the real names, a suffixed label and the compact form are accepted
    Datasheet.from_dict({"sigma_2": 1.0, "N": {"max": 1.0}})
    Datasheet.from_dict({"limits": [{"quantity": "adev", "tau": 1, "max": 1, "unit": "deg/s"}]})
    with pytest.raises(InputError, match=r"entry 'ARW': unknown quantity 'ARW' \(did you mean 'N'"):
        Datasheet.from_dict({"ARW": 0.1})


def _model_file(tmp_path: Path) -> Path:
    path = tmp_path / "model.json"
    NoiseModel([White(0.001)], units={"rate": "deg/s", "time": "s"}).save(path)
    return path


def test_simulate_refuses_an_output_larger_than_the_free_space(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: simulate -n 1000000000000 started writing an 8 TB file."""
    import shutil
    from collections import namedtuple

    from allanite.simulation.writers import output_size, write_record

    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda _: usage(10**12, 0, 5 * 10**9))
    model = _model_file(tmp_path)
    out = tmp_path / "big.npy"
    assert main(["simulate", str(model), "--fs", "100", "-n", "1e12", "-o", str(out)]) == 2
    line = _one_line_error(capsys, "simulate")
    assert "cannot write" in line
    assert "big.npy: the record needs 8 TB but" in line
    assert "has 5 GB free; write fewer samples (-n, --duration)" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]
    with pytest.raises(OSError, match="needs 8 TB"):
        write_record(out, NoiseModel.load(model), 10**12, fs=100.0)
    # sizes: exact for .npy/raw, an upper bound for CSV
    assert output_size("a.bin", 1000, 3) == 24_000
    assert output_size("a.npy", 1000, 3) == 24_128


def test_simulate_says_what_it_wrote(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = _model_file(tmp_path)
    for name, channels in (("s.npy", 1), ("s.csv", 2)):
        out = tmp_path / name
        argv = ["simulate", str(model), "--fs", "100", "--duration", "1h", "--seed", "3"]
        assert main([*argv, "--channels", str(channels), "-o", str(out)]) == 0
        printed, err = capsys.readouterr()
        assert err == ""
        size = out.stat().st_size
        axes = " x 2 channels" if channels == 2 else ""
        assert printed == (
            f"wrote {out}: 360000 samples{axes} of rate [deg/s] at 100 Hz (1 h, seed 3), "
            f"{size / 1e6:.3g} MB\n"
        )
    assert main([*argv, "-o", str(tmp_path / "q.npy"), "--quiet"]) == 0
    assert capsys.readouterr() == ("", "")


def test_negative_channel_indices_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: --channels -1 silently took the last column."""
    from allanite.errors import InputError
    from allanite.io import read_record

    path = tmp_path / "three.npy"
    np.save(path, RNG.standard_normal((1000, 3)))
    assert main(["analyze", str(path), "--fs", "100", "--channels", "-1"]) == 2
    line = _one_line_error(capsys, "analyze")
    assert "column -1: columns are numbered from 0 to 2; negative indices are not accepted" in line
    with pytest.raises(InputError, match="negative indices are not accepted"):
        read_record(path, fs=100.0, columns=[0, -2])
    with pytest.raises(InputError, match="negative indices"):
        read_record(path, fs=100.0, time_column=-1)
    record = read_record(path, fs=100.0)
    with pytest.raises(ValueError, match=r"channel -1: channels are numbered from 0 to 2"):
        record.select([-1])
    assert main(["analyze", "--example", "--channels", "-1"]) == 2
    assert "negative indices are not accepted" in _one_line_error(capsys, "analyze")
    assert record.select([2]).channels == (record.channels[2],)
