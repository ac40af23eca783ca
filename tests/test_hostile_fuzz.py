"""Fuzz every record reader and config reader with damaged copies of small valid files (#31).

Each valid seed is built here (as tests/test_io_readers.py and tests/test_io_robot_logs.py
do); hypothesis flips bits, truncates, or overwrites a span with random bytes, with a fixed
seed (``derandomize``) and a fixed budget, so the run is the same everywhere. The only
acceptable outcomes are a record (or config) or a ValueError/TypeError (InputError is a
ValueError) with a message; any other exception is a defect. Every defect found is kept as a
small file in ``tests/data/hostile/`` and replayed by :func:`test_corpus_is_refused_cleanly`.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from allanite.formats import FORMATS as CONFIG_FORMATS
from allanite.formats import format_module
from allanite.formats.base import ImuConfig, sensor_model
from allanite.io import read_record
from allanite.model import NoiseModel
from allanite.terms import RateRandomWalk, White

CORPUS = Path(__file__).parent / "data" / "hostile"
#: examples per reader: the whole file runs in well under a minute on a loaded 2-core machine
#: (a deeper run: ALLANITE_FUZZ_EXAMPLES=1000)
EXAMPLES = int(os.environ.get("ALLANITE_FUZZ_EXAMPLES", "60"))
FUZZ = settings(
    derandomize=True,
    max_examples=EXAMPLES,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
FS = 100.0


def _rows(n: int = 200) -> np.ndarray:
    rng = np.random.default_rng(3)
    out = rng.normal(0.0, 0.01, (n, 6))
    out[:, 5] += 9.81
    return out


def _record_seeds(root: Path) -> dict[str, Path]:
    """One small valid file per record format (name -> path)."""
    data = _rows()
    seeds: dict[str, Path] = {}
    seeds["csv"] = root / "r.csv"
    np.savetxt(seeds["csv"], data[:, :3], delimiter=",", header="gx,gy,gz", comments="")
    seeds["npy"] = root / "r.npy"
    np.save(seeds["npy"], data[:, :3])
    seeds["npz"] = root / "r.npz"
    np.savez(seeds["npz"], gyro=data[:, :3])
    seeds["raw"] = root / "r.bin"
    data[:, :3].astype("<f4").tofile(seeds["raw"])
    h5py = pytest.importorskip("h5py")
    seeds["hdf5"] = root / "r.h5"
    with h5py.File(seeds["hdf5"], "w") as f:
        f["gyro"] = data[:, :3]
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq

        seeds["parquet"] = root / "r.parquet"
        pq.write_table(pa.table({"gx": data[:, 0], "gy": data[:, 1]}), seeds["parquet"])
    except ImportError:
        pass
    _robot_seeds(root, data, seeds)
    return seeds


def _robot_seeds(root: Path, data: np.ndarray, seeds: dict[str, Path]) -> None:
    try:
        from test_io_robot_logs import write_bag, write_ulog
    except pytest.skip.Exception:  # rosbags or pyulog not installed
        return
    times = np.arange(len(data)) / FS
    write_bag(root / "r.bag", "ros1", data, times)
    seeds["bag"] = root / "r.bag"
    for kind, suffix in (("sqlite3", ".db3"), ("mcap", ".mcap")):
        write_bag(root / kind, kind, data, times)
        seeds[kind] = next(p for p in (root / kind).iterdir() if p.suffix == suffix)
    fields = [("uint64_t", "timestamp"), ("float", "x"), ("float", "y"), ("float", "z")]
    rows = [(int(1e6 * t), *map(float, r[:3])) for t, r in zip(times, data, strict=True)]
    seeds["ulog"] = root / "r.ulg"
    write_ulog(seeds["ulog"], "sensor_gyro", fields, rows)


def _read_options(name: str) -> dict[str, object]:
    if name in ("bag", "sqlite3", "mcap", "ulog"):
        return {}
    if name == "raw":
        return {"fs": FS, "dtype": "float32", "n_channels": 3}
    return {"fs": FS}


@pytest.fixture(scope="module")
def record_seeds(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return _record_seeds(tmp_path_factory.mktemp("seeds"))


def _config_seeds() -> dict[str, str]:
    """One valid text per config format, written by the format's own writer."""
    gyro = sensor_model([White(1e-4), RateRandomWalk(1e-6)], "gyro")
    accel = sensor_model([White(2e-3), RateRandomWalk(3e-5)], "accel")
    config = ImuConfig(gyro=gyro, accel=accel, rate=200.0)
    seeds = {}
    for name in CONFIG_FORMATS:
        try:
            seeds[name] = format_module(name).write(config, rate=200.0).text
        except ImportError:
            continue
    seeds["model_json"] = NoiseModel((White(1e-4), RateRandomWalk(1e-6)), "rad/s").to_json()
    return seeds


