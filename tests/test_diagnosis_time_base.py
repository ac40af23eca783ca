"""The time base in the diagnosis: gaps and jitter of time stamps, held samples."""

from __future__ import annotations

import json

import numpy as np
import pytest

from allanite.diagnosis import diagnose
from allanite.diagnosis.time_base import held_samples_item, time_base_items, with_time_base
from allanite.diagnosis.verdict import Verdict
from allanite.io import make_record
from allanite.model import NoiseModel
from allanite.terms import RateRandomWalk, White

FS = 100.0
UNITS = {"rate": "deg/s", "time": "s"}
MODEL = NoiseModel((White(N=0.05), RateRandomWalk(K=1e-4)), UNITS)


def _noise(n: int, seed: int) -> np.ndarray:
    return np.asarray(MODEL.simulate(n, fs=FS, seed=seed)).ravel()


def _dropped(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int]]]:
    """Time stamps and samples with runs of 1-5 samples dropped; the true (start, length)."""
    rng = np.random.default_rng(seed)
    keep = np.ones(n, dtype=bool)
    truth = []
    k = 50
    while k < n - 50:
        run = int(rng.integers(1, 6))
        keep[k : k + run] = False
        truth.append((k, run))
        k += run + int(rng.integers(200, 400))
    t = np.arange(n) / FS
    return t[keep], _noise(n, seed)[keep], truth


def test_gaps_of_a_time_column_are_reported_with_times_and_count():
    t, x, truth = _dropped(2**13, 4)
    rec = make_record(np.column_stack([t, x]), ["t", "gyro"], source="test", time_column="t",
                      gaps="fill", units="deg/s")  # fmt: skip
    items = time_base_items(rec)
    assert [i.evidence for i in items] == ["time base"]
    item = items[0]
    assert item.view == "time"
    assert item.size["gaps"] == len(truth)
    assert item.size["missing_samples"] == sum(r for _, r in truth)
    # each gap starts at the last sample before it and lasts (run + 1) periods
    starts = [a for a, _ in item.where["time_segments_s"]]
    np.testing.assert_allclose(starts, [(k - 1) / FS for k, _ in truth], atol=1e-9)
    assert "time stamps have" in item.text


def test_jittered_time_stamps_are_reported():
    n = 4096
    t = np.arange(n) / FS + np.random.default_rng(1).uniform(-0.2, 0.2, n) / FS
    rec = make_record(np.column_stack([t, _noise(n, 2)]), ["t", "gyro"], source="test",
                      time_column="t", units="deg/s")  # fmt: skip
    items = time_base_items(rec)  # without the rates: any jitter above the reader's level
    assert [i.evidence for i in items] == ["time base"]
    # uniform +-0.2 periods on each stamp: intervals have rms 0.2 * sqrt(2/3) = 0.163 periods
    assert items[0].size["jitter_rms_relative"] == pytest.approx(0.163, rel=0.05)


def _jittered_angle(n: int, table: float, jitter: float, seed: int) -> tuple[np.ndarray, ...]:
    """Angle samples taken at jittered instants of a turntable at ``table`` deg/s."""
    rng = np.random.default_rng(seed)
    t = np.arange(n + 1) / FS + rng.normal(0.0, jitter / FS, n + 1)
    rate = _noise(n + 1, seed)
    angle = np.concatenate([[0.0], np.cumsum(rate[:-1]) / FS]) + table * t
    return t, angle


def test_a_jitter_the_record_cannot_show_is_not_a_gap():
    """Regression: a ROS bag's ordinary 1 % jitter kept every diagnosis from "closed".

    At rest a sample off its instant by 1 % of the period changes by the slope times that,
    about 1e-7 of the noise variance; the reader's note stays, the item goes.
    """
    n = 2**14
    rng = np.random.default_rng(5)
    t = np.arange(n) / FS + rng.normal(0.0, 0.011 / FS, n)
    x = _noise(n, 6)
    rec = make_record(np.column_stack([t, x]), ["t", "gyro"], source="test", time_column="t",
                      units="deg/s")  # fmt: skip
    assert any("jitter" in w for w in rec.warnings)  # the reader still says so
    assert time_base_items(rec, rec.samples[:, 0], "rate") == []
    d = diagnose(rec, MODEL, n_mc=40, seed=1)
    assert not any(u.evidence == "time base" for u in d.unexplained)


