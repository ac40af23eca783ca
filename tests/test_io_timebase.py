"""Time columns: fs inference, jitter and gap detection, the error/split/fill policies."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from allanite.errors import InputError
from allanite.io import read_record
from allanite.io.timebase import JITTER_WARN, resolve_time

RNG = np.random.default_rng(7)


def _write(path: Path, t: np.ndarray, x: np.ndarray) -> Path:
    rows = [f"{a:.17g},{b:.17g}" for a, b in zip(t, x, strict=True)]
    path.write_text("t,gx\n" + "\n".join(rows) + "\n")
    return path


def test_fs_inferred_and_jitter_measured(tmp_path: Path) -> None:
    n, dt = 4000, 0.002
    jitter = 0.03 * dt  # rms 3 % of the period, above the warning threshold
    t = np.arange(n) * dt + RNG.normal(scale=jitter / np.sqrt(2), size=n)
    x = RNG.normal(size=n)
    record = read_record(_write(tmp_path / "j.csv", t, x), time_column="t")
    timing = record.timing
    assert timing is not None
    # differences of independent stamps: rms jitter of intervals = jitter; its estimate from n-1
    # intervals has relative standard error about 1/sqrt(2 (n-1)) (4 sigma allowed)
    assert timing.jitter_rms == pytest.approx(jitter, rel=4 / np.sqrt(2 * (n - 1)))
    # mean interval = (t[-1] - t[0]) / (n - 1): standard error jitter/sqrt(2)*sqrt(2)/(n-1)
    assert timing.dt_nominal == pytest.approx(dt, abs=4 * jitter / (n - 1))
    assert record.fs == pytest.approx(1 / dt, rel=4 * jitter / (n - 1) / dt)
    assert any("jitter" in w for w in record.warnings)
    assert timing.jitter_relative > JITTER_WARN
    np.testing.assert_array_equal(record.samples[:, 0], x)


def test_no_warning_for_clean_stamps(tmp_path: Path) -> None:
    t = np.arange(1000) * 0.01
    record = read_record(_write(tmp_path / "c.csv", t, RNG.normal(size=1000)), time_column=0)
    assert record.warnings == ()
    assert record.fs == pytest.approx(100.0, rel=1e-12)


def test_time_scale_milliseconds(tmp_path: Path) -> None:
    t_ms = np.arange(500) * 5.0
    path = _write(tmp_path / "ms.csv", t_ms, RNG.normal(size=500))
    assert read_record(path, time_column="t", time_scale=1e-3).fs == pytest.approx(200.0)


def _gapped() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t_full = np.arange(300) * 0.01
    keep = np.ones(300, dtype=bool)
    keep[100:104] = False  # 4 missing samples
    keep[200:201] = False  # 1 missing sample
    x_full = np.cumsum(RNG.normal(size=300))
    return t_full[keep], x_full[keep], t_full


def test_gap_policy_error(tmp_path: Path) -> None:
    t, x, _ = _gapped()
    path = _write(tmp_path / "g.csv", t, x)
    with pytest.raises(InputError) as info:
        read_record(path, time_column="t")
    message = str(info.value)
    assert "g.csv" in message
    # the first gap is between data rows 100 and 101: file line 102 (header is line 1)
    assert "2 gap(s)" in message
    assert "line 102" in message
    assert "4 missing" in message
    assert "--gaps split" in message
    assert "--gaps fill" in message


def test_gap_policy_split(tmp_path: Path) -> None:
    t, x, _ = _gapped()
    record = read_record(_write(tmp_path / "g.csv", t, x), time_column="t", gaps="split")
    assert [(s.start, s.stop) for s in record.segments] == [(0, 100), (100, 196), (196, 295)]
    assert record.segments[1].t0 == pytest.approx(1.04)
    longest = record.longest_segment()
    np.testing.assert_array_equal(longest.samples[:, 0], x[:100])
    np.testing.assert_array_equal(record.segment(2).samples[:, 0], x[196:295])
    assert record.fs == pytest.approx(100.0)
    assert record.timing is not None
    assert len(record.timing.gaps) == 2


def test_gap_policy_fill(tmp_path: Path) -> None:
    t, x, t_full = _gapped()
    record = read_record(_write(tmp_path / "g.csv", t, x), time_column="t", gaps="fill")
    assert record.n_samples == 300
    assert record.timing is not None
    assert record.timing.filled == 5
    expected = np.interp(t_full, t, x)
    np.testing.assert_allclose(record.samples[:, 0], expected, rtol=0, atol=1e-12)
    assert any("filled 5 sample(s)" in w for w in record.warnings)


@pytest.mark.parametrize(
    ("t", "pattern"),
    [
        (np.array([0.0, 0.01, 0.02, 0.015, 0.04]), r"line 5: time stamps are not sorted"),
        (np.array([0.0, 0.01, 0.01, 0.02, 0.03]), r"line 4: duplicated time stamp 0.01 s"),
    ],
)
def test_bad_stamps_name_the_line(tmp_path: Path, t: np.ndarray, pattern: str) -> None:
    path = _write(tmp_path / "bad.csv", t, np.ones_like(t))
    with pytest.raises(InputError, match=pattern):
        read_record(path, time_column="t")


def test_given_fs_wins_with_warning() -> None:
    t = np.arange(100) * 0.01
    base = resolve_time(t, np.ones((100, 1)), source="x", fs=105.0)
    assert base.fs == 105.0
    assert any("differs" in w for w in base.warnings)
    # beyond FS_CONFLICT (10 %) the caller must say which wins (issue 30 item 13)
    with pytest.raises(ValueError, match=r"contradicts the 100 Hz.*fs_source='time'"):
        resolve_time(t, np.ones((100, 1)), source="x", fs=120.0)
    assert resolve_time(t, np.ones((100, 1)), source="x", fs=120.0, fs_source="fs").fs == 120.0
    chosen = resolve_time(t, np.ones((100, 1)), source="x", fs=120.0, fs_source="time")
    assert chosen.fs == pytest.approx(100.0)
    with pytest.raises(ValueError, match="unknown gap policy 'skip'"):
        resolve_time(t, np.ones((100, 1)), source="x", policy="skip")


def test_iso_datetime_time_column(tmp_path: Path) -> None:
    start = np.datetime64("2024-05-01T23:59:59")
    stamps = start + np.arange(400) * np.timedelta64(20, "ms")  # crosses midnight, 50 Hz
    x = RNG.normal(size=400)
    lines = [f"{str(s).replace('T', ' ')},{v:.17g}" for s, v in zip(stamps, x, strict=True)]
    path = tmp_path / "iso.csv"
    path.write_text("time,gx\n" + "\n".join(lines) + "\n")
    record = read_record(path, time_column="time")
    assert record.fs == pytest.approx(50.0, rel=1e-9)
    assert record.channels == ("gx",)
    np.testing.assert_array_equal(record.samples[:, 0], x)
    lines[6] = "2024-05-01 25:00:00,1.0"
    path.write_text("time,gx\n" + "\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"iso.csv, line 8: field 1 .* not an ISO date-time"):
        read_record(path, time_column="time")