CONFIG_SEEDS = _config_seeds()


@st.composite
def damaged(draw: st.DrawFn, seed: bytes) -> bytes:
    """``seed`` with bits flipped, truncated, or a span overwritten by random bytes."""
    kind = draw(st.sampled_from(["flip", "truncate", "overwrite"]))
    out = bytearray(seed)
    if kind == "truncate":
        return bytes(out[: draw(st.integers(0, len(out) - 1))])
    if kind == "flip":
        for _ in range(draw(st.integers(1, 16))):
            i = draw(st.integers(0, len(out) - 1))
            out[i] ^= 1 << draw(st.integers(0, 7))
        return bytes(out)
    start = draw(st.integers(0, len(out) - 1))
    span = draw(st.binary(min_size=1, max_size=64))
    out[start : start + len(span)] = span
    return bytes(out)


def check_clean(read: object) -> None:
    """Call ``read``: a result, or a ValueError/TypeError with a short message, nothing else."""
    message = None
    try:
        read()  # type: ignore[operator]
    except (ValueError, TypeError) as exc:
        message = f"{type(exc).__name__}: {exc}"
    if message is not None:
        assert message.split(": ", 1)[1].strip(), f"{message} without a message"
        assert len(message) < 5000, f"message of {len(message)} characters"


def _read_bytes(name: str, seed: Path, content: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / seed.name
        path.write_bytes(content)
        check_clean(lambda: read_record(path, **_read_options(name)))


RECORDS = ["csv", "npy", "npz", "raw", "hdf5", "parquet", "bag", "sqlite3", "mcap", "ulog"]


@pytest.mark.parametrize("name", RECORDS)
def test_damaged_records_are_read_or_refused_cleanly(
    name: str, record_seeds: dict[str, Path]
) -> None:
    if name not in record_seeds:
        pytest.skip(f"{name}: the library to write the seed is not installed")
    seed = record_seeds[name]

    @FUZZ
    @given(damaged(seed.read_bytes()))
    def fuzz(content: bytes) -> None:
        _read_bytes(name, seed, content)

    fuzz()


@pytest.mark.parametrize("name", sorted(CONFIG_SEEDS))
def test_damaged_configs_are_read_or_refused_cleanly(name: str) -> None:
    seed = CONFIG_SEEDS[name].encode()

    def read(text: str) -> object:
        if name == "model_json":
            return NoiseModel.from_json(text)
        return format_module(name).read(text)

    @FUZZ
    @given(damaged(seed))
    def fuzz(content: bytes) -> None:
        text = content.decode("utf-8", errors="replace")
        check_clean(lambda: read(text))

    fuzz()


def _corpus() -> list[Path]:
    return sorted(p for p in CORPUS.glob("*") if p.is_file() and p.name != "README.md")


@pytest.mark.parametrize("path", _corpus(), ids=lambda p: p.name)
def test_corpus_is_refused_cleanly(path: Path) -> None:
    """Each file the fuzzer once broke a reader with: now a record or a clean refusal."""
    kind = path.name.split("-")[0]
    if kind in CONFIG_SEEDS:
        text = path.read_text(encoding="utf-8", errors="replace")
        if kind == "model_json":
            check_clean(lambda: NoiseModel.from_json(text))
        else:
            check_clean(lambda: format_module(kind).read(text))
        return
    check_clean(lambda: read_record(path, **_read_options(kind)))