def test_a_jitter_on_a_turntable_is_reported_with_its_share():
    """Angle samples at jittered instants (0.02 periods rms per stamp) on a 20 deg/s table:
    each rate sample is off by 20 * 100 * (d_k+1 - d_k); half its mean squared first
    difference is 3 (20 * 0.02)^2 = 0.48 (deg/s)^2 against the white noise's 0.05^2 * 100 =
    0.25: the jitter's share of the short-term variance is 0.48 / 0.73 = 0.66."""
    n = 2**14
    t, angle = _jittered_angle(n, 20.0, 0.02, 7)
    rec = make_record(np.column_stack([t, angle]), ["t", "gyro"], source="test",
                      time_column="t", units="deg", input="angle")  # fmt: skip
    rate = np.diff(rec.samples[:, 0]) * rec.fs
    items = time_base_items(rec, rate, "angle")
    assert [i.evidence for i in items] == ["time base"]
    share = items[0].size["extra_variance_share"]
    short = 0.5 * np.mean(np.diff(rate) ** 2)
    measured = 1.0 - 0.05**2 * FS / short  # the part of the short-term variance not white
    # the interval rms is measured from the stamps (sd ~ 1 %), the local rate is the table's
    assert share == pytest.approx(0.48 / 0.73, rel=0.05)
    assert share == pytest.approx(measured, rel=0.05)
    assert "accounts for about 66 % of the short-term noise variance" in items[0].text


def test_a_raw_array_and_an_even_record_have_no_time_base_item():
    x = _noise(4096, 3)
    assert time_base_items(x) == []
    rec = make_record(np.column_stack([np.arange(4096) / FS, x]), ["t", "gyro"], source="test",
                      time_column="t", units="deg/s")  # fmt: skip
    assert time_base_items(rec) == []


def test_held_samples_are_counted():
    x = _noise(2**13, 5)
    rng = np.random.default_rng(6)
    held = np.flatnonzero(rng.random(x.size) < 0.05)
    held = held[held > 0]
    y = x.copy()
    for k in held:
        y[k] = y[k - 1]
    item = held_samples_item(y, FS, 0.005)
    assert item is not None
    assert item.evidence == "held"
    assert item.size["count"] == len(held)
    assert item.where["time_segments_s"][0][0] == pytest.approx(held[0] / FS)
    assert held_samples_item(x, FS, 0.005) is None


def test_quantized_samples_are_not_held_samples():
    # counts of a 16-bit converter: the resolution q is a twentieth of the noise, so equal
    # consecutive counts happen about as often as a step of one count
    x = _noise(2**14, 7)
    q = float(np.std(np.diff(x))) / 20.0
    assert held_samples_item(np.round(x / q) * q, FS, 0.005) is None
    # and a coarse converter (q = 2 sd of the steps): zero steps are the rule, not a defect
    q = 2.0 * float(np.std(np.diff(x)))
    assert held_samples_item(np.round(x / q) * q, FS, 0.005) is None


def test_with_time_base_opens_a_closed_verdict():
    closed = Verdict(True, [], "no gap")
    x = _noise(4096, 8)
    y = x.copy()
    y[100:140] = y[99]
    item = held_samples_item(y, FS, 0.005)
    assert item is not None
    out = with_time_base(closed, [item])
    assert not out.closed
    assert out.unexplained == [item]
    assert out.headline.startswith("no gap; but not everything is explained: time view: 40 held")
    assert with_time_base(closed, []) is closed


