"""HTML report: datasheet checks, slope table, coefficients, self-containment, CLI, Chromium."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import allanite
from allanite.cli import main
from allanite.datasheet import Measured
from allanite.errors import InputError
from allanite.io import Record
from allanite.model import NoiseModel
from allanite.report import (
    Datasheet,
    DeviceAnalysis,
    build_report,
    check_limits,
    coefficient_table,
    customary_rate,
    slope_table,
)
from allanite.terms import RateRandomWalk, White

FS = 100.0
RNG = np.random.default_rng(3)
N = 6000
# white rate noise (ARW) plus a slow random walk: slopes -1/2 then +1/2
SAMPLES = RNG.normal(size=(N, 2)) * 0.5 + np.cumsum(RNG.normal(size=(N, 2)) * 0.002, axis=0)


def _device(samples: np.ndarray = SAMPLES, name: str = "dut.npy") -> DeviceAnalysis:
    record = Record(samples=samples, fs=FS, units="deg/s", channels=("gx", "gy"), source=name)
    return DeviceAnalysis(record, allanite.avar(samples, fs=FS, points=30, units="deg/s"))


# --- datasheet ------------------------------------------------------------------------------
SHEET = {
    "device": "Demo gyro",
    "limits": [
        {"quantity": "adev", "tau": 1.0, "max": 0.2, "unit": "deg/s"},
        {"quantity": "adev", "tau": 1.0, "max": 0.05 * 3600, "unit": "deg/h"},
        {"quantity": "N", "max": 1.0, "unit": "deg/sqrt(h)"},
    ],
}


def test_datasheet_parse_errors(tmp_path: Path) -> None:
    bad = tmp_path / "limits.json"
    bad.write_text('{"limits": [\n  {"quantity": "N", "max": 1,}\n]}')
    with pytest.raises(InputError, match=r"limits.json, line 2: not valid JSON"):
        Datasheet.load(bad)
    with pytest.raises(InputError, match=r"limits\[0\] needs a 'max' and/or a 'min'"):
        Datasheet.from_dict({"limits": [{"quantity": "N", "unit": "deg/sqrt(h)"}]})
    with pytest.raises(InputError, match=r"'adev' limit needs 'tau'"):
        Datasheet.from_dict({"limits": [{"quantity": "adev", "unit": "deg/s", "max": 1}]})
    with pytest.raises(InputError, match=r"unknown field\(s\) \['maxx'\]"):
        Datasheet.from_dict({"limits": [{"quantity": "N", "unit": "deg/s", "maxx": 1}]})


def test_check_statuses_and_unit_conversion() -> None:
    sheet = Datasheet.from_dict(
        {
            "limits": [
                {"quantity": "N", "max": 0.5, "unit": "deg/sqrt(h)"},
                {"quantity": "B", "max": 10.0, "unit": "deg/h"},
                {"quantity": "K", "max": 1.0, "unit": "deg/h/sqrt(h)"},
                {"quantity": "R", "max": 1.0, "unit": "deg/h^2"},
                {"quantity": "adev", "tau": 2.0, "min": 0.5, "unit": "deg/h"},
            ]
        }
    )
    coefficients = {
        # N = 0.005 deg/sqrt(s) = 0.3 deg/sqrt(h), interval 0.27 ... 0.33 -> pass
        "N": Measured(0.005, 0.0045, 0.0055, "deg/sqrt(s)"),
        # B = 9 deg/h, interval up to 11 -> marginal
        "B": Measured(9.0 / 3600, 8.0 / 3600, 11.0 / 3600, "deg/s"),
        # K = 2 deg/h/sqrt(h) -> fail
        "K": Measured(2.0, 1.5, 2.5, "deg/h/sqrt(h)"),
    }
    tau = np.array([1.0, 4.0])
    dev = np.array([1e-3, 1e-4])  # deg/s; at tau = 2 (log-log): 10^-3.5 deg/s = 1.138 deg/h
    checks = check_limits(sheet, "gx", coefficients, (tau, dev, dev * 0.9, dev * 1.1, "deg/s"))
    assert [c.status for c in checks] == ["pass", "marginal", "fail", "missing", "pass"]
    assert checks[0].value == pytest.approx(0.3)
    assert checks[4].value == pytest.approx(10**-3.5 * 3600)


def test_slope_table_of_exact_power_laws() -> None:
    tau = np.geomspace(0.01, 1e7, 80)
    # sum of asymptotes: ARW N = 1e-3 dominates below ~2 s, the bias-instability plateau
    # 0.664 B (B = 1e-3) up to ~1e4 s, rate random walk K = 1e-5 above
    dev = np.sqrt((1e-3) ** 2 / tau + (0.664 * 1e-3) ** 2 + (1e-5) ** 2 * tau / 3)
    rows = slope_table(tau, dev)
    assert [r.symbol for r in rows] == ["N", "B", "K"]
    assert rows[0].tau_min == tau[0]
    assert rows[-1].tau_max == tau[-1]
    assert rows[0].slope == pytest.approx(-0.5, abs=0.1)


def test_customary_units_and_coefficients() -> None:
    from allanite.model import NoiseModel
    from allanite.terms import TERM_TYPES

    assert customary_rate("deg/s") == "deg/h"
    assert customary_rate("rad/s") == "deg/h"  # ROS/PX4 gyros read like datasheets
    assert customary_rate("dph") == "deg/h"
    assert customary_rate("arcsec/s") == "deg/h"  # ring-laser increments: datasheet units
    assert customary_rate("furlong/s") is None
    assert customary_rate(None) is None
    white = TERM_TYPES["white"](N=0.01)
    rows = coefficient_table(NoiseModel(terms=(white,), units={"rate": "deg/s", "time": "s"}), None)
    assert len(rows) == 1
    assert rows[0].unit == "deg/sqrt(h)"
    assert rows[0].value == pytest.approx(0.6)  # 0.01 deg/sqrt(s) * 60
    assert rows[0].slope == "−1/2"


def test_report_is_self_contained_and_complete() -> None:
    reference = _device(RNG.normal(size=(N, 2)) * 0.3, name="ref.npy")
    report = build_report(
        [_device()], reference=reference, datasheet=Datasheet.from_dict(SHEET), title="Test"
    )
    html = report.html
    assert html.startswith("<!DOCTYPE html>")
    for forbidden in ("http://", "https://", "<script", "<link", "@import", "url("):
        assert forbidden not in html, forbidden
    images = re.findall(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    assert len(images) == 1
    for section in (
        "Record summary",
        "Allan deviation",
        "Noise coefficients",
        "Slope table",
        "Datasheet comparison",
        "Comparison with the reference device",
    ):
        assert f"<h2>{section}</h2>" in html
    # white noise 0.5 deg/s at 100 Hz: adev(1 s) = 0.05 deg/s -> the 0.2 limit passes and the
    # 180 deg/h = 0.05 deg/s limit is decided by the interval (marginal or fail), N is missing
    statuses = [c.status for c in report.checks]
    assert statuses[0::3] == ["pass", "pass"]
    assert set(statuses[1::3]) <= {"marginal", "fail"}
    assert statuses[2::3] == ["missing", "missing"]
    assert "ref.npy" in html


def test_cli_report_exit_codes_and_exports(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "dut.npy"
    np.save(data, SAMPLES)
    passing = tmp_path / "pass.json"
    passing.write_text(json.dumps({"device": "loose", "limits": [SHEET["limits"][0]]}))
    failing = tmp_path / "fail.json"
    failing.write_text(
        json.dumps(
            {
                "device": "tight",
                "limits": [{"quantity": "adev", "tau": 1.0, "max": 0.001, "unit": "deg/s"}],
            }
        )
    )
    common = [str(data), "--fs", "100", "--units", "deg/s", "--points", "20", "--no-fit"]
    out = tmp_path / "ok.html"
    assert (
        main(
            [
                "report",
                *common,
                "--datasheet",
                str(passing),
                "-o",
                str(out),
                "--png",
                "--pdf",
                "--json",
            ]
        )
        == 0
    )
    verdict = json.loads(capsys.readouterr().out)
    assert verdict["passed"] is True
    assert out.read_text().count("<h2>") >= 5
    assert (tmp_path / "ok-adev.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "ok-adev.pdf").read_bytes()[:4] == b"%PDF"
    assert verdict["figures"] == [str(tmp_path / "ok-adev.png"), str(tmp_path / "ok-adev.pdf")]
    bad = tmp_path / "bad.html"
    assert main(["report", *common, "--datasheet", str(failing), "-o", str(bad)]) == 1
    assert "datasheet tight: FAIL" in capsys.readouterr().out
    assert bad.exists()
    # bad input: nothing written, one line, exit 2
    broken = tmp_path / "broken.json"
    broken.write_text("{")
    never = tmp_path / "never.html"
    assert main(["report", *common, "--datasheet", str(broken), "-o", str(never)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "broken.json" in err[0]
    assert not never.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".never")]


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def test_report_renders_in_headless_chromium(tmp_path: Path) -> None:
    browser = _chromium()
    if browser is None:
        pytest.skip("Chromium is not installed (CI installs it: apt-get install chromium)")
    image = pytest.importorskip("PIL.Image")
    report = build_report([_device()], datasheet=Datasheet.from_dict(SHEET))
    page = tmp_path / "report.html"
    report.write(page)
    shot = tmp_path / "shot.png"
    proc = subprocess.run(
        [
            browser,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--window-size=1200,2600",
            f"--screenshot={shot}",
            page.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=90,
        check=False,
    )
    assert shot.exists(), proc.stderr[-2000:]
    pixels = np.asarray(image.open(shot).convert("RGB")).astype(int)

    def count(rgb: tuple[int, int, int], tol: int = 12) -> int:
        return int(np.all(np.abs(pixels - np.array(rgb)) <= tol, axis=-1).sum())

    # the plot: matplotlib's first two curve colours (blue #1f77b4, orange #ff7f0e)
    assert count((0x1F, 0x77, 0xB4)) > 500
    assert count((0xFF, 0x7F, 0x0E)) > 500
    # the tables: header cells (#e8eef5) and the pass badge (#2e8b57)
    assert count((0xE8, 0xEE, 0xF5), tol=3) > 5000
    assert count((0x2E, 0x8B, 0x57), tol=6) > 200
    # the page is not blank: the main column is white, the margins grey (#f4f6f8)
    assert count((0xF4, 0xF6, 0xF8), tol=2) > 10000


def test_cli_report_with_sim_model_has_diagnosis(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("allanite.diagnosis")
    from allanite.model import NoiseModel
    from allanite.terms import TERM_TYPES

    rate = RNG.normal(size=4000) * 0.5  # white rate noise: N = 0.5 / sqrt(100) deg/sqrt(s)
    rate[2000:] += 0.3  # a bias step the model does not have
    data = tmp_path / "real.npy"
    np.save(data, rate)
    model = tmp_path / "model.json"
    white = TERM_TYPES["white"](N=0.05)
    model.write_text(NoiseModel(terms=(white,), units={"rate": "deg/s", "time": "s"}).to_json())
    out = tmp_path / "diag.html"
    code = main(
        [
            "report",
            str(data),
            "--fs",
            "100",
            "--units",
            "deg/s",
            "--points",
            "20",
            "--no-fit",
            "--sim-model",
            str(model),
            "--n-mc",
            "20",
            "-o",
            str(out),
        ]
    )
    assert code == 0, capsys.readouterr().err
    html = out.read_text()
    assert "<h2>Sim-to-real diagnosis</h2>" in html
    assert "model.json" in html
    # the step is a significant gap: the verdict badge says so and the views are embedded
    assert "differs significantly" in html
    assert len(re.findall(r'<img src="data:image/png;base64,', html)) == 2


def test_report_with_models_shows_coefficients_and_reference_ratios() -> None:
    from allanite.model import NoiseModel
    from allanite.terms import TERM_TYPES

    units = {"rate": "deg/s", "time": "s"}
    mine = NoiseModel(terms=(TERM_TYPES["white"](N=0.05),), units=units)
    theirs = NoiseModel(terms=(TERM_TYPES["white"](N=0.025),), units=units)
    device = _device()
    device = DeviceAnalysis(device.record, device.result, (mine, mine))
    reference = _device(RNG.normal(size=(N, 2)) * 0.25, name="ref.npy")
    reference = DeviceAnalysis(reference.record, reference.result, (theirs, theirs))
    sheet = Datasheet.from_dict({"limits": [{"quantity": "N", "max": 2.5, "unit": "deg/sqrt(h)"}]})
    report = build_report([device], reference=reference, datasheet=sheet)
    html = report.html
    # N = 0.05 deg/sqrt(s) = 3 deg/sqrt(h): shown in customary units, fails the 2.5 limit
    assert "deg/sqrt(h)" in html
    assert [c.status for c in report.checks] == ["fail", "fail"]
    assert report.checks[0].value == pytest.approx(3.0)
    assert report.passed is False
    # the reference comparison lists the coefficient ratio 0.05 / 0.025 = 2
    assert re.search(r"<td>3</td><td>1\.5</td><td>deg/sqrt\(h\)</td><td>2</td>", html)
    # one Allan plot plus one model plot per channel
    assert len(re.findall(r'<img src="data:image/png;base64,', html)) == 3
    assert set(report.figures) == {"adev", "fit-0", "fit-1"}


def test_compact_batch_datasheet_in_record_units() -> None:
    from allanite.model import NoiseModel
    from allanite.terms import TERM_TYPES

    model = NoiseModel(terms=(TERM_TYPES["white"](N=0.05),), units={"rate": "deg/s", "time": "s"})
    device = _device()
    device = DeviceAnalysis(device.record, device.result, (model, model))
    # N in the record's own unit deg/s*sqrt(s): 0.05 fails a 0.04 limit and passes 0.06
    sheet = Datasheet.from_dict({"device": "lot 7", "N": 0.04, "B": {"min": 0.0, "max": 1.0}})
    statuses = [c.status for c in build_report([device], datasheet=sheet).checks]
    assert statuses == ["fail", "missing", "fail", "missing"]
    sheet = Datasheet.from_dict({"N": {"max": 0.06}})
    report = build_report([device], datasheet=sheet)
    assert [c.status for c in report.checks] == ["pass", "pass"]
    assert report.checks[0].value == pytest.approx(0.05)
    assert "≤ 0.06 (record units)" in report.html
    with pytest.raises(InputError, match=r"entry 'N' must be a number"):
        Datasheet.from_dict({"N": "small"})


def test_several_records_are_overlaid_and_summarised() -> None:
    first = _device(name="unit_a.npy")
    second = _device(RNG.normal(size=(N, 2)) * 0.2, name="unit_b.npy")
    report = build_report([first, second])
    legend = [t.get_text() for t in report.figures["adev"].axes[0].get_legend().get_texts()]
    assert legend == ["unit_a.npy: gx", "unit_a.npy: gy", "unit_b.npy: gx", "unit_b.npy: gy"]
    assert "<h3>unit_a.npy</h3>" in report.html
    assert "<h3>unit_b.npy</h3>" in report.html
    assert report.html.count("<h3>unit_b.npy — gy</h3>") == 1  # its slope table


def test_goodness_of_fit_is_reported_and_misfits_are_flagged() -> None:
    fit_module = pytest.importorskip("allanite.fit")
    rate = RNG.normal(size=20_000) * 0.5
    result = allanite.avar(rate, fs=FS, points=40, units="deg/s")
    record = Record(samples=rate, fs=FS, units="deg/s", channels=("gx",), source="w.npy")
    good = fit_module.fit(result, terms=["white"])
    bad = fit_module.fit(result, terms=["rrw"])  # white noise fitted as rate random walk
    html_good = build_report([DeviceAnalysis(record, result, (good,))]).html
    html_bad = build_report([DeviceAnalysis(record, result, (bad,))]).html
    assert f"for {good.dof} degrees of freedom" in html_good
    assert "REJECTED" not in html_good
    assert "Model not rejected" in html_good
    assert good.p_value >= 0.001
    assert bad.p_value < 0.001
    assert "Model REJECTED" in html_bad
    assert 'class="rejected"' in html_bad


def test_slope_table_says_why_a_bias_instability_band_is_not_in_the_model() -> None:
    # white + random walk only: the bottom of the curve has slope ~0 over a few points, but the
    # fitted model has no B term; the table must say so next to that band
    model = NoiseModel((White(N=0.5 / np.sqrt(FS)), RateRandomWalk(K=0.002 * np.sqrt(FS))),
                       {"rate": "deg/s", "time": "s"})  # fmt: skip
    samples = model.simulate(200_000, fs=FS, n_channels=1, seed=4)
    record = Record(samples=samples, fs=FS, units="deg/s", channels=("gx",), source="dut.npy")
    result = allanite.avar(samples, fs=FS, units="deg/s")
    bands = slope_table(result.tau, result.dev, result.edf)
    assert any(r.symbol == "B" for r in bands)  # the flat bottom is there
    fit = allanite.fit(result)
    assert "B" not in {t.symbol for t in fit.model.terms}
    html = build_report([DeviceAnalysis(record, result, (fit,))]).html
    assert "in the fitted model" in html
    assert "so its selection found no B term" in html
    # without a fit the column is not shown
    assert "in the fitted model" not in build_report([DeviceAnalysis(record, result)]).html


def test_every_check_status_has_a_coloured_badge() -> None:
    import re

    from allanite.datasheet import STATUSES, status_text
    from allanite.report import html as h

    colours = dict(re.findall(r"\.(\w+) \{ background: (#[0-9a-f]{6}); \}", h.STYLE))
    for status in STATUSES:
        assert status in colours, f"no badge colour for {status!r}"
        assert f'class="badge {status}">{status_text(status)}<' in h.badge(status)
    assert len({colours[s] for s in STATUSES}) == len(STATUSES)  # each its own colour
    assert ">NOT DETERMINED<" in h.badge("undetermined")  # as the CLI prints it


def test_first_screen_has_coefficients_and_means(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 30 item 10: the coefficients come right after the record summary (before the
    plot), and the summary shows each channel's mean and, for an accelerometer triad, the
    magnitude of the mean (1 g at rest)."""
    rng = np.random.default_rng(10)
    triad = np.array([0.12, -0.25, 9.79]) + 0.02 * rng.standard_normal((40_000, 3))
    path = tmp_path / "acc.npy"
    np.save(path, triad)
    html_path = tmp_path / "r.html"
    code = main(["report", str(path), "--fs", "100", "--units", "m/s^2", "-o", str(html_path)])
    capsys.readouterr()
    assert code == 0
    html = html_path.read_text()
    assert html.index('id="coefficients"') < html.index('id="adev"')
    assert html.index('id="summary"') < html.index('id="coefficients"')
    row = re.search(r"mean \(static bias; gravity on an accelerometer\)</td><td[^>]*>([^<]*)", html)
    assert row is not None
    text = row.group(1)
    means = triad.mean(axis=0)
    assert f"col2 {means[2]:.6g} m/s^2" in text
    assert f"magnitude {np.linalg.norm(means):.6g} m/s^2" in text
