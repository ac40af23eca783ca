"""Atomic outputs: nothing is left behind on failure; the file gets an ordinary mode."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest

from allanite.io.atomic import atomic_output


def test_failure_leaves_nothing(tmp_path: Path) -> None:
    target = tmp_path / "out.csv"

    def write_then_fail() -> None:
        with atomic_output(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError):
        write_then_fail()
    assert list(tmp_path.iterdir()) == []


def test_success_mode_is_readable_and_kept_on_replace(tmp_path: Path) -> None:
    target = tmp_path / "report.html"
    with atomic_output(target) as tmp:
        tmp.write_text("<html></html>")
    assert stat.S_IMODE(target.stat().st_mode) == 0o644
    target.chmod(0o640)
    with atomic_output(target) as tmp:
        tmp.write_text("<html>2</html>")
    assert stat.S_IMODE(target.stat().st_mode) == 0o640
    assert target.read_text() == "<html>2</html>"


def test_missing_directory_is_named(tmp_path: Path) -> None:
    with (
        pytest.raises(OSError, match="does not exist; create it first"),
        atomic_output(tmp_path / "nope" / "x.csv"),
    ):
        pass