def test_diagnose_reports_dropped_samples_of_a_record_with_time_stamps():
    t, x, truth = _dropped(2**13, 9)
    rec = make_record(np.column_stack([t, x]), ["t", "gyro"], source="test", time_column="t",
                      gaps="fill", units="deg/s")  # fmt: skip
    d = diagnose(rec, MODEL, n_mc=20, seed=1)
    assert not d.closed
    items = [u for u in d.unexplained if u.evidence == "time base"]
    assert len(items) == 1
    assert items[0].size["gaps"] == len(truth)
    assert "time stamps have" in d.headline


def test_held_samples_of_quantized_counts_are_found():
    x = _noise(2**14, 10)
    q = float(np.std(np.diff(x))) / 5.0
    y = np.round(x / q) * q
    rng = np.random.default_rng(11)
    for k in np.flatnonzero(rng.random(y.size) < 0.05):
        if k > 0:
            y[k] = y[k - 1]
    item = held_samples_item(y, FS, 0.005)
    assert item is not None
    # zero steps: the held ones plus those of the resolution (about 1/5 * 0.4 of the steps)
    assert item.size["count"] > item.size["expected"]


def test_cli_reports_the_gaps_of_a_csv_time_column(tmp_path, capsys):
    from allanite.cli import main

    t, x, truth = _dropped(2**13, 12)
    path = tmp_path / "gyro.csv"
    np.savetxt(path, np.column_stack([t, x]), delimiter=",", header="t,gyro", comments="")
    model = tmp_path / "model.json"
    MODEL.save(model)
    args = ["diagnose", str(path), "--time-column", "t", "--gaps", "fill", "--units", "deg/s",
            "--sim-model", str(model), "--n-mc", "20", "--json"]  # fmt: skip
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["closed"] is False
    items = [u for u in out["unexplained"] if u["evidence"] == "time base"]
    assert items[0]["size"]["gaps"] == len(truth)


def test_spikes_of_the_mean_rate_in_angle_input_are_dropped_samples():
    from types import SimpleNamespace

    from allanite.diagnosis.time_base import doubled_increments_item

    rng = np.random.default_rng(13)
    heights = 10.0 + 0.5 * rng.standard_normal(30)
    view = SimpleNamespace(spike_amplitudes=list(heights), spike_times_s=list(np.arange(30.0)))
    item = doubled_increments_item("angle", 10.0, view)
    assert item is not None
    assert item.evidence == "time base"
    assert item.size["doubled_increments"] == 30
    assert "dropped angle samples" in item.text
    assert doubled_increments_item("rate", 10.0, view) is None
    # spikes of another size are spikes, not dropped samples
    assert doubled_increments_item("angle", 3.0, view) is None


def test_diagnose_finds_dropped_angle_samples_on_a_turntable():
    rng = np.random.default_rng(14)
    rate = _noise(2**13, 15) + 10.0  # a 10 deg/s turntable, noise sd 0.5 deg/s per sample
    angle = np.concatenate([[0.0], np.cumsum(rate) / FS])
    keep = rng.random(angle.size) > 0.02
    keep[0] = True
    d = diagnose(angle[keep], MODEL, fs=FS, input="angle", units="deg/s", n_mc=20, seed=1)
    assert not d.closed
    items = [u for u in d.unexplained if u.evidence == "time base"]
    assert len(items) == 1
    # each isolated drop gives one rate sample 10 deg/s (20 noise sd) too high: all are found
    # as spikes; a run of two gives one twice as high (not a doubled increment). The spike
    # finder merges neighbours closer than two samples, so two drops that close count once.
    drop = ~keep
    isolated = drop & ~np.roll(drop, 1) & ~np.roll(drop, -1)
    close = int(np.count_nonzero(np.diff(np.flatnonzero(isolated)) <= 2))
    found = items[0].size["doubled_increments"]
    assert int(isolated.sum()) - close <= found <= int(isolated.sum())
