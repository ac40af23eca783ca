"""Issue 30 items 6-14: what a new user's first hour tripped over in outputs and plausibility."""

from __future__ import annotations

import csv
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
