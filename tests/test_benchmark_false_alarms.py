"""The design of benchmarks/calibrate_false_alarms.py: its null records, rows and summary."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy import stats

import benchmark_module
from allanite.units import convert

fa = benchmark_module.load("calibrate_false_alarms")


def test_clopper_pearson_on_known_counts() -> None:
    # 0 of 20: the upper bound solves (1 - p)^20 = 0.025
    none = fa.rate(0, 20)
    assert none["rate"] == 0.0
    assert none["low"] == 0.0
    assert none["high"] == pytest.approx(1.0 - 0.025 ** (1 / 20), rel=1e-9)
    assert none["high"] == pytest.approx(0.168, abs=5e-4)
    every = fa.rate(20, 20)
    assert every["low"] == pytest.approx(0.025 ** (1 / 20), rel=1e-9)
    assert every["high"] == 1.0
    # an inner count against scipy's exact binomial interval
    some = fa.rate(3, 100)
    ci = stats.binomtest(3, 100).proportion_ci(0.95, method="exact")
    assert (some["low"], some["high"]) == pytest.approx((ci.low, ci.high), rel=1e-9)
    assert fa.rate(0, 0)["rate"] is None


def test_draws_are_reproducible_and_cover_the_design() -> None:
    records = [fa.draw(i) for i in range(60)]
    assert fa.draw(7) == records[7]
    assert fa.draw(7, grid_seed=15) != records[7]
    assert {r.sensor for r in records} == set(fa.CLASSES)
    assert {r.unit for r in records} == set(fa.UNITS)
    for r in records:
        assert r.n in fa.LENGTHS or r.n == fa.LONG_LENGTH
        assert r.fs in fa.RATES
        assert r.sensor == "designed" or r.terms[0] == "N"


@pytest.mark.parametrize("sensor", list(fa.SENSORS))
@pytest.mark.parametrize("unit", fa.UNITS)
def test_class_coefficients_lie_in_their_customary_ranges(sensor: str, unit: str) -> None:
    terms = ("N", "Q", "B", "K", "R", "markov")
    for seed in range(5):
        record = fa.Record(0, sensor, terms, 2**14, 200.0, unit, seed)
        model = fa.model_of(record)
        assert model.units["rate"] == unit
        by_type = {t.type: t for t in model.terms}
        for symbol in ("N", "Q", "B", "K", "R"):
            value = by_type[fa.TERM_KIND[symbol]].values()[symbol]
            got = convert(
                value, fa.coefficient_unit(unit, *fa.SYMBOL_POWERS[symbol]), fa.CUSTOMARY[symbol]
            )
            lo, hi = fa.SENSORS[sensor][symbol]
            assert lo * (1 - 1e-9) <= got <= hi * (1 + 1e-9), (symbol, got)
        gm = by_type["markov"]
        assert 20.0 / 200.0 <= gm.tau_c <= 2**14 / 200.0 / 3.0


def test_designed_record_uses_validate_fit_span_design() -> None:
    record = next(r for r in (fa.draw(i) for i in range(100)) if r.sensor == "designed")
    model = fa.model_of(record)
    case = fa.vf.Case(0, record.terms, record.n, record.fs, "log", "rate", record.unit, record.seed)
    assert model.to_dict() == fa.vf.design_span(case).to_dict()


def _row(index: int, *, n: int, significant: bool, spike_p: float, unit: str) -> dict[str, Any]:
    return {
        "index": index,
        "sensor": "mems",
        "terms": ["N", "B"],
        "n": n,
        "fs": 100.0,
        "unit": unit,
        "seed": 1000 + index,
        "model": {"terms": [{"type": "white", "N": 0.1}]},
        "null": "full",
        "significant": significant,
        "p_value": 0.01 if significant else 0.5,
        "views": {"tau": 0.5, "frequency": 0.5, "time": min(1.0, 9 * spike_p)},
        "families": {"tau:T": 0.5, "time:spike": spike_p, "time:level": 0.7},
        "closed": not significant,
        "headline": "",
        "seconds": 1.0,
    }


def test_summary_flags_an_anti_conservative_family_and_the_worst_cell() -> None:
    # 40 records: the spike family has p = 0.001 in 12 of them (30 %, far above 1 % and 5 %),
    # and the 12 alarms all fall in the deg/h cell (12 of 20)
    rows = [
        _row(
            i,
            n=2**16 if i != 5 else 2**14,
            significant=i < 12,
            spike_p=(1e-9 if i == 5 else 0.001) if i < 12 else 0.6,
            unit="deg/h" if i < 20 else "deg/s",
        )
        for i in range(40)
    ]
    s = fa.summarize(rows)
    assert s["false_alarms"]["k"] == 12
    assert s["false_alarms"]["n"] == 40
    assert s["worst_cell"]["grouping"] == "unit"
    assert s["worst_cell"]["cell"] == "deg/h"
    assert s["worst_cell"]["k"] == 12
    assert s["worst_cell"]["n"] == 20
    assert {(c["grouping"], c["cell"]) for c in s["cells_above_goal"]} >= {("unit", "deg/h")}
    flagged = {(a["statistic"], a["level"]) for a in s["anti_conservative"]}
    assert ("time:spike", 0.01) in flagged
    assert ("time:spike", 0.05) in flagged
    assert not any(name in ("tau", "tau:T", "time:level") for name, _ in flagged)
    assert {a["null"] for a in s["anti_conservative"]} == {"all", "full"}
    assert s["calibration_by_null"]["full"] == s["calibration"]
    spike = next(a for a in s["anti_conservative"] if a["statistic"] == "time:spike")
    assert spike["reproducer"]["index"] == 5
    assert spike["reproducer"]["n"] == 2**14
    assert s["calibration"]["time:level"]["p<0.05"]["k"] == 0
    assert s["calibration"]["time:spike"]["min_p"] == 1e-9
    # one p of 1e-9 in 40 records: out of reach of a calibrated test (chance 4e-5)
    extreme = {(e["statistic"], e["null"]): e for e in s["extreme_p"]}
    assert set(extreme) == {("time:spike", "full"), ("time", "full")}  # the view holds it
    assert extreme["time:spike", "full"]["count"] == 1
    assert extreme["time:spike", "full"]["reproducer"]["index"] == 5


def test_tiny_records_run_end_to_end(tmp_path: Path) -> None:
    base = fa.Record(0, "mems", ("N", "B", "markov"), 4096, 100.0, "deg/h", 11)
    records = [
        base,
        replace(base, index=1, sensor="navigation", terms=("N", "Q", "K"), unit="rad/s", seed=12),
        replace(base, index=2, sensor="consumer", terms=("N", "R"), unit="deg/s", seed=13),
    ]
    rows = [fa.evaluate(r, n_mc=20) for r in records]
    for row in rows:
        assert set(row["views"]) == {"tau", "frequency", "time"}
        assert {"tau:T", "frequency:line", "frequency:band"} <= set(row["families"])
        assert any(k.startswith("time:") for k in row["families"])
        assert all(0.0 <= p <= 1.0 for p in row["families"].values())
        assert row["n_mc"] == 20
        assert row["null"] == "full"
        assert isinstance(row["headline"], str)
        assert row["headline"]
        assert row["seconds"] > 0.0
        # the overall p is the Bonferroni combination of the three views
        assert row["p_value"] == pytest.approx(min(1.0, 3 * min(row["views"].values())))
        assert row["significant"] == (row["p_value"] < fa.SIGNIFICANCE)
    stem = tmp_path / "false_alarms_test"
    summary = fa.write(stem, rows, "test")
    stored = json.loads(stem.with_suffix(".json").read_text())
    assert list(stored) == ["command", "rows", "summary"]
    assert stored["summary"] == json.loads(json.dumps(summary))
    assert summary["records"] == 3
    assert summary["false_alarms"]["k"] == sum(r["significant"] for r in rows)
    assert set(summary["cells"]) == {"sensor", "length", "fs", "unit", "term", "null"}
    assert summary["cells"]["length"]["2^12"]["n"] == 3
    assert sum(v["n"] for v in summary["cells"]["unit"].values()) == 3
    for name in ("tau", "frequency", "time", "tau:T"):
        entry = summary["calibration"][name]
        assert set(entry) == {"p<0.01", "p<0.05", "min_p"}
        assert entry["p<0.05"]["n"] == 3
        assert entry["p<0.01"]["k"] <= entry["p<0.05"]["k"]
    text = stem.with_suffix(".md").read_text()
    assert "False alarms on null records nobody picked" in text
    assert "| time |" in text
    # --summarize rewrites the same summary from the stored rows
    assert fa.main(["--summarize", str(stem.with_suffix(".json"))]) == 0
    again = json.loads(stem.with_suffix(".json").read_text())["summary"]
    assert again == stored["summary"]
    assert math.isfinite(summary["seconds"]["total"])
    assert np.isfinite(summary["calibration"]["tau"]["min_p"])


def test_fixed_length_keeps_the_other_draws() -> None:
    for i in range(20):
        free, long = fa.draw(i), fa.draw(i, length=fa.LONG_LENGTH)
        assert long.n == fa.LONG_LENGTH
        assert (long.sensor, long.fs, long.unit, long.seed) == (
            free.sensor,
            free.fs,
            free.unit,
            free.seed,
        )


def test_summarize_pools_distinct_runs_and_refuses_shared_records(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    first = [_row(i, n=2**15, significant=i == 0, spike_p=0.5, unit="deg/s") for i in range(10)]
    second = [_row(i, n=10**6, significant=False, spike_p=0.5, unit="rad/s") for i in range(10)]
    fa.write(tmp_path / "a", first, "run a")
    fa.write(tmp_path / "b", second, "run b")
    paths = [str(tmp_path / "a.json"), str(tmp_path / "b.json")]
    monkeypatch.setattr(fa, "RESULTS", tmp_path)
    assert fa.main(["--summarize", *paths, "--tag", "pooled"]) == 0
    pooled = json.loads((tmp_path / "false_alarms_pooled.json").read_text())
    assert pooled["summary"]["false_alarms"]["k"] == 1
    assert pooled["summary"]["false_alarms"]["n"] == 20
    assert pooled["summary"]["cells"]["length"]["1e6"]["n"] == 10
    assert pooled["command"] == "run a + run b"
    with pytest.raises(ValueError, match="share records"):
        fa.main(["--summarize", paths[0], paths[0], "--tag", "twice"])
