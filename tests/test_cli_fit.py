"""``allanite fit``: coefficients in customary units from the library's fit, model JSON out."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import allanite
from allanite.cli import main
from allanite.confidence import DEFAULT_LEVEL
from allanite.datasheet import undetected_measured

fit_module = pytest.importorskip("allanite.fit", reason="the fitter (issue 3) is not installed")
if not hasattr(fit_module, "fit"):
    pytest.skip("allanite.fit.fit is not available yet", allow_module_level=True)

FS = 100.0
RNG = np.random.default_rng(17)
N_TRUE = 0.01  # deg/s/sqrt(Hz) = deg/sqrt(s)
RATE = RNG.normal(size=40_000) * N_TRUE * np.sqrt(FS)


def test_fit_cli_json_model_and_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "rate.npy"
    np.save(data, RATE)
    model_path = tmp_path / "model.json"
    plot = tmp_path / "fit.png"
    code = main(
        [
            "fit",
            str(data),
            "--fs",
            "100",
            "--units",
            "deg/s",
            "--points",
            "40",
            "--json",
            "-o",
            str(model_path),
            "--plot",
            str(plot),
        ]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    data_out = json.loads(out)
    (channel,) = data_out["channels"]
    rows = {r["symbol"]: r for r in channel["coefficients"]}
    expected = fit_module.fit(allanite.avar(RATE, fs=FS, points=40, units="deg/s"))
    n = expected["N"]
    # customary unit: deg/sqrt(s) -> deg/sqrt(h) is a factor 60; intervals at the default level
    assert rows["N"]["unit"] == "deg/sqrt(h)"
    assert rows["N"]["value"] == pytest.approx(60 * n.value, rel=1e-12)
    lo, hi = n.ci(DEFAULT_LEVEL)
    assert rows["N"]["low"] == pytest.approx(60 * lo, rel=1e-12)
    assert rows["N"]["high"] == pytest.approx(60 * hi, rel=1e-12)
    # white noise: the fitted N agrees with the truth within 4 of its standard errors
    assert abs(n.value - N_TRUE) < 4 * n.stderr
    model = allanite.NoiseModel.from_json(model_path.read_text())
    assert model.units["rate"] == "deg/s"
    assert plot.read_bytes()[:4] == b"\x89PNG"


def test_fit_cli_text_and_bad_kind(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "rate.txt"
    np.savetxt(data, RATE[:20_000])
    assert main(["fit", str(data), "--fs", "100", "--units", "deg/s", "--points", "30"]) == 0
    out = capsys.readouterr().out
    assert "channel col0 (gyro, deg/s):" in out
    assert "angle random walk" in out
    assert "deg/sqrt(h)" in out
    target = tmp_path / "m.json"
    assert main(["fit", str(data), "--fs", "100", "--kind", "modified", "-o", str(target)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "overlapping" in err[0]
    assert not target.exists()


def test_fit_cli_datasheet_exit_codes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "rate.npy"
    np.save(data, RATE[:20_000])
    common = ["fit", str(data), "--fs", "100", "--units", "deg/s", "--points", "30", "--json"]
    # N = 0.01 deg/sqrt(s) = 0.6 deg/sqrt(h)
    loose = tmp_path / "loose.json"
    loose.write_text(json.dumps({"limits": [{"quantity": "N", "max": 2, "unit": "deg/sqrt(h)"}]}))
    tight = tmp_path / "tight.json"
    tight.write_text(json.dumps({"limits": [{"quantity": "N", "max": 0.3, "unit": "deg/sqrt(h)"}]}))
    assert main([*common, "--datasheet", str(loose)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["passed"] is True
    assert out["channels"][0]["checks"][0]["status"] == "pass"
    assert main([*common, "--datasheet", str(tight)]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["passed"] is False
    expected = fit_module.fit(allanite.avar(RATE[:20_000], fs=FS, points=30, units="deg/s"))
    assert out["channels"][0]["checks"][0]["value"] == pytest.approx(60 * expected["N"].value)


def test_datasheet_on_a_term_not_detected(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """White noise only: B is not fitted, but its upper limit decides a loose B limit (PASS)
    and leaves a tight one NOT DETERMINED (exit 0: undecided, not failed); fit and batch,
    text, JSON and CSV."""
    data = tmp_path / "rate.npy"
    np.save(data, RATE[:20_000])
    rec = allanite.avar(RATE[:20_000], fs=FS, points=30, units="deg/s")
    f = fit_module.fit(rec)
    assert "B" not in f.coefficients  # left out (here an AMBIGUOUS addition, with a bound)
    upper = 3600 * undetected_measured(f, DEFAULT_LEVEL)["B"].high  # deg/h
    sheet = tmp_path / "sheet.json"
    limits = [
        {"quantity": "B", "max": 2 * upper, "unit": "deg/h"},
        {"quantity": "B", "max": upper / 2, "unit": "deg/h"},
    ]
    sheet.write_text(json.dumps({"limits": limits}))
    common = ["fit", str(data), "--fs", "100", "--units", "deg/s", "--points", "30"]
    assert main([*common, "--datasheet", str(sheet)]) == 0
    text = capsys.readouterr().out
    assert f"datasheet B: not detected (<= {upper:.3g} deg/h) -> PASS" in text
    assert f"datasheet B: not detected (<= {upper:.3g} deg/h) -> NOT DETERMINED" in text
    assert "MISSING" not in text
    assert main([*common, "--datasheet", str(sheet), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    checks = out["channels"][0]["checks"]
    assert [c["status"] for c in checks] == ["pass", "undetermined"]
    assert checks[1]["value"] is None
    assert checks[1]["upper"] == pytest.approx(upper)
    assert out["passed"] is True
    # batch: the same verdicts, the upper limit in the table and the exit code 0
    csv = tmp_path / "lot.csv"
    argv = ["batch", str(data), "--fs", "100", "--units", "deg/s", "--points", "30"]
    assert main([*argv, "--datasheet", str(sheet), "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert f"NOT DETERMINED (<= {upper:.4g})" in text
    assert f"<={upper:.4g}" in text
    assert main([*argv, "--datasheet", str(sheet), "--no-progress", "-o", str(csv)]) == 0
    head, row = csv.read_text().splitlines()[:2]
    cells = dict(zip(head.split(","), row.split(","), strict=True))
    assert cells["check_B"] == "pass"
    assert cells["check_B_2"] == "undetermined"
    assert cells["status"] == "undetermined"
    assert cells["pass"] == "True"
    assert float(cells["B_upper"]) == pytest.approx(upper / 3600)


def test_fit_text_short_on_a_six_axis_white_noise_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Six channels of white noise: additions the record shows no evidence of (zero estimate
    or a chi-square drop below 1) are listed once per channel as "not detected" with their
    upper limit, not as AMBIGUOUS lines; every line stays readable (<= 170 characters)."""
    from allanite.fit.result import NO_EVIDENCE_CHI2

    rng = np.random.default_rng(3)
    x = np.hstack([rng.standard_normal((60_000, 3)), 0.02 * rng.standard_normal((60_000, 3))])
    path = tmp_path / "imu.npy"
    np.save(path, x)
    code = main(["fit", str(path), "--fs", "100", "--units", "deg/s,deg/s,deg/s,m/s^2,m/s^2,m/s^2"])
    assert code == 0
    text = capsys.readouterr().out
    assert max(len(line) for line in text.splitlines()) <= 170
    assert text.count("not detected (95 % upper limits): ") == 6
    weak = 0
    for c in range(6):
        unit = "deg/s" if c < 3 else "m/s^2"
        f = fit_module.fit(allanite.avar(x[:, c], fs=FS, units=unit))
        note, undetected = f.ambiguity_note(), f.undetected_line()
        for alt in f.alternatives:
            coef = f.exchangeable[alt["symbol_in"]]
            silent = alt["symbol_out"] is None and (
                coef.value <= 0 or alt["delta_chi2"] < NO_EVIDENCE_CHI2
            )
            weak += silent
            shown = f"{alt['symbol_in']} <= " in undetected
            assert shown == silent, (c, alt)
            assert (f"{alt['swap_in']} {alt['symbol_in']} =" in note) != silent, (c, alt)
        # the JSON keeps every alternative with its note
        assert len(f.alternatives_dict()) == len(f.alternatives)
    assert weak >= 3  # the case this test is about occurs on this record


