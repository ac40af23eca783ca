"""A missing optional extra: exit code 2 and one line naming the extra, never a traceback.

Each ``test_without_<dep>`` hides one optional dependency (and its already imported
submodules) from the import system and runs what needs it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import allanite
from allanite.cli import main
from allanite.errors import MissingExtraError
from allanite.io.readers import read_record

RNG = np.random.default_rng(3)
SAMPLES = RNG.standard_normal((2000, 2))


def _hide(monkeypatch: pytest.MonkeyPatch, package: str) -> None:
    """Make ``import package`` (and ``import package.anything``) fail."""
    for name in [n for n in sys.modules if n == package or n.startswith(package + ".")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, package, None)


def _one_line_rc2(
    argv: list[str], capsys: pytest.CaptureFixture[str], extra: str, command: str
) -> str:
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2, err
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"allanite {command}: error: ")
    assert f'pip install "allanite[{extra}]"' in lines[0]
    return lines[0]


def _npy(tmp_path: Path) -> Path:
    path = tmp_path / "rec.npy"
    np.save(path, SAMPLES)
    return path


def test_without_h5py(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "rec.h5"
    path.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(100))
    _hide(monkeypatch, "h5py")
    line = _one_line_rc2(["analyze", str(path), "--fs", "100"], capsys, "hdf5", "analyze")
    assert "reading HDF5 needs h5py" in line
    with pytest.raises(MissingExtraError, match=r'pip install "allanite\[hdf5\]"') as info:
        read_record(path, fs=100.0)
    assert isinstance(info.value, ImportError)
    assert info.value.extra == "hdf5"


def test_without_pyarrow(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "rec.parquet"
    path.write_bytes(b"PAR1" + bytes(100))
    _hide(monkeypatch, "pyarrow")
    line = _one_line_rc2(["analyze", str(path), "--fs", "100"], capsys, "parquet", "analyze")
    assert "reading Parquet needs pyarrow" in line


def test_without_matplotlib(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _npy(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    _hide(monkeypatch, "matplotlib")
    argv = ["analyze", str(path), "--fs", "100", "--plot", str(out / "a.png")]
    line = _one_line_rc2([*argv, "-o", str(out / "a.csv")], capsys, "plot", "analyze")
    assert "plotting needs matplotlib" in line
    assert list(out.iterdir()) == []  # no partial output
    report = ["report", str(path), "--fs", "100", "-o", str(out / "r.html"), "--no-fit"]
    _one_line_rc2(report, capsys, "plot", "report")
    assert list(out.iterdir()) == []


def test_without_pyside6(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _hide(monkeypatch, "PySide6")
    line = _one_line_rc2(["gui", "--example"], capsys, "gui", "gui")
    assert "the GUI needs PySide6" in line


def test_without_dask(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _npy(tmp_path)
    _hide(monkeypatch, "distributed")
    argv = ["batch", str(path), "--fs", "100", "--dask", "local:1", "--json"]
    line = _one_line_rc2(argv, capsys, "dask", "batch")
    assert "--dask needs distributed" in line
    with pytest.raises(MissingExtraError, match=r'pip install "allanite\[dask\]"'):
        allanite.batch([("a", SAMPLES[:, 0])], fs=100.0, client=object())


def test_without_tqdm(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _npy(tmp_path)
    _hide(monkeypatch, "tqdm")
    argv = ["batch", str(path), "--fs", "100", "--progress", "--json"]
    line = _one_line_rc2(argv, capsys, "progress", "batch")
    assert "--progress needs tqdm" in line
    # a bar nobody asked for explicitly is simply not drawn
    assert main(["batch", str(path), "--fs", "100", "--json"]) == 0
    assert capsys.readouterr().err == ""


def test_without_pandas(monkeypatch: pytest.MonkeyPatch) -> None:
    result = allanite.avar(SAMPLES[:, 0], fs=100.0, taus="octave")
    _hide(monkeypatch, "pandas")
    with pytest.raises(MissingExtraError, match=r'to_frame\(\) needs pandas.*"allanite\[pandas\]"'):
        result.to_frame()


def test_without_yaml(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from allanite.datasheet import Datasheet

    path = tmp_path / "sheet.yaml"
    path.write_text("N: 0.1\n")
    _hide(monkeypatch, "yaml")
    with pytest.raises(
        MissingExtraError, match=r'reading YAML datasheets needs pyyaml.*"allanite\[yaml\]"'
    ):
        Datasheet.load(path)


@pytest.mark.parametrize(
    ("suffix", "package", "extra", "said"),
    [
        (".bag", "rosbags", "bags", "reading ROS bags needs rosbags"),
        (".ulg", "pyulog", "ulog", "reading PX4 ULog needs pyulog"),
    ],
)
def test_without_robot_log_readers(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    suffix: str,
    package: str,
    extra: str,
    said: str,
) -> None:
    path = tmp_path / f"flight{suffix}"
    path.write_bytes(bytes(200))
    _hide(monkeypatch, package)
    line = _one_line_rc2(["analyze", str(path)], capsys, extra, "analyze")
    assert said in line


def test_without_yaml_for_a_simulator_config(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "imu.yaml"
    path.write_text("gyroscope_noise_density: 1.0e-4\ngyroscope_random_walk: 1.0e-6\n")
    _hide(monkeypatch, "yaml")
    out = tmp_path / "model.json"
    line = _one_line_rc2(["model", "convert", str(path), str(out)], capsys, "yaml", "model")
    assert "needs pyyaml" in line
    assert not out.exists()
