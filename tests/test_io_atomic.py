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


def test_output_that_is_a_directory_is_named_in_words(tmp_path: Path) -> None:
    target = tmp_path / "adev.csv"
    target.mkdir()
    with (
        pytest.raises(OSError, match=r"cannot write .*adev.csv: it is a directory; give a file"),
        atomic_output(target),
    ):
        pass
    assert [p.name for p in tmp_path.iterdir()] == ["adev.csv"]


def _no_temp_name(message: str) -> None:
    assert "Errno" not in message
    assert ".out.csv." not in message  # the temporary sibling's name


def test_unwritable_directory_is_said_in_words(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import errno
    import tempfile

    def refuse(*args: object, dir: str, **kwargs: object) -> tuple[int, str]:
        raise PermissionError(errno.EACCES, "Permission denied", f"{dir}/.out.csv.abc123.csv")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    with (
        pytest.raises(OSError, match=r"cannot write .*out.csv: no permission to write in ") as info,
        atomic_output(tmp_path / "out.csv"),
    ):
        pass
    _no_temp_name(str(info.value))


@pytest.mark.parametrize(
    ("code", "words"),
    [("EROFS", "is on a read-only file system"), ("ENOSPC", "no space left on the device")],
)
def test_errors_of_the_temporary_file_name_the_output(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, code: str, words: str
) -> None:
    import errno
    import os

    def fail(src: str, dst: str) -> None:
        raise OSError(getattr(errno, code), os.strerror(getattr(errno, code)), src, dst)

    monkeypatch.setattr(os, "replace", fail)
    with (
        pytest.raises(OSError, match=rf"cannot write .*out.csv: .*{words}") as info,
        atomic_output(tmp_path / "out.csv") as tmp,
    ):
        tmp.write_text("x")
    _no_temp_name(str(info.value))
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_while_writing_names_the_output(tmp_path: Path) -> None:
    import errno

    with (
        pytest.raises(OSError, match=r"cannot write .*out.csv: no space left") as info,
        atomic_output(tmp_path / "out.csv"),
    ):
        raise OSError(errno.ENOSPC, "No space left on device")  # file.write has no name
    _no_temp_name(str(info.value))


def test_other_errors_in_the_block_pass_unchanged(tmp_path: Path) -> None:
    with (
        pytest.raises(FileNotFoundError, match=r"input\.npy"),
        atomic_output(tmp_path / "out.csv"),
    ):
        open(tmp_path / "input.npy", "rb")  # noqa: SIM115
    assert list(tmp_path.iterdir()) == []


def test_cli_directory_output_is_one_line_without_the_temporary_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import numpy as np

    from allanite.cli import main

    record = tmp_path / "rec.npy"
    np.save(record, np.random.default_rng(0).standard_normal(2000))
    (tmp_path / "adev.csv").mkdir()
    assert main(["analyze", str(record), "--fs", "100", "-o", str(tmp_path / "adev.csv")]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1
    assert "cannot write" in err
    assert "adev.csv: it is a directory" in err
    _no_temp_name(err)
    assert ".adev.csv." not in err
