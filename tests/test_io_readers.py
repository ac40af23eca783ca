"""Readers: every format round-trips, columns/time/scale/units are honoured, bad files are named."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from allanite.errors import InputError
from allanite.io import Record, read_record
from allanite.io.readers import from_frame

RNG = np.random.default_rng(20260121)
DATA = RNG.normal(size=(500, 3))
NAMES = ("gx", "gy", "gz")


def _write_text(path: Path, data: np.ndarray, delimiter: str, header: str | None) -> Path:
    lines = [] if header is None else [header]
    lines += [delimiter.join(f"{v:.17g}" for v in row) for row in data]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize(
    ("delimiter", "header"),
    [(",", "gx,gy,gz"), (" ", None), ("\t", "gx\tgy\tgz"), (";", "gx;gy;gz"), ("  ", None)],
)
def test_text_round_trip(tmp_path: Path, delimiter: str, header: str | None) -> None:
    path = _write_text(tmp_path / "rec.txt", DATA, delimiter, header)
    record = read_record(path, fs=100.0, units="deg/s")
    np.testing.assert_array_equal(record.samples, DATA)
    assert record.fs == 100.0
    assert record.units == "deg/s"
    assert record.channels == (NAMES if header else ("col0", "col1", "col2"))


def test_text_comments_blank_lines_and_gzip(tmp_path: Path) -> None:
    body = "% MATLAB comment\n# another\n\n" + "\n".join(f"{v:.17g}" for v in DATA[:, 0]) + "\n"
    path = tmp_path / "angles.txt.gz"
    with gzip.open(path, "wt") as handle:
        handle.write(body)
    record = read_record(path, fs=10.0, input="angle", units="deg")
    np.testing.assert_array_equal(record.samples[:, 0], DATA[:, 0])
    assert record.input == "angle"


def test_columns_by_name_and_index(tmp_path: Path) -> None:
    path = _write_text(tmp_path / "rec.csv", DATA, ",", "gx,gy,gz")
    by_name = read_record(path, fs=1.0, columns=["gz", "gx"])
    by_index = read_record(path, fs=1.0, columns="2,0")
    np.testing.assert_array_equal(by_name.samples, DATA[:, [2, 0]])
    np.testing.assert_array_equal(by_index.samples, DATA[:, [2, 0]])
    assert by_name.channels == ("gz", "gx")
    with pytest.raises(InputError, match=r"no column named 'gq'; available: gx, gy, gz"):
        read_record(path, fs=1.0, columns="gq")
    with pytest.raises(InputError, match="column 5 does not exist"):
        read_record(path, fs=1.0, columns=[5])


def test_scale_from_counts(tmp_path: Path) -> None:
    counts = RNG.integers(-300, 300, size=(400, 2)).astype(np.int16)
    path = tmp_path / "counts.npy"
    np.save(path, counts)
    record = read_record(path, fs=100.0, scale=0.05, units="deg/s")
    np.testing.assert_allclose(record.samples, counts * 0.05, rtol=0, atol=0)
    assert record.scale == 0.05
    with pytest.raises(ValueError, match="scale must be a finite, non-zero"):
        read_record(path, fs=100.0, scale=0.0)


def test_npy_npz(tmp_path: Path) -> None:
    np.save(tmp_path / "a.npy", DATA)
    np.testing.assert_array_equal(read_record(tmp_path / "a.npy", fs=1.0).samples, DATA)
    np.savez(tmp_path / "b.npz", gyro=DATA, accel=DATA[:, :2] * 2)
    record = read_record(tmp_path / "b.npz", fs=1.0, key="accel")
    np.testing.assert_array_equal(record.samples, DATA[:, :2] * 2)
    with pytest.raises(InputError, match=r"several arrays \(gyro, accel\).*--key"):
        read_record(tmp_path / "b.npz", fs=1.0)
    with pytest.raises(InputError, match="no array 'mag'"):
        read_record(tmp_path / "b.npz", fs=1.0, key="mag")


@pytest.mark.parametrize("byteorder", ["little", "big"])
def test_raw_binary(tmp_path: Path, byteorder: str) -> None:
    counts = RNG.integers(-3000, 3000, size=(256, 3)).astype(np.int16)
    code = "<" if byteorder == "little" else ">"
    path = tmp_path / "imu.bin"
    path.write_bytes(b"HEADER16" + counts.astype(f"{code}i2").tobytes())
    record = read_record(
        path, fs=2000.0, dtype="int16", n_channels=3, byteorder=byteorder, offset=8
    )
    np.testing.assert_array_equal(record.samples, counts)
    wrong = read_record(
        path,
        fs=2000.0,
        dtype="int16",
        n_channels=3,
        byteorder="big" if byteorder == "little" else "little",
        offset=8,
    )
    assert not np.array_equal(wrong.samples, counts)


def test_raw_binary_layout_errors(tmp_path: Path) -> None:
    path = tmp_path / "imu.raw"
    path.write_bytes(np.arange(7, dtype="<i2").tobytes())
    with pytest.raises(InputError, match=r"not a whole number of 3-channel int16 frames"):
        read_record(path, fs=1.0, dtype="int16", n_channels=3)
    with pytest.raises(InputError, match=r"needs the sample type.*--dtype"):
        read_record(path, fs=1.0)


def test_raw_layout_options_imply_raw(tmp_path: Path) -> None:
    counts = RNG.integers(-3000, 3000, size=(256, 2)).astype(np.int16)
    path = tmp_path / "counts.i16"  # an unknown suffix would be read as text
    path.write_bytes(counts.astype("<i2").tobytes())
    record = read_record(path, fs=100.0, dtype="int16", n_channels=2)
    np.testing.assert_array_equal(record.samples, counts)
    big = tmp_path / "counts.dat"  # a text suffix, but binary content and a raw option
    big.write_bytes(b"HDR!" + counts.astype(">i2").tobytes())
    record = read_record(big, fs=100.0, dtype="int16", n_channels=2, byteorder="big", offset=4)
    np.testing.assert_array_equal(record.samples, counts)
    with pytest.raises(InputError, match=r"counts.i16: raw binary needs the sample type"):
        read_record(path, fs=100.0, n_channels=2)
    npy = tmp_path / "rec.npy"
    np.save(npy, counts)
    with pytest.raises(InputError, match=r"--dtype describe raw binary, but the file is npy"):
        read_record(npy, fs=100.0, dtype="int16")
    with pytest.raises(InputError, match=r"--offset describe raw binary, but the file is text;"):
        read_record(path, fs=100.0, offset=4, format="text")


def test_hdf5(tmp_path: Path) -> None:
    h5py = pytest.importorskip("h5py")
    path = tmp_path / "rec.h5"
    with h5py.File(path, "w") as handle:
        ds = handle.create_dataset("imu/gyro", data=DATA)
        ds.attrs["columns"] = list(NAMES)
        handle.create_dataset("imu/temp", data=DATA[:, 0])
    record = read_record(path, fs=100.0, key="imu/gyro", columns=["gy"])
    np.testing.assert_array_equal(record.samples[:, 0], DATA[:, 1])
    with pytest.raises(InputError, match=r"holds 2 datasets \(imu/gyro, imu/temp\)"):
        read_record(path, fs=100.0)


def test_parquet_and_dataframe(tmp_path: Path) -> None:
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    t = np.arange(DATA.shape[0]) * 0.005
    frame = pd.DataFrame({"time": t, "gx": DATA[:, 0], "gy": DATA[:, 1], "label": "static"})
    path = tmp_path / "rec.parquet"
    frame.to_parquet(path)
    record = read_record(path, columns=["gx", "gy"], time_column="time", units="rad/s")
    np.testing.assert_array_equal(record.samples, DATA[:, :2])
    assert record.fs == pytest.approx(200.0, rel=1e-9)
    with pytest.raises(InputError, match=r"column 'label' is not numeric"):
        read_record(path, time_column="time")
    indexed = frame.set_index(pd.to_datetime(t, unit="s"))
    record = from_frame(indexed, columns=["gx"], time_column="index")
    np.testing.assert_array_equal(record.samples[:, 0], DATA[:, 0])
    assert record.fs == pytest.approx(200.0, rel=1e-6)
    direct = read_record(frame[["gx", "gy"]], fs=50.0)
    assert direct.channels == ("gx", "gy")


def test_record_select_and_segments() -> None:
    record = Record(samples=DATA, fs=10.0, channels=NAMES)
    assert record.select(["gz", 0]).channels == ("gz", "gx")
    with pytest.raises(ValueError, match="no channel named 'q'"):
        record.select(["q"])
    with pytest.raises(ValueError, match="--fs HZ"):
        Record(samples=DATA, fs=None).require_fs()


def test_adis16405_counts(shared_data: Path) -> None:
    path = shared_data / "imu" / "adis16405" / "run2.npz"
    if not path.exists():
        pytest.skip(f"{path} not in the reference data")
    record = read_record(path, key="gyro_counts", fs=100.0, scale=0.05, units="deg/s")
    assert record.samples.shape == (1_000_000, 3)
    # values lie exactly on the 0.05 deg/s grid of the sensor's LSB
    lsb = record.samples[:1000] / 0.05
    np.testing.assert_allclose(lsb, np.rint(lsb), atol=1e-9)


@pytest.mark.parametrize(
    ("module", "suffix", "extra"),
    [("h5py", ".h5", "hdf5"), ("pyarrow.parquet", ".parquet", "parquet")],
)
def test_missing_optional_reader_names_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, module: str, suffix: str, extra: str
) -> None:
    import sys

    path = tmp_path / f"rec{suffix}"
    path.write_bytes(b"not really")
    monkeypatch.setitem(sys.modules, module, None)  # makes the import fail
    with pytest.raises(ImportError, match=rf'pip install "allanite\[{extra}\]"'):
        read_record(path, fs=1.0)


def test_corrupt_npz_and_hdf5_are_input_errors(tmp_path: Path) -> None:
    npz = tmp_path / "cut.npz"
    np.savez(npz, a=DATA)
    npz.write_bytes(npz.read_bytes()[:200])
    with pytest.raises(InputError, match=r"cut.npz: .*copy it again|cut.npz: .*truncated"):
        read_record(npz, fs=1.0)
    h5 = tmp_path / "bad.h5"
    h5.write_bytes(b"\x89HDF-but-not-really" * 10)
    pytest.importorskip("h5py")
    with pytest.raises(InputError, match=r"bad.h5: not a readable HDF5 file"):
        read_record(h5, fs=1.0)


def _mapped(samples: np.ndarray) -> bool:
    """Whether ``samples`` is a view of a memory-mapped file."""
    import mmap

    base = samples
    while base is not None:
        if isinstance(base, (np.memmap, mmap.mmap)):
            return True
        base = getattr(base, "base", None)
    return False


def test_npy_and_raw_records_stay_memory_mapped(tmp_path: Path) -> None:
    """Regression: read_record copied a memory-mapped .npy (a list of columns is a copy) and the
    NaN check built full-size temporaries: a 6 h, 2 kHz, 3-axis .npy (1.04 GB) peaked at 2.2 GB
    before the Allan variance began, so --memory-limit could not keep it below the record."""
    np.save(tmp_path / "a.npy", DATA)
    for columns in (None, [1, 2], "col1,col2"):
        record = read_record(tmp_path / "a.npy", fs=1.0, columns=columns)
        assert _mapped(record.samples), columns
        np.testing.assert_array_equal(record.samples, DATA[:, 1:] if columns else DATA)
    DATA.astype("<f4").tofile(tmp_path / "r.bin")
    raw = read_record(tmp_path / "r.bin", fs=1.0, dtype="<f4", n_channels=3)
    assert _mapped(raw.samples)
    picked = read_record(tmp_path / "a.npy", fs=1.0, columns=[2, 0])  # out of order: a copy
    np.testing.assert_array_equal(picked.samples, DATA[:, [2, 0]])


def test_a_nan_beyond_the_first_block_is_located(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import allanite.io.readers as readers

    monkeypatch.setattr(readers, "_FINITE_BLOCK", 30)  # 10 rows of 3 channels per block
    bad = DATA.copy()
    bad[437, 2] = np.inf
    np.save(tmp_path / "bad.npy", bad)
    with pytest.raises(InputError, match=r"row 438, column 'col2': sample is inf"):
        read_record(tmp_path / "bad.npy", fs=1.0)
