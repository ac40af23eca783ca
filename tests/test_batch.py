"""Batch analysis: fitted coefficients with intervals, datasheet checks, local vs Dask, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

import allanite
from allanite.batch import BatchResult, batch
from allanite.errors import InputError

FS = 100.0
N_SAMPLES = 20_000


def _lot(n_records: int, n: int = N_SAMPLES, channels: int = 1) -> list[tuple[str, np.ndarray]]:
    """Gyros with white rate noise N = sigma / sqrt(fs); gyro 3 is twice as noisy."""
    out = []
    for i in range(n_records):
        rng = np.random.default_rng(100 + i)
        sigma = 0.02 if i == 3 else 0.01
        out.append((f"gyro{i:02d}", rng.standard_normal((n, channels)) * sigma))
    return out


def _true_n(i: int) -> float:
    return (0.02 if i == 3 else 0.01) / np.sqrt(FS)


def test_table_holds_the_fit_with_intervals_and_pass_fail():
    lot = _lot(5)
    res = batch(lot, fs=FS, datasheet={"N": 0.0015}, units="deg/s")
    assert isinstance(res, BatchResult)
    assert len(res) == 5
    assert res.column("record") == [name for name, _ in lot]
    n, low, high = (np.array(res.column(c)) for c in ("N", "N_low", "N_high"))
    expected = np.array([_true_n(i) for i in range(5)])
    assert np.all((low < n) & (n < high))
    # the truth lies within 4 standard errors of the fit (95 % half-width = 1.96 se)
    se = (high - low) / (2 * 1.96)
    assert np.all(np.abs(n - expected) < 4 * se)
    # white noise only: auto selection leaves the other terms out, the model is not rejected
    for name in ("Q", "B", "K", "R"):
        assert res.column(name) == [None] * 5
    assert all(p > 1e-3 for p in res.column("p_value"))
    assert res.column("check_N") == ["pass", "pass", "pass", "fail", "pass"]
    assert res.column("pass") == [True, True, True, False, True]
    assert res.failures == [("gyro03", "0")]
    assert not res.passed
    # the very numbers of allanite.fit on the same curve
    single = allanite.avar(lot[0][1][:, 0], fs=FS, alpha=0, units="deg/s")
    fitted = allanite.fit(single)
    assert res.column("N")[0] == fitted["N"].value
    assert (res.column("N_low")[0], res.column("N_high")[0]) == fitted["N"].ci(0.95)
    assert res.column("p_value")[0] == fitted.p_value


def test_marginal_when_only_the_interval_crosses_the_limit():
    lot = _lot(1)
    first = batch(lot, fs=FS)
    n, high = first.column("N")[0], first.column("N_high")[0]
    inside = batch(lot, fs=FS, datasheet={"N": (n + high) / 2})
    assert inside.column("check_N") == ["marginal"]
    assert inside.column("status") == ["marginal"]
    assert inside.passed  # marginal is not a failure
    # just above the 95 % interval (1.25 x 1.96 = 2.45 standard errors above the estimate)
    limit = n + 1.25 * (high - n)
    above = batch(lot, fs=FS, datasheet={"N": limit})
    assert above.column("status") == ["pass"]
    below = batch(lot, fs=FS, datasheet={"N": {"min": limit}})
    assert below.column("status") == ["fail"]
    # a higher level widens the interval (3.29 standard errors): the limit becomes undecided
    wide = batch(lot, fs=FS, datasheet={"N": limit}, level=0.999)
    assert wide.column("check_N") == ["marginal"]
    assert wide.column("N_high")[0] > high


def test_multichannel_rows_and_minimum_limits():
    lot = _lot(2, channels=3)
    res = batch(
        lot,
        fs=FS,
        datasheet={"N": {"min": 0.0005, "max": 0.002}, "R": {"min": 1.0}, "K": {"min": 0.0}},
    )
    assert len(res) == 6
    assert res.column("channel") == ["0", "1", "2"] * 2
    assert res.column("check_N") == ["pass"] * 6
    # no sign of a ramp, and an upper limit below the positive minimum: fails it
    assert res.column("check_R") == ["fail"] * 6
    assert all(0.0 < r < 1.0 for r in res.column("R_upper"))
    # a term left out is bounded by its upper limit: K >= 0 holds whatever it is
    assert res.column("K") == [None] * 6
    assert all(k > 0.0 for k in res.column("K_upper"))
    assert res.column("check_K") == ["pass"] * 6
    assert not any(res.column("pass"))


def test_full_datasheet_with_units_and_adev_limit():
    lot = _lot(4)
    sheet = {
        "device": "lot spec",
        "limits": [
            # N = 0.001 deg/sqrt(s) = 0.06 deg/sqrt(h); gyro 3 has 0.12
            {"quantity": "N", "max": 0.09, "unit": "deg/sqrt(h)"},
            # white noise: adev(1 s) = N / sqrt(1 s) = 0.001 deg/s; gyro 3 has 0.002
            {"quantity": "adev", "tau": 1, "max": 0.0015, "unit": "deg/s"},
        ],
    }
    res = batch(lot, fs=FS, datasheet=sheet, units="deg/s")
    assert res.column("check_N") == ["pass", "pass", "pass", "fail"]
    assert res.column("check_adev@1s") == ["pass", "pass", "pass", "fail"]
    assert res.to_dict()["datasheet"]["device"] == "lot spec"
    # limits in physical units need the record's units
    unknown = batch(lot[:1], fs=FS, datasheet=sheet)
    assert unknown.column("status") == ["error"]
    assert "units are unknown" in unknown.column("error")[0]


def test_errors_are_rows_not_crashes(tmp_path):
    missing = tmp_path / "nope.csv"
    flat = np.zeros(1000)  # an Allan curve of zeros: nothing to fit
    res = batch([("ok", _lot(1)[0][1]), missing, ("flat", flat)], fs=FS)
    assert res.column("pass") == [True, False, False]
    assert res.column("status") == ["pass", "error", "error"]
    error = res.column("error")[1].lower()
    assert "not found" in error or "no such" in error
    assert res.column("channel")[2] == "0"
    assert "constant" in res.column("error")[2]  # the cause, not "too few usable taus" (#31)


def test_paths_and_datasheet_files(tmp_path):
    paths = []
    for name, x in _lot(3):
        p = tmp_path / f"{name}.npy"
        np.save(p, x)
        paths.append(p)
    sheet = tmp_path / "sheet.json"
    sheet.write_text(json.dumps({"N": 0.0015, "B": {"max": 0.01}}))
    res = batch(paths, fs=FS, datasheet=sheet)
    assert res.column("record") == [str(p) for p in paths]
    assert res.passed
    yml = tmp_path / "sheet.yaml"
    yml.write_text("N: 0.0015\nB:\n  max: 0.01\n")
    assert batch(paths, fs=FS, datasheet=str(yml)) == res
    out = tmp_path / "table.csv"
    res.to_csv(out)
    head = out.read_text().splitlines()[0]
    assert head.startswith(
        "record,channel,n_samples,fs,units,p_value,rejected,Q,Q_low,Q_high,Q_upper,N,N_low"
    )
    # white noise only: B is not detected, its upper limit is below the limit and in the CSV
    assert res.column("check_B") == ["pass"] * 3
    assert all(0.0 < b <= 0.01 for b in res.column("B_upper"))
    row = out.read_text().splitlines()[1].split(",")
    upper = row[head.split(",").index("B_upper")]
    assert float(upper) == res.column("B_upper")[0]
    assert head.endswith("check_N,check_B,status,pass,error")
    assert json.loads(res.to_json())["columns"] == list(res.columns)


def test_bad_datasheets_and_options():
    with pytest.raises(InputError, match="must be a number"):
        batch(_lot(1), fs=FS, datasheet={"N": {}})
    with pytest.raises(InputError, match=r"unknown quantity 'ARW' \(did you mean 'N'\?\)"):
        batch(_lot(1), fs=FS, datasheet={"ARW": 1.0})
    with pytest.raises(ValueError, match="not coefficients"):
        batch(_lot(1), fs=FS, datasheet={"sigma": 1.0}, terms=["N"])
    with pytest.raises(InputError, match="must be a number"):
        batch(_lot(1), fs=FS, datasheet={"N": "small"})
    with pytest.raises(TypeError, match="datasheet must be"):
        batch(_lot(1), fs=FS, datasheet=3.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="level must lie"):
        batch(_lot(1), fs=FS, level=95)
    with pytest.raises(ValueError, match="no records"):
        batch([], fs=FS)


def test_explicit_terms_and_progress():
    seen = []
    rng = np.random.default_rng(7)
    # white noise plus a rate random walk K = 1e-4 (sigma of the rate steps * sqrt(fs))
    x = 0.01 * rng.standard_normal(N_SAMPLES) + 1e-5 * np.cumsum(rng.standard_normal(N_SAMPLES))
    res = batch(
        [("a", x), ("b", x[::-1].copy()), ("c", x)],
        fs=FS,
        terms=["N", "K"],
        datasheet={"K": 1.0},
        progress=lambda stage, done, total: seen.append((stage, done, total)),
    )
    assert [c for c in res.columns if not c.endswith(("_low", "_high"))][5:] == [
        "p_value",
        "rejected",
        "N",
        "K",
        "check_K",
        "status",
        "pass",
        "error",
    ]
    assert seen == [("records", 1, 3), ("records", 2, 3), ("records", 3, 3)]
    k, k_low, k_high = res.column("K")[0], res.column("K_low")[0], res.column("K_high")[0]
    se = (k_high - k_low) / (2 * 1.96)
    assert abs(k - 1e-5 * np.sqrt(FS)) < 4 * se
    with pytest.raises(ValueError, match="not coefficients"):
        batch([("a", x)], fs=FS, terms=["N"], datasheet={"K": 1.0})


@pytest.mark.slow
def test_local_and_dask_cluster_give_identical_tables():
    distributed = pytest.importorskip("distributed")
    lot = _lot(8)
    sheet = {
        "limits": [
            {"quantity": "N", "max": 0.09, "unit": "deg/sqrt(h)"},
            {"quantity": "adev", "tau": 1, "max": 0.0015, "unit": "deg/s"},
        ]
    }
    local = batch(lot, fs=FS, datasheet=sheet, units="deg/s")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        seen = []
        remote = batch(
            lot,
            fs=FS,
            datasheet=sheet,
            units="deg/s",
            client=client,
            progress=lambda s, d, t: seen.append(d),
        )
    assert remote == local
    assert local.column("status").count("fail") == 1
    assert seen == list(range(1, 9))


def test_cli_batch_glob_datasheet_and_exit_codes(tmp_path, capsys):
    from allanite.cli import main

    for name, x in _lot(4):
        np.save(tmp_path / f"{name}.npy", x)
    sheet = tmp_path / "sheet.json"
    sheet.write_text(json.dumps({"N": 0.0015}))
    out = tmp_path / "table.csv"
    common = ["--fs", "100", "--datasheet", str(sheet), "--no-progress"]
    code = main(["batch", str(tmp_path / "gyro*.npy"), *common, "-o", str(out)])
    assert code == 1  # gyro03 is too noisy
    printed = capsys.readouterr().out
    assert "FAIL" in printed
    assert "gyro03" in printed
    assert "N" in printed.splitlines()[0]
    assert "[" in printed  # intervals shown next to the values
    lines = out.read_text().splitlines()
    assert len(lines) == 5
    assert lines[4].split(",")[0].endswith("gyro03.npy")
    code = main(["batch", str(tmp_path / "gyro0[012].npy"), *common, "--json"])
    assert code == 0
    table = json.loads(capsys.readouterr().out)
    assert len(table["rows"]) == 3
    code = main(
        ["batch", str(tmp_path / "gyro00.npy"), *common, "--terms", "N,K", "--level", "0.9"]
    )
    assert code == 0
    header = capsys.readouterr().out.splitlines()[0].split()
    assert header == ["record", "channel", "p", "rejected", "N", "K", "check_N", "status"]


def test_cli_batch_bad_input(tmp_path, capsys):
    from allanite.cli import main

    assert main(["batch", str(tmp_path / "none*.npy"), "--fs", "100"]) == 2
    assert "no files match" in capsys.readouterr().err
    np.save(tmp_path / "a.npy", np.zeros(100))
    assert (
        main(["batch", str(tmp_path / "a.npy"), "--fs", "100", "-o", str(tmp_path / "t.txt")]) == 2
    )
    assert not (tmp_path / "t.txt").exists()
    broken = tmp_path / "sheet.json"
    broken.write_text("{not json")
    out = tmp_path / "t.csv"
    code = main(["batch", str(tmp_path / "a.npy"), "--fs", "100", "--datasheet", str(broken)])
    assert code == 2
    assert "sheet.json, line 1" in capsys.readouterr().err
    assert not out.exists()


def test_cli_batch_takes_ros2_bag_directories(tmp_path, capsys):
    """Regression: ``allanite batch 'flights/*'`` skipped ROS 2 bags (a directory holding
    metadata.yaml and the .db3/.mcap file) and said "no files match"."""
    pytest.importorskip("rosbags")
    from allanite.cli import main
    from test_io_robot_logs import write_bag

    n = 4000
    data = np.random.default_rng(12).standard_normal((n, 6)) * 1e-3
    for name in ("flight1", "flight2"):
        write_bag(tmp_path / name, "sqlite3", data, np.arange(n) / 200.0, topics=("/imu",))
    (tmp_path / "notes").mkdir()  # a plain directory is no record: an error row (#31)
    argv = ["batch", str(tmp_path / "*"), "--channels", "gyro_x", "--json"]
    assert main(argv) == 1
    table = json.loads(capsys.readouterr().out)
    rows = [dict(zip(table["columns"], row, strict=True)) for row in table["rows"]]
    records = [str(tmp_path / name) for name in ("flight1", "flight2", "notes")]
    assert [r["record"] for r in rows] == records
    assert "is a directory" in rows.pop()["error"]
    assert all(r["channel"] == "gyro_x" and r["units"] == "rad/s" for r in rows)
    assert all(r["n_samples"] == n and r["error"] in (None, "") for r in rows)


def test_a_six_axis_log_is_one_sensor_at_a_time(tmp_path, capsys):
    """Regression: ``allanite batch`` on a ROS bag (gyro rad/s, accelerometer m/s^2) fitted
    all six axes in one unknown unit and printed "the records have no unit (give --units)",
    advice that --units refuses for a log that states both units."""
    pytest.importorskip("rosbags")
    from allanite.cli import main
    from test_io_robot_logs import write_bag

    n = 4000
    data = np.random.default_rng(13).standard_normal((n, 6)) * 1e-3
    write_bag(tmp_path / "flight.bag", "ros1", data, np.arange(n) / 200.0, topics=("/imu",))
    (error,) = batch([tmp_path / "flight.bag"]).column("error")
    assert "(gyro_x, gyro_y, gyro_z in rad/s; accel_x, accel_y, accel_z in m/s^2)" in error
    assert main(["batch", str(tmp_path / "flight.bag")]) == 1
    out = capsys.readouterr().out
    assert "choose its channels with --channels gyro_x,gyro_y,gyro_z, or fit the whole log" in out
    assert "give --units" not in out
    assert main(["batch", str(tmp_path / "flight.bag"), "--channels", "accel_x,accel_y"]) == 0
    out = capsys.readouterr().out
    assert "N in m/s/sqrt(h)" in out
