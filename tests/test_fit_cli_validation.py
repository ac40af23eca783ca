"""``allanite fit FILE`` against ``allanite.fit`` on the validation grid's records (issue 12).

``benchmarks/validate_fit.py --cli`` writes grid records as a user has them (npy, CSV with a
units header, one or six channels, a time column), runs the CLI's default path and compares
it with the API on the same record; a handful of those records here (``slow``: a subprocess
and two fits each). The unit checks are fast: a deg/h record gives the deg/s record's
customary coefficients, and a record without ``--units`` says so instead of assuming deg/s.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import allanite
import benchmark_module
from allanite.cli import main

fit_module = pytest.importorskip("allanite.fit", reason="the fitter is not installed")


def _slice(vf: Any) -> list[tuple[Any, Any]]:
    """One short record per file form of the CLI grid: npy/CSV, one/six channels, time column."""
    chosen: dict[tuple[str, str, bool], tuple[Any, Any]] = {}
    for case, form in vf.cli_grid():
        key = (form.fmt, form.layout, form.time_column)
        if case.n == 100_000 and key not in chosen:
            chosen[key] = (case, form)
    return list(chosen.values())


@pytest.mark.slow
def test_cli_slice_matches_api_and_scores(tmp_path: Path) -> None:
    vf = benchmark_module.load("validate_fit")
    pairs = _slice(vf)
    forms = {(f.fmt, f.layout, f.time_column) for _, f in pairs}
    assert {("npy", "single", False), ("csv", "six", True), ("npy", "six", False)} <= forms
    assert {c.input for c, _ in pairs} == {"rate", "angle"}
    for case, form in pairs:
        row = vf.run_case_cli(case, form, tmp_path)
        assert row["returncode"] == 0, row["stderr"]
        # the same terms, coefficients and bounds as the API, the JSON's unit the record's
        assert row["ok"], row["mismatches"]
        assert row["worst_rel"] <= vf.CLI_REL
        assert not row["rejected"], row
        assert not row["missing_clear"], row
        for name, entry in row["terms"].items():
            if entry["dominant"] and entry["value"] is not None:
                # a 5-sigma miss has probability 6e-7 per term for an honest interval
                assert abs(entry["z"]) < 5, (case, name, entry)
    summary = vf.summarise_cli([vf.run_case_cli(*pairs[0], tmp_path)])
    assert summary["cli"]["agree"] == 1
    assert summary["records"] == 1


def test_cli_records_are_written_in_the_users_units(tmp_path: Path) -> None:
    # rate records in their unit; an angle record in the angle unit its gyro has (deg for deg/h)
    vf = benchmark_module.load("validate_fit")
    case = vf.Case(0, ("N",), 20_000, 100.0, "octave", "rate", "deg/s", seed=5)
    form = vf.CliForm("npy", "single")
    x = np.asarray(vf.design(case).simulate(case.n, fs=case.fs, seed=case.seed)).ravel()
    _, flags, _, rate = vf.write_cli_record(case, form, x, tmp_path)
    assert rate == "deg/s"
    assert flags[flags.index("--units") + 1] == "deg/s"
    angle = vf.Case(1, ("N",), 20_000, 100.0, "octave", "angle", "deg/h", seed=5)
    _, flags, _, rate = vf.write_cli_record(angle, form, x, tmp_path)
    # a deg/h gyro's angle is written in deg: its rate unit is deg/s
    assert flags[flags.index("--units") + 1] == "deg"
    assert rate == "deg/s"
    np.testing.assert_allclose(np.load(tmp_path / "rec1.npy"), x / 3600.0, rtol=1e-15)


def _fit_json(args: list[str], capsys: pytest.CaptureFixture[str]) -> dict[str, Any]:
    code = main(["fit", *args, "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)["channels"][0]


def test_cli_units_deg_h_rad_s_and_none(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # issue 12's "N 60x wrong": the same record in deg/s, deg/h and rad/s gives the same
    # customary coefficients (deg/sqrt(h), for rad/s too), and without --units the CLI says the
    # coefficients are in the record's own units instead of silently assuming deg/s
    fs, n_true = 100.0, 0.01  # deg/sqrt(s)
    rate = np.random.default_rng(12).normal(size=30_000) * n_true * np.sqrt(fs)
    files: dict[str, Path] = {}
    for unit, factor in (("deg/s", 1.0), ("deg/h", 3600.0), ("rad/s", np.pi / 180.0)):
        files[unit] = tmp_path / f"r{len(files)}.npy"
        np.save(files[unit], rate * factor)
    common = ["--fs", "100", "--taus", "octave"]
    got = {u: _fit_json([str(p), *common, "--units", u], capsys) for u, p in files.items()}
    n = {u: {r["symbol"]: r for r in ch["coefficients"]}["N"] for u, ch in got.items()}
    assert n["deg/s"]["unit"] == n["deg/h"]["unit"] == n["rad/s"]["unit"] == "deg/sqrt(h)"
    assert n["deg/h"]["value"] == pytest.approx(n["deg/s"]["value"], rel=1e-9)
    assert n["rad/s"]["value"] == pytest.approx(n["deg/s"]["value"], rel=1e-9)
    # the API on the deg/s record: N in deg/sqrt(s), 60 x that in deg/sqrt(h)
    api = fit_module.fit(allanite.avar(rate, fs=fs, taus="octave", units="deg/s"))
    assert n["deg/s"]["value"] == pytest.approx(60.0 * api["N"].value, rel=1e-9)
    for unit, ch in got.items():
        assert ch["units"] == unit
        assert ch["model"]["units"]["rate"] == unit
    # no --units: a stated assumption (record units), never deg/s
    bare = _fit_json([str(files["rad/s"]), *common], capsys)
    assert bare["units"] is None
    assert bare["model"]["units"]["rate"] == "unit"
    assert {r["unit"] for r in bare["coefficients"] if r["symbol"] == "N"} == {"unit*sqrt(s)"}
    code = main(["fit", str(files["rad/s"]), *common])
    out, _ = capsys.readouterr()
    assert code == 0
    assert "no --units given: coefficients in the record's own units" in out
    assert "deg" not in out


def test_one_column_csv_with_a_units_header(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # found by validate_fit.py --cli: a one-column CSV whose header states the unit
    # ("gyro [rad]") was refused ("the header names 2 column(s) but the rows have 1"): the
    # header was split at the space because one column has no delimiter to detect
    fs = 100.0
    angle = np.cumsum(np.random.default_rng(3).normal(size=20_000)) * 1e-4
    path = tmp_path / "angle.csv"
    np.savetxt(path, angle, fmt="%.17g", header="gyro [rad]", comments="")
    ch = _fit_json(
        [str(path), "--fs", "100", "--input", "angle", "--units", "rad", "--taus", "octave"],
        capsys,
    )
    assert ch["channel"] == "gyro [rad]"
    assert ch["units"] == "rad/s"
    api = fit_module.fit(allanite.avar(angle, fs=fs, input="angle", taus="octave", units="rad/s"))
    n = {r["symbol"]: r for r in ch["coefficients"]}["N"]
    assert n["unit"] == "deg/sqrt(h)"  # customary; the model keeps rad/s
    assert ch["model"]["units"]["rate"] == "rad/s"
    assert n["value"] == pytest.approx(60.0 * np.rad2deg(api["N"].value), rel=1e-9)
    # several columns still split at the delimiter; a ragged one-column file is still refused
    two = tmp_path / "two.csv"
    np.savetxt(
        two, np.c_[angle, angle], fmt="%.17g", delimiter=",", header="a [rad],b [rad]", comments=""
    )
    assert allanite.io.read_record(two, fs=fs).channels == ("a [rad]", "b [rad]")
    bad = tmp_path / "bad.csv"
    np.savetxt(bad, angle, fmt="%.17g", header="a [rad],b [rad]", comments="")
    with pytest.raises(ValueError, match=r"the header names \d column\(s\) but the rows have 1"):
        allanite.io.read_record(bad, fs=fs)


def test_cli_comparison_reports_a_wrong_unit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the CLI-vs-API comparison is not vacuous: the record labelled deg/h instead of deg/s
    # (a 3600x error) is reported as a units and a coefficient mismatch
    vf = benchmark_module.load("validate_fit")
    case = vf.Case(0, ("N",), 20_000, 100.0, "octave", "rate", "deg/s", seed=5)
    write = vf.write_cli_record

    def mislabelled(*args: Any) -> Any:
        path, flags, channel, rate = write(*args)
        return path, [("deg/h" if f == "deg/s" else f) for f in flags], channel, rate

    monkeypatch.setattr(vf, "write_cli_record", mislabelled)
    row = vf.run_case_cli(case, vf.CliForm("npy", "single"), tmp_path)
    assert not row["ok"]
    text = " ".join(row["mismatches"])
    assert "units 'deg/h', expected 'deg/s'" in text
    assert "N value" in text
    assert "-o model N" in text