def test_fit_json_gives_the_upper_limits_the_text_prints(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--json`` carries the text's "not detected (95 % upper limits)" line as
    ``"undetected"``: every left-out candidate with its upper limit in the same customary
    unit (a user scripting the CLI can tell "not detected, <= u" from "not reported")."""
    data = tmp_path / "rate.npy"
    np.save(data, RATE[:20_000])
    common = ["fit", str(data), "--fs", "100", "--units", "deg/s", "--points", "30"]
    assert main(common) == 0
    text = capsys.readouterr().out
    (line,) = [x for x in text.splitlines() if "not detected (95 % upper limits): " in x]
    shown = dict(
        part.split(" <= ") for part in line.split("upper limits): ")[1].strip().split(", ")
    )
    assert main([*common, "--json"]) == 0
    (channel,) = json.loads(capsys.readouterr().out)["channels"]
    got = {u["symbol"]: u for u in channel["undetected"]}
    assert list(got) == list(shown)  # the same terms, in the same order (Q N B K R)
    f = fit_module.fit(allanite.avar(RATE[:20_000], fs=FS, points=30, units="deg/s"))
    for symbol, printed in shown.items():
        assert f"{got[symbol]['high']:.3g} {got[symbol]['unit']}" == printed
        assert symbol not in f.coefficients
        high, unit = f.upper_limits()[symbol]
        assert got[symbol]["high"] == pytest.approx(high, rel=1e-12)
        assert got[symbol]["unit"] == unit
    # the gyro's customary units (deg, deg/h, deg/h/sqrt(h), deg/h^2), not the model's
    units = {"Q": "deg", "B": "deg/h", "K": "deg/h/sqrt(h)", "R": "deg/h^2"}
    assert {s: u["unit"] for s, u in got.items()} == {s: units[s] for s in got}
    assert got["K"]["high"] > 0


def test_fit_csv_with_a_time_column_the_error_names_a_fix_that_works(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``allanite fit imu.csv`` on a CSV whose header names the time column ``t [s]`` (units
    in brackets, as users and ``allanite simulate`` write them): the error names the time
    column, and its fix pasted into a shell (split as a shell splits it) fits the record."""
    import shlex

    path = tmp_path / "imu.csv"
    t = np.arange(20_000) / FS
    np.savetxt(
        path,
        np.column_stack([t, RATE[:20_000]]),
        delimiter=",",
        header="t [s],gz [deg/s]",
        comments="",
    )
    assert main(["fit", str(path)]) == 2
    err = capsys.readouterr().err
    assert "column 't [s]' looks like the time: --time-column " in err
    fix = shlex.split(err.strip().splitlines()[-1].split("looks like the time: ")[1])
    assert main(["fit", str(path), *fix, "--json"]) == 0
    (channel,) = json.loads(capsys.readouterr().out)["channels"]
    assert channel["units"] == "deg/s"  # from the header
    rows = {r["symbol"]: r for r in channel["coefficients"]}
    assert rows["N"]["low"] <= 60 * N_TRUE <= rows["N"]["high"]


def test_fit_csv_time_column_given_fs_instead_the_notes_name_the_time_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A CSV with ``t [s]`` and ``gz [deg/s]`` read with ``--fs`` (the time column not named):
    the time column is analysed as a channel and the header's units are not used; the notes
    say why (a time column) and give the fix, quoted for the shell, instead of advising
    ``--input angle`` for a header that states deg/s."""
    import shlex

    path = tmp_path / "imu.csv"
    t = np.arange(20_000) / FS
    header = "t [s],gz [deg/s]"
    np.savetxt(path, np.column_stack([t, RATE[:20_000]]), delimiter=",", header=header, comments="")
    assert main(["fit", str(path), "--fs", "100"]) == 0
    err = capsys.readouterr().err
    assert "--input angle or increment" not in err
    note = [x for x in err.splitlines() if "t [s] is a time column read as a channel" in x]
    assert len(note) == 1
    fix = shlex.split(note[0].split("give ")[1].split(" to read it")[0])
    assert fix == ["--time-column", "t [s]"]
    assert "give --time-column 't [s]' (time_column='t [s]')" in err  # the channel-name note
