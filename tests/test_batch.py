"""Batch analysis: table of coefficients, datasheet checks, local vs Dask, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

import allanite
from allanite.batch import BatchResult, batch, curve_coefficients, load_datasheet
from allanite.errors import InputError

FS = 100.0


def _lot(n_records: int, n: int = 20_000, channels: int = 1) -> list[tuple[str, np.ndarray]]:
    """Gyros with white rate noise N = sigma / sqrt(fs); gyro 3 is twice as noisy."""
    out = []
    for i in range(n_records):
        rng = np.random.default_rng(100 + i)
        sigma = 0.02 if i == 3 else 0.01
        out.append((f"gyro{i:02d}", rng.standard_normal((n, channels)) * sigma))
    return out


def test_table_coefficients_and_pass_fail():
    lot = _lot(5)
    res = batch(lot, FS, datasheet={"N": 0.0015}, units="deg/s")
    assert isinstance(res, BatchResult)
    assert len(res) == 5
    assert res.column("record") == [name for name, _ in lot]
    n_values = np.array(res.column("N"))
    expected = np.array([0.02 if i == 3 else 0.01 for i in range(5)]) / np.sqrt(FS)
    # N^2 = min(var * tau) sits at or below the white level by the scatter of the estimate
    assert np.all(n_values <= expected * 1.05)
    assert np.all(n_values >= expected * 0.85)
    assert res.column("pass") == [True, True, True, False, True]
    assert res.failures == [("gyro03", "0")]
    assert not res.passed
    # the same coefficients as reading each curve by hand
    single = allanite.avar(lot[0][1][:, 0], FS, alpha=0)
    assert curve_coefficients(single)["N"] == res.column("N")[0]


def test_multichannel_rows_and_minimum_limits():
    lot = _lot(2, channels=3)
    res = batch(lot, FS, datasheet={"N": {"min": 0.0005, "max": 0.002}, "R": {"min": 1.0}})
    assert len(res) == 6
    assert res.column("channel") == ["0", "1", "2"] * 2
    assert all(res.column("pass_N"))
    assert not any(res.column("pass_R"))  # a minimum that is not met (or no ramp at all)


def test_errors_are_rows_not_crashes(tmp_path):
    missing = tmp_path / "nope.csv"
    res = batch([("ok", _lot(1)[0][1]), missing], FS)
    assert res.column("pass") == [True, False]
    assert (
        "not found" in res.column("error")[1].lower() or "no such" in res.column("error")[1].lower()
    )


def test_paths_and_datasheet_file(tmp_path):
    paths = []
    for name, x in _lot(3):
        p = tmp_path / f"{name}.npy"
        np.save(p, x)
        paths.append(p)
    sheet = tmp_path / "sheet.json"
    sheet.write_text(json.dumps({"N": 0.0015, "B": {"max": 0.01}}))
    res = batch(paths, FS, datasheet=sheet)
    assert res.column("record") == [str(p) for p in paths]
    assert res.passed
    out = tmp_path / "table.csv"
    res.to_csv(out)
    assert out.read_text().splitlines()[0].startswith("record,channel,n_samples,fs,units,Q,N,B")
    assert json.loads(res.to_json())["columns"] == list(res.columns)


def test_bad_datasheets():
    with pytest.raises(ValueError, match="neither min nor max"):
        batch(_lot(1), FS, datasheet={"N": {}})
    with pytest.raises(ValueError, match="not coefficients"):
        batch(_lot(1), FS, datasheet={"ARW": 1.0})
    with pytest.raises(TypeError, match="must be a number"):
        batch(_lot(1), FS, datasheet={"N": "small"})
    with pytest.raises(ValueError, match="no records"):
        batch([], FS)


def test_bad_datasheet_file(tmp_path):
    bad = tmp_path / "sheet.json"
    bad.write_text("{not json")
    with pytest.raises(InputError, match="line 1"):
        load_datasheet(bad)
    yml = tmp_path / "sheet.yaml"
    yml.write_text("N: 0.01\nB:\n  max: 0.003\n")
    assert load_datasheet(yml) == {"N": 0.01, "B": {"max": 0.003}}


def test_custom_coefficients_and_progress():
    seen = []
    res = batch(
        _lot(3),
        FS,
        coefficients=lambda r: {"adev_1s": float(np.interp(1.0, r.tau, r.dev))},
        datasheet={"adev_1s": 0.0015},
        progress=lambda stage, done, total: seen.append((stage, done, total)),
    )
    assert res.columns[5] == "adev_1s"
    assert seen == [("records", 1, 3), ("records", 2, 3), ("records", 3, 3)]
    assert res.column("pass") == [True, True, True]


@pytest.mark.slow
def test_local_and_dask_cluster_give_identical_tables():
    distributed = pytest.importorskip("distributed")
    lot = _lot(8)
    local = batch(lot, FS, datasheet={"N": 0.0015, "B": 0.01})
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        seen = []
        remote = batch(
            lot,
            FS,
            datasheet={"N": 0.0015, "B": 0.01},
            client=client,
            progress=lambda s, d, t: seen.append(d),
        )
    assert remote == local
    assert seen == list(range(1, 9))


def test_cli_batch_glob_datasheet_and_exit_codes(tmp_path, capsys):
    from allanite.cli import main

    for name, x in _lot(4):
        np.save(tmp_path / f"{name}.npy", x)
    sheet = tmp_path / "sheet.json"
    sheet.write_text(json.dumps({"N": 0.0015}))
    out = tmp_path / "table.csv"
    code = main(
        [
            "batch",
            str(tmp_path / "gyro*.npy"),
            "--fs",
            "100",
            "--datasheet",
            str(sheet),
            "-o",
            str(out),
            "--no-progress",
        ]
    )
    assert code == 1  # gyro03 is too noisy
    printed = capsys.readouterr().out
    assert "FAIL" in printed
    assert "gyro03" in printed
    lines = out.read_text().splitlines()
    assert len(lines) == 5
    assert lines[4].split(",")[0].endswith("gyro03.npy")
    code = main(
        [
            "batch",
            str(tmp_path / "gyro0[012].npy"),
            "--fs",
            "100",
            "--datasheet",
            str(sheet),
            "--json",
            "--no-progress",
        ]
    )
    assert code == 0
    table = json.loads(capsys.readouterr().out)
    assert len(table["rows"]) == 3


def test_cli_batch_bad_input(tmp_path, capsys):
    from allanite.cli import main

    assert main(["batch", str(tmp_path / "none*.npy"), "--fs", "100"]) == 2
    assert "no files match" in capsys.readouterr().err
    np.save(tmp_path / "a.npy", np.zeros(100))
    assert (
        main(["batch", str(tmp_path / "a.npy"), "--fs", "100", "-o", str(tmp_path / "t.txt")]) == 2
    )
    assert not (tmp_path / "t.txt").exists()


def test_progress_bars_callback_draws_stages(capsys):
    from allanite.cli.batch import progress_bars

    with progress_bars(True) as bar:
        for i in range(1, 4):
            bar("phase", i * 10, 30)
        bar("variance", 5, 5)
    err = capsys.readouterr().err
    assert "phase" in err
    assert "variance" in err
