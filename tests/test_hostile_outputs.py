"""Outputs never destroy: special files, links, inputs, SIGTERM (issue 31, items 1, 2, 10, 12).

Every command writes through :func:`allanite.io.atomic.atomic_output`; these tests run the
command line on a small white-noise record (plain numpy) and check what is left at the output
path and beside it.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from allanite.cli import main
from allanite.io.atomic import atomic_output, check_output_path, guard_inputs, note_input


@pytest.fixture
def record(tmp_path: Path) -> Path:
    path = tmp_path / "rec.npy"
    np.save(path, np.random.default_rng(31).normal(0.0, 0.01, 4000))
    return path


def _fit(record: Path, output: str) -> int:
    return main(["fit", str(record), "--fs", "100", "--units", "rad/s", "-o", output])


def _no_temporaries(directory: Path) -> None:
    assert [p.name for p in directory.iterdir() if p.name.startswith(".")] == []


def test_symlink_output_keeps_the_link_and_writes_its_target(tmp_path: Path, record: Path) -> None:
    target = tmp_path / "model.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    assert _fit(record, str(link)) == 0
    assert link.is_symlink()
    assert json.loads(target.read_text())  # the target holds the model
    _no_temporaries(tmp_path)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_fifo_output_is_written_through_not_replaced(tmp_path: Path, record: Path) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    reader = subprocess.Popen(["cat", str(fifo)], stdout=subprocess.PIPE)
    assert _fit(record, str(fifo)) == 0
    out, _ = reader.communicate(timeout=30)
    assert json.loads(out)
    assert fifo.is_fifo()  # still the FIFO, not a regular file
    _no_temporaries(tmp_path)


def test_character_device_output_is_written_through(tmp_path: Path, record: Path) -> None:
    null = tmp_path / "null"
    null.symlink_to(os.devnull)  # a link to the null device: the device stays a device
    assert _fit(record, str(null)) == 0
    assert Path(os.devnull).is_char_device()
    assert null.is_symlink()
    _no_temporaries(tmp_path)


def test_dash_is_standard_output(
    tmp_path: Path, record: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    with atomic_output("-") as tmp:
        tmp.write_text('{"ok": 1}\n')
    assert capsys.readouterr().out.endswith('{"ok": 1}\n')
    assert not (tmp_path / "-").exists()


def test_output_equal_to_input_is_refused_for_a_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rec = tmp_path / "rec.csv"
    np.savetxt(rec, np.random.default_rng(2).normal(0, 0.01, 3000))
    before = rec.read_bytes()
    assert main(["analyze", str(rec), "--fs", "100", "-o", str(rec)]) == 2
    assert "it is the input file" in capsys.readouterr().err
    assert rec.read_bytes() == before
    hard = tmp_path / "hard.csv"
    os.link(rec, hard)
    soft = tmp_path / "soft.csv"
    soft.symlink_to(rec)
    for other in (hard, soft):
        assert main(["analyze", str(rec), "--fs", "100", "-o", str(other)]) == 2
        assert rec.read_bytes() == before
    _no_temporaries(tmp_path)


def test_input_guard_is_scoped(tmp_path: Path) -> None:
    path = tmp_path / "a.csv"
    path.write_text("1\n")
    note_input(path)  # outside a command: not remembered
    check_output_path(path)
    with guard_inputs():
        note_input(path)
        with pytest.raises(OSError, match="it is the input file"):
            check_output_path(path)
    check_output_path(path)


def test_symlink_loop_output_is_named(tmp_path: Path) -> None:
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.symlink_to(b)
    b.symlink_to(a)
    with pytest.raises(OSError, match="symbolic link loop"), atomic_output(a):
        pass


def test_sigterm_removes_the_temporary_file(tmp_path: Path) -> None:
    target = tmp_path / "big.bin"
    script = textwrap.dedent(
        f"""
        import sys, time
        from allanite.io.atomic import atomic_output
        with atomic_output({str(target)!r}) as tmp:
            with open(tmp, "wb") as f:
                f.write(b"x" * 1000)
                f.flush()
                print("writing", flush=True)
                time.sleep(60)
        """
    )
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE)
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == b"writing"
    proc.send_signal(signal.SIGTERM)
    start = time.monotonic()
    rc = proc.wait(timeout=30)
    proc.stdout.close()
    assert time.monotonic() - start < 30
    assert rc == 128 + signal.SIGTERM
    assert list(tmp_path.iterdir()) == []
