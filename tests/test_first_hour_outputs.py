"""Issue 30 items 6-14: what a new user's first hour tripped over in outputs and plausibility."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import allanite
from allanite.cli import main


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def _white(tmp_path: Path, n: int = 20000, seed: int = 3) -> Path:
    path = tmp_path / "white.npy"
    np.save(path, np.random.default_rng(seed).normal(0.0, 0.01, n))
    return path


def test_analyze_csv_names_and_holds_the_requested_level(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Item 6: ``-o a.csv --level 0.95`` writes the 95 % interval, named dev_low_95."""
    rec = _white(tmp_path)
    out_csv = tmp_path / "a.csv"
    code, _, err = _run(
        ["analyze", str(rec), "--fs", "100", "--level", "0.95", "-o", str(out_csv)], capsys
    )
    assert code == 0, err
    with out_csv.open() as fh:
        rows = list(csv.DictReader(fh))
    assert "dev_low_95" in rows[0]
    assert "dev_high_95" in rows[0]
    assert "dev_low_68" not in rows[0]
    expected = allanite.avar(np.load(rec), fs=100.0)
    lo, hi = expected.ci(0.95)
    np.testing.assert_allclose([float(r["dev_low_95"]) for r in rows], lo, rtol=1e-12)
    np.testing.assert_allclose([float(r["dev_high_95"]) for r in rows], hi, rtol=1e-12)


@pytest.mark.parametrize("flag", ["--version", "--help"])
def test_version_and_help_import_no_numerics(flag: str) -> None:
    """Item 11: ``allanite --version``/``--help`` answer without loading numpy/scipy/matplotlib."""
    code = (
        "import sys\n"
        "from allanite.cli import main\n"
        "try:\n"
        f"    main([{flag!r}])\n"
        "except SystemExit:\n"
        "    pass\n"
        "heavy = sorted(m for m in ('numpy', 'scipy', 'matplotlib') if m in sys.modules)\n"
        "print('HEAVY', heavy)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "HEAVY []" in done.stdout, done.stdout[-400:]
    assert "allanite" in done.stdout


def test_lazy_package_keeps_fit_and_batch_the_functions() -> None:
    """Item 11: importing the subpackages allanite.fit/.batch does not hide the functions."""
    import allanite.batch as batch_module  # noqa: F401
    import allanite.fit.api

    assert callable(allanite.fit)
    assert callable(allanite.batch)
    assert allanite.avar is allanite.variance.avar


def _timed_csv(tmp_path: Path, rate: float = 100.0, n: int = 2000) -> Path:
    t = np.arange(n) / rate
    x = np.random.default_rng(1).normal(0.0, 0.01, n)
    path = tmp_path / "timed.csv"
    np.savetxt(path, np.column_stack([t, x]), delimiter=",", header="time,gx", comments="")
    return path


def test_fs_contradicting_the_time_column_is_refused_until_one_is_chosen(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Item 13: --fs 10 on a 100 Hz time column: refused, naming --fs-source; then obeyed."""
    path = _timed_csv(tmp_path)
    base = ["analyze", str(path), "--time-column", "time", "--fs", "10", "--json"]
    code, out, err = _run(base, capsys)
    assert code == 2
    assert out == ""
    assert "--fs-source time" in err
    assert "--fs-source fs" in err
    assert "10x apart" in err
    for source, rate in (("time", 100.0), ("fs", 10.0)):
        code, out, err = _run([*base, "--fs-source", source], capsys)
        assert code == 0, err
        assert json.loads(out)["record"]["fs"] == pytest.approx(rate)


def test_bag_with_one_noisy_gyro_axis_analyses_it_and_names_the_constant_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Item 14: a ROS 2 bag with noise on gyro_z only: gyro_z analysed, the rest named."""
    pytest.importorskip("rosbags")
    from test_io_robot_logs import write_bag

    n = 1200
    data = np.zeros((n, 6))
    data[:, 5] = 9.81
    data[:, 2] = np.random.default_rng(5).normal(0.0, 0.01, n)
    path = tmp_path / "sim_bag"
    write_bag(path, "sqlite3", data, np.arange(n) / 200.0)
    code, out, err = _run(["analyze", str(path), "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["allan"]["channels"] == ["gyro_z"]
    warning = next(line for line in err.splitlines() if "constant" in line)
    for name in ("gyro_x", "gyro_y", "accel_x", "accel_y", "accel_z"):
        assert name in warning
    assert "analysing gyro_z" in warning
