"""Messages for unlucky inputs name the real cause (issue 31, item 12).

Outputs checked before the computation, directories and all-zero records in a batch, arrays
of Python objects, pipes and devices as records, and messages bounded whatever the input.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from allanite.cli import main
from allanite.errors import MESSAGE_LIMIT, InputError
from allanite.io import read_record
from allanite.model import NoiseModel
from allanite.terms import White


def _record(path: Path, seed: int = 8, n: int = 3000) -> Path:
    np.save(path, np.random.default_rng(seed).normal(0.0, 0.01, n))
    return path


def _no_computation(*_args: object, **_kwargs: object) -> None:
    raise AssertionError("the computation ran before the output path was checked")


@pytest.mark.parametrize("option", ["-o", "--report"])
def test_diagnose_checks_its_outputs_before_the_computation(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    option: str,
) -> None:
    import allanite.diagnosis

    rec = _record(tmp_path / "real.npy")
    model = tmp_path / "model.json"
    model.write_text(NoiseModel((White(N=0.01),), "rad/s").to_json())
    monkeypatch.setattr(allanite.diagnosis, "diagnose", _no_computation)
    monkeypatch.setattr("allanite.cli.diagnose.read_from_args", _no_computation)
    target = tmp_path / "missing" / ("d.json" if option == "-o" else "d.html")
    argv = ["diagnose", str(rec), "--fs", "100", "--sim-model", str(model), option, str(target)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err
    assert "Traceback" not in err


def test_report_checks_its_output_before_the_analysis(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    rec = _record(tmp_path / "real.npy")
    monkeypatch.setattr("allanite.cli.report.read_sensors", _no_computation)
    target = tmp_path / "missing" / "r.html"
    assert main(["report", str(rec), "--fs", "100", "-o", str(target)]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err
    assert "Traceback" not in err


def _batch_rows(out: Path) -> dict[str, str]:
    return {Path(line.split(",")[0]).name: line for line in out.read_text().splitlines()[1:]}


def test_batch_gives_a_directory_matched_by_the_glob_an_error_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "data"
    data.mkdir()
    _record(data / "a.npy")
    (data / "b.npy").mkdir()  # a directory whose name matches the pattern
    out = tmp_path / "out.csv"
    rc = main(["batch", str(data / "*.npy"), "--fs", "100", "-o", str(out)])
    assert "Traceback" not in capsys.readouterr().err
    assert rc in (0, 1)
    rows = _batch_rows(out)
    assert set(rows) == {"a.npy", "b.npy"}
    assert ",error," in rows["b.npy"]
    assert "is a directory" in rows["b.npy"]


def test_batch_gives_an_all_zero_record_a_clear_error_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = _record(tmp_path / "good.npy")
    zero = tmp_path / "zero.npy"
    np.save(zero, np.zeros(3000))
    out = tmp_path / "out.csv"
    rc = main(["batch", str(good), str(zero), "--fs", "100", "-o", str(out)])
    assert "Traceback" not in capsys.readouterr().err
    assert rc in (0, 1)
    rows = _batch_rows(out)
    assert ",error," in rows["zero.npy"]
    assert "constant" in rows["zero.npy"]
    assert ",error," not in rows["good.npy"]


def test_object_npz_names_the_real_cause(tmp_path: Path) -> None:
    path = tmp_path / "objects.npz"
    np.savez(path, gyro=np.array([1.0, "x", None], dtype=object))
    with pytest.raises(InputError, match="Python objects") as info:
        read_record(path, fs=100.0)
    assert "truncated" not in str(info.value)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs need a POSIX system")
def test_fifo_as_a_record_is_refused_naming_it(tmp_path: Path) -> None:
    fifo = tmp_path / "stream.csv"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match=r"a pipe \(FIFO\)") as info:
        read_record(fifo, fs=100.0)  # must not block opening the pipe
    assert "empty" not in str(info.value)


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero")
def test_dev_zero_as_a_record_is_refused_naming_it() -> None:
    with pytest.raises(InputError, match="a character device"):
        read_record("/dev/zero", fs=100.0)


def test_wide_csv_error_message_is_bounded(tmp_path: Path) -> None:
    """A 300,000-column header listed in full in a message was megabytes on one line."""
    n = 300_000
    path = tmp_path / "wide.csv"
    header = ",".join(f"column_{i}" for i in range(n))
    row = ",".join("0.5" for _ in range(n))
    path.write_text(f"{header}\n{row}\n{row}\n{row}\n")
    with pytest.raises(InputError, match="no column named 'gz'") as info:
        read_record(path, fs=100.0, columns="gz")
    assert len(str(info.value)) < MESSAGE_LIMIT + len(str(path)) + 100
    assert "characters cut" in str(info.value)


DEEP = "[" * 100_000 + "]" * 100_000


def test_json_nested_100000_deep_is_a_clean_error(tmp_path: Path) -> None:
    """Python's json recursion ended in a RecursionError traceback (#31 item 8)."""
    from allanite.datasheet import Datasheet
    from allanite.formats import airsim

    for read in (NoiseModel.from_json, airsim.read):
        with pytest.raises(ValueError, match="nested too deeply"):
            read(DEEP)
    sheet = tmp_path / "sheet.json"
    sheet.write_text(DEEP)
    with pytest.raises(ValueError, match="nested too deeply"):
        Datasheet.load(sheet)
    model = tmp_path / "model.json"
    model.write_text(DEEP)
    out = tmp_path / "sim.npy"
    assert main(["simulate", str(model), "--fs", "100", "-n", "1000", "-o", str(out)]) == 2
    assert not out.exists()


def test_dash_reads_a_text_record_from_standard_input(monkeypatch: pytest.MonkeyPatch) -> None:
    """``-`` is standard input for text records (it was "no such file"); errors name <stdin>."""
    import io
    import sys

    data = np.random.default_rng(9).normal(0.0, 0.01, (500, 2))
    text = "gx,gy\n" + "\n".join(f"{float(a)!r},{float(b)!r}" for a, b in data) + "\n"
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(text.encode())))
    record = read_record("-", fs=100.0)
    np.testing.assert_array_equal(record.samples, data)
    assert record.source == "<stdin>"
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(b"gx\n1\nzz\n3\n")))
    with pytest.raises(InputError, match=r"^<stdin>, line 3: field 1 is 'zz'"):
        read_record("-", fs=100.0)
