"""Plausibility checks: mistaken inputs are said out loud (stderr, JSON, report), never silent."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter

import allanite
from allanite.cli import main
from allanite.model import NoiseModel
from allanite.plausibility import (
    check_allan,
    check_coefficients,
    check_samples,
    refuse_constant,
    stuck_segments,
)
from allanite.terms import Flicker, GaussMarkov, Quantization, RateRandomWalk, White
from fit_generator import simulate

FS = 100.0


def _random_model(rng: np.random.Generator) -> NoiseModel:
    """A gyro nobody picked: white noise plus, at random, flicker, RRW, quantization, GM."""
    n = 10 ** rng.uniform(-4, -2)
    terms: list = [White(n)]
    if rng.random() < 0.7:
        terms.append(Flicker(n * 10 ** rng.uniform(-1.5, 0.5)))
    if rng.random() < 0.5:
        terms.append(RateRandomWalk(n * 10 ** rng.uniform(-3, -0.5)))
    if rng.random() < 0.4:
        terms.append(Quantization(n * 10 ** rng.uniform(-2, 0.3)))
    if rng.random() < 0.3:
        terms.append(GaussMarkov(n * 10 ** rng.uniform(0, 1.5), 10 ** rng.uniform(0, 2)))
    return NoiseModel(terms)


def _gyro(seed: int, n: int = 60_000) -> np.ndarray:
    rng = np.random.default_rng(seed)
    bias = rng.uniform(-1, 1) * 10 ** rng.uniform(-3, 0)
    return simulate(_random_model(rng), n, 1 / FS, seed=seed)[:, 0] + bias


def _codes(findings: list) -> set[str]:
    return {f.code for f in findings}


def test_default_path_on_generated_gyros_no_false_alarm_and_wrong_input_caught() -> None:
    """30 random gyros: read correctly, nothing is flagged; read as the other kind, 28 of 30
    are flagged as angle-given-as-rate and 25 of 30 as rate-given-as-angle (measured with these
    seeds). The misses of the second check have a long-tau end flatter than -0.7 (the rate's
    own flicker or random walk, differenced), which a real angle record dominated by
    quantization also shows: there the check stays silent rather than cry wolf."""
    caught = {"angle_as_rate": 0, "rate_as_angle": 0}
    seeds = range(30)
    for seed in seeds:
        rate = _gyro(seed)
        angle = np.cumsum(rate) / FS
        right = allanite.avar(rate, fs=FS), allanite.avar(angle, fs=FS, input="angle")
        for res, x in zip(right, (rate, angle), strict=True):
            dev0 = np.atleast_1d(res.dev[0])
            found = check_allan(res) + check_samples(x, fs=FS, input=res.input, short_dev=dev0)
            assert found == [], (seed, [f.message for f in found])
        caught["angle_as_rate"] += "angle_as_rate" in _codes(
            check_allan(allanite.avar(angle, fs=FS))
        )
        wrong = allanite.avar(rate, fs=FS, input="angle")
        caught["rate_as_angle"] += "rate_as_angle" in _codes(check_allan(wrong))
    assert caught["angle_as_rate"] >= 27, caught
    assert caught["rate_as_angle"] >= 24, caught


def test_pure_cases_are_named_with_their_slope() -> None:
    rng = np.random.default_rng(1)
    w = rng.standard_normal(100_000) * 0.01
    angle_as_rate = check_allan(allanite.avar(np.cumsum(w + 0.004) / FS, fs=FS), ["gx"])
    assert [f.code for f in angle_as_rate] == ["angle_as_rate"]
    assert "channel gx: the Allan deviation rises (as tau^+0.9" in angle_as_rate[0].message
    assert "give --input angle" in angle_as_rate[0].message
    rate_as_angle = check_allan(allanite.avar(w, fs=FS, input="angle"))
    assert [f.code for f in rate_as_angle] == ["rate_as_angle"]
    assert "falls as tau^-1.0" in rate_as_angle[0].message
    assert "give --input rate" in rate_as_angle[0].message
    # the modified deviation has other slopes: not judged
    assert check_allan(allanite.avar(w, fs=FS, input="angle", kind="modified")) == []


def test_counts_without_scale() -> None:
    rng = np.random.default_rng(2)
    counts = np.round(rng.standard_normal(50_000) * 3 + 5000).astype(np.int16)
    dev0 = np.atleast_1d(allanite.avar(counts, fs=FS).dev[0])
    found = check_samples(counts, fs=FS, short_dev=dev0)
    assert [f.code for f in found] == ["counts_without_scale"]
    assert "raw counts without a scale factor? give the units per count (--scale)" in str(found[0])
    assert check_samples(counts, fs=FS, short_dev=dev0, scale=0.01) == []
    assert check_samples(counts - 5000, fs=FS, short_dev=dev0) == []  # centred: plausible
    floats = counts + rng.uniform(-0.5, 0.5, counts.size)  # not whole numbers
    assert check_samples(floats, fs=FS, short_dev=dev0) == []


@pytest.mark.parametrize("seed", range(8))
def test_stuck_segments_no_false_alarm_on_quantized_and_correlated_records(seed: int) -> None:
    """Quantized white noise (sigma 0.05 to 2 LSB), a quantized Gauss-Markov process and a
    quantized resting angle repeat values naturally: none of it is reported as stuck."""
    rng = np.random.default_rng(seed)
    n = 100_000
    for sigma in (0.05, 0.2, 0.3, 0.5, 1.0, 2.0):
        white = np.round(rng.standard_normal(n) * sigma)
        phi = 0.99
        gm = np.round(
            lfilter([1], [1, -phi], rng.standard_normal(n) * sigma * math.sqrt(1 - phi**2))
        )
        angle = np.round(np.cumsum(rng.standard_normal(n) * sigma * 0.1))
        for x in (white, gm, angle, rng.standard_normal(n) * sigma):
            assert stuck_segments(x) == [], sigma


@pytest.mark.parametrize(("sigma", "length"), [(None, 20), (None, 500), (1.0, 300), (0.3, 2000)])
def test_stuck_segments_found_where_they_are(sigma: float | None, length: int) -> None:
    rng = np.random.default_rng(7)
    x = rng.standard_normal(100_000)
    if sigma is not None:
        x = np.round(x * sigma)
    x[40_000 : 40_000 + length] = x[40_000]
    (found,) = stuck_segments(x)
    # the run may extend by the neighbours that happen to equal the stuck value
    assert found[0] <= 40_000 < 40_000 + length <= found[1]
    assert found[1] - found[0] < length + 50


def test_constant_channel_is_refused_by_name() -> None:
    x = np.column_stack([np.random.default_rng(0).standard_normal(100), np.full(100, 7.0)])
    with pytest.raises(ValueError, match=r"rec.npy: channel gy \(all 100 samples equal 7\) is "):
        refuse_constant(x, ["gx", "gy"], source="rec.npy")
    refuse_constant(x[:, :1], ["gx"])


def _cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("command", ["analyze", "fit", "report", "diagnose"])
def test_constant_record_refused_by_every_command(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "dead.npy"
    np.save(path, np.full(5000, 0.25))
    extra = {
        "report": ["-o", str(tmp_path / "r.html")],
        "diagnose": ["--sim-model", str(tmp_path / "model.json")],
    }.get(command, [])
    inputs = ["dead.npy"]
    if command == "diagnose":  # the config is read first (issue 30 item 2): a valid one
        from allanite.examples import example_model

        example_model().save(tmp_path / "model.json")
        inputs.append("model.json")
    code, out, err = _cli([command, str(path), "--fs", "100", *extra], capsys)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1
    assert "dead.npy: channel col0 (all 5000 samples equal 0.25) is constant" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == inputs  # nothing written


def test_warnings_reach_stderr_json_and_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(4)
    x = rng.standard_normal(60_000) * 0.01
    x[20_000:23_000] = x[20_000]
    path = tmp_path / "stuck.npy"
    np.save(path, x)
    code, out, err = _cli(["analyze", str(path), "--fs", "100", "--json"], capsys)
    assert code == 0
    assert "allanite analyze: warning: channel col0: stuck at" in err
    assert "for 3000 samples (30 s) from t = 200 s" in err
    warnings = json.loads(out)["record"]["warnings"]
    assert len(warnings) == 1
    assert "from t = 200 s" in warnings[0]
    # text mode: on stderr, not mixed into the summary
    code, out, err = _cli(["analyze", str(path), "--fs", "100"], capsys)
    assert "stuck at" in err
    assert "stuck at" not in out
    html = tmp_path / "r.html"
    code, out, err = _cli(["report", str(path), "--fs", "100", "-o", str(html), "--no-fit"], capsys)
    assert code == 0
    assert "stuck at" in err
    assert "for 3000 samples (30 s) from t = 200 s" in html.read_text()
    code, out, err = _cli(["fit", str(path), "--fs", "100", "--json"], capsys)
    assert "stuck at" in err
    assert "from t = 200 s" in json.loads(out)["record"]["warnings"][0]


def test_angle_read_as_rate_warns_in_the_cli(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    w = np.random.default_rng(5).standard_normal(60_000) * 0.01
    path = tmp_path / "angle.npy"
    np.save(path, np.cumsum(w + 0.01) / FS)
    code, _, err = _cli(["analyze", str(path), "--fs", "100", "--summary"], capsys)
    assert code == 0
    assert "angle given as rate? if the samples are angles, give --input angle" in err
    code, _out, err = _cli(["analyze", str(path), "--fs", "100", "--input", "angle"], capsys)
    assert code == 0
    assert err == ""


def test_runs_are_the_same_whatever_the_chunk() -> None:
    from allanite.plausibility import _runs

    rng = np.random.default_rng(9)
    for _ in range(100):
        n = int(rng.integers(1, 400))
        v = np.round(rng.standard_normal(n) * rng.uniform(0.05, 2))
        change = np.flatnonzero(v[1:] != v[:-1]) + 1
        starts = np.concatenate(([0], change))
        expected = list(zip(starts, np.diff(np.concatenate((starts, [n]))), strict=True))
        for chunk in (1, 2, 7, 64, 1000):
            got = [
                (a, k) for s, lengths in _runs(v, chunk) for a, k in zip(s, lengths, strict=True)
            ]
            assert got == expected


def test_stuck_search_memory_does_not_grow_with_the_record() -> None:
    """One streaming pass: the working memory is a few chunks, not several record copies."""
    import tracemalloc

    x = np.random.default_rng(3).standard_normal(4_000_000)  # 32 MB
    x[1_000_000:1_000_100] = x[1_000_000]
    tracemalloc.start()
    try:
        found = stuck_segments(x)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert found == [(1_000_000, 1_000_100)]
    assert peak < 20e6, peak  # one copy of the change indices alone would be 32 MB


def test_units_that_contradict_channel_names_are_warned(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Three units for six channels: gz lands in m/s^2 and ax in g; the names say otherwise."""
    rng = np.random.default_rng(4)
    x = rng.standard_normal((20_000, 6)) * 0.01
    path = tmp_path / "imu.csv"
    np.savetxt(path, x, delimiter=",", header="gx,gy,gz,ax,ay,az", comments="")
    argv = ["fit", str(path), "--fs", "100", "--channels", "gx,gy,gz,ax,ay,az"]
    code, _, err = _cli([*argv, "--units", "deg/s,m/s^2,g"], capsys)
    assert code == 0
    assert "channel gz is named like a gyro but its unit m/s^2 is for an accelerometer" in err
    assert "channel gx" not in err
    code, _, err = _cli([*argv, "--units", "deg/s,m/s^2"], capsys)
    assert code == 0
    assert "named like" not in err


# --- wrong --units: coefficients outside any real sensor's range (check_coefficients) --------


def test_coefficients_in_every_sensor_class_and_unit_are_not_flagged() -> None:
    """N from strategic grade to consumer MEMS, B ten times N in deg/h, in deg/s, rad/s, deg/h
    and as an angle record: nothing is flagged."""
    from allanite.units import convert

    for n_dph in (1e-4, 1e-3, 0.01, 0.1, 1.0, 10.0):
        for unit, kind in (
            ("deg/s", "rate"),
            ("rad/s", "rate"),
            ("deg/h", "rate"),
            ("rad", "angle"),
        ):
            rate = unit if kind == "rate" else "rad/s"
            values = {
                "N": convert(n_dph, "deg/sqrt(h)", f"{rate}*sqrt(s)"),
                "B": convert(10 * n_dph, "deg/h", rate),
                "K": None,
            }
            assert check_coefficients(values, unit, input=kind) == [], (n_dph, unit)
    # an accelerometer: 0.01 ... 1 m/s/sqrt(h), 10 ... 1000 ug, in m/s^2, g and mg
    for vrw in (1e-3, 0.01, 0.1, 1.0):
        for unit in ("m/s^2", "g", "mg"):
            values = {
                "N": convert(vrw, "m/s/sqrt(h)", f"{unit}*sqrt(s)"),
                "B": convert(1000 * vrw, "ug", unit),
            }
            assert check_coefficients(values, unit) == [], (vrw, unit)
    assert check_coefficients({"N": 1e6}, None) == []  # no unit: nothing to judge


def test_implausible_coefficients_name_the_likely_unit() -> None:
    from allanite.units import convert

    # a navigation gyro (N 0.003 deg/sqrt(h)) recorded in deg/h and declared deg/s reads
    # N = 10.8 deg/sqrt(h), a bad but real MEMS value: no check on magnitudes can tell
    n = convert(0.003, "deg/sqrt(h)", "deg/h*sqrt(s)")  # the numbers, read as deg/s*sqrt(s)
    assert check_coefficients({"N": n}, "deg/s") == []
    # a consumer gyro (0.3 deg/sqrt(h)) the same way reads 1080: flagged, deg/h named
    n = convert(0.3, "deg/sqrt(h)", "deg/h*sqrt(s)")
    (finding,) = check_coefficients({"N": n}, "deg/s", channel="gz")
    assert finding.code == "implausible_units"
    assert finding.channel == "gz"
    assert "channel gz: N = 1080 deg/sqrt(h) is outside any real gyro's range" in (finding.message)
    # deg/h, rad/h and mrad/s would all make it plausible: listed, none proposed (issue 30
    # item 12: a proposal can be worse than the input)
    assert "deg/h given as deg/s: N would be 0.3 deg/sqrt(h); or rad/h given as" in (
        finding.message
    )
    assert "no unit is proposed" in finding.message
    assert "pass --units deg/h" not in finding.message
    # too small: a 0.01 deg/sqrt(h) gyro's deg/s numbers declared as mrad/h
    n = convert(0.01, "deg/sqrt(h)", "deg/s*sqrt(s)")
    (finding,) = check_coefficients({"N": n}, "mrad/h")
    assert "(N 1e-05 to 100 deg/sqrt(h))" in finding.message
    assert "deg/s given as mrad/h: N would be 0.01 deg/sqrt(h)" in finding.message
    # bias instability alone out of range (1e6 deg/h): flagged with its bound
    (finding,) = check_coefficients({"B": convert(1e6, "deg/h", "deg/s")}, "deg/s")
    assert "B = 1e+06 deg/h is outside" in finding.message
    assert "B <= 100000 deg/h" in (finding.message)
    # an accelerometer's ug numbers declared m/s^2 (VRW 0.05 m/s/sqrt(h))
    n = convert(0.05, "m/s/sqrt(h)", "ug*sqrt(s)")
    (finding,) = check_coefficients({"N": n}, "m/s^2")
    assert "real accelerometer's range" in finding.message
    assert "ug given as m/s^2: N would be 0.05 m/s/sqrt(h); if so, pass --units ug" in (
        finding.message
    )  # the one unit that restores the range: proposed
    # an angle record: the suggestion is an angle unit
    n = convert(0.3, "deg/sqrt(h)", "arcsec/s*sqrt(s)")
    (finding,) = check_coefficients({"N": n}, "deg", input="angle")
    assert "arcsec given as deg: N would be 0.3 deg/sqrt(h); or mrad given as deg" in (
        finding.message
    )


def test_wrong_units_warned_by_fit_and_analyze(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The reviewers' case: a deg/h record fitted with --units deg/s gave N = 1321 deg/sqrt(h),
    exit 0, no warning. Now fit and analyze name the mix-up; the right unit is silent."""
    from allanite.examples import example_model

    rate = example_model().simulate(60_000, fs=FS, seed=102).ravel() * 3600.0  # deg/h
    path = tmp_path / "dph.npy"
    np.save(path, rate)
    code, out, err = _cli(["fit", str(path), "--fs", "100", "--units", "deg/s", "--json"], capsys)
    assert code == 0
    channel = json.loads(out)["channels"][0]
    n = next(c["value"] for c in channel["coefficients"] if c["symbol"] == "N")
    assert n > 100.0  # deg/sqrt(h): the fit itself is unchanged
    (warning,) = channel["warnings"]
    assert f"N = {n:.4g} deg/sqrt(h) is outside any real gyro's range" in warning
    assert f"deg/h given as deg/s: N would be {n / 3600:.3g} deg/sqrt(h)" in warning
    assert "no unit is proposed: pass the unit the logger writes with --units" in warning
    assert err.count("warning:") == 1
    assert warning in err
    code, out, err = _cli(["fit", str(path), "--fs", "100", "--units", "deg/h"], capsys)
    assert code == 0
    assert "outside any real" not in err
    code, out, err = _cli(["analyze", str(path), "--fs", "100", "--units", "deg/s"], capsys)
    assert code == 0
    assert "deg/h given as deg/s" in err
    code, out, err = _cli(["analyze", str(path), "--fs", "100", "--units", "deg/h"], capsys)
    assert "outside any real" not in err
    # the README's example: no warning
    code, out, err = _cli(["fit", "--example"], capsys)
    assert code == 0
    assert "warning" not in err


def test_the_library_fit_runs_the_same_wrong_units_check() -> None:
    """allanite.fit() warns where `allanite fit` does, with the fix spelled as a keyword;
    the right unit is silent, and the CLI does not print the finding twice (above)."""
    import warnings

    from allanite.errors import ImplausibleInputWarning
    from allanite.examples import example_model

    rate = example_model().simulate(60_000, fs=FS, seed=102).ravel() * 3600.0  # deg/h
    with pytest.warns(ImplausibleInputWarning) as caught:
        fitted = allanite.fit(rate, fs=FS, units="deg/s")
    (warning,) = [w for w in caught if issubclass(w.category, ImplausibleInputWarning)]
    message = str(warning.message)
    (expected,) = check_coefficients(fitted.model.coefficients(), "deg/s", spelling="python")
    assert message == expected.message
    assert "deg/h given as deg/s" in message
    assert "pass the unit the logger writes with units= (CLI: --units)" in message
    assert warning.filename == __file__  # points at the caller's line
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleInputWarning)
        allanite.fit(rate, fs=FS, units="deg/h")
        allanite.fit(allanite.avar(rate, fs=FS, units="deg/h", taus="octave"))


def test_batch_warns_about_wrong_units_as_the_cli_speaks(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`allanite batch` reaches the check through the library fit: one line in the CLI's own
    form (the channel named as in the table, --units), not a Python warning."""
    from allanite.examples import example_model

    rate = example_model().simulate(60_000, fs=FS, seed=102).ravel() * 3600.0  # deg/h
    path = tmp_path / "dph.npy"
    np.save(path, rate)
    code, _out, err = _cli(["batch", str(path), "--fs", "100", "--units", "deg/s"], capsys)
    assert code == 0
    (line,) = err.strip().splitlines()
    assert line.startswith("allanite batch: warning: channel col0: N = ")
    assert line.endswith("pass the unit the logger writes with --units")
    assert "ImplausibleInputWarning" not in err
    code, _out, err = _cli(["batch", str(path), "--fs", "100", "--units", "deg/h"], capsys)
    assert "warning" not in err


# --- issue 30 item 12: wrong units read from the record's mean and noise floor -------------


def _write(tmp_path: Path, name: str, samples: np.ndarray) -> str:
    path = tmp_path / name
    np.save(path, samples)
    return str(path)


def test_still_gyro_reading_36_rad_s_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A still gyro's mean of 36 rad/s (2063 deg/s; Earth rate is 7.3e-5 rad/s) is beyond any
    gyro's bias: named, with the bound; a 0.01 rad/s bias is silent."""
    rng = np.random.default_rng(30)
    noise = 0.002 * rng.standard_normal(40_000)
    path = _write(tmp_path, "spin.npy", 36.0 + noise)
    code, _out, err = _cli(["analyze", path, "--fs", "100", "--units", "rad/s"], capsys)
    assert code == 0
    assert "the mean, 2063 deg/s, is beyond any still gyro's bias (|mean| <= 30 deg/s" in err
    assert "pass --units" not in err  # mrad/s, deg/h, rad/h all fit: no unit is proposed
    path = _write(tmp_path, "still.npy", 0.01 + noise)
    code, _out, err = _cli(["analyze", path, "--fs", "100", "--units", "rad/s"], capsys)
    assert code == 0
    assert "warning" not in err


def test_rad_s_given_as_deg_h_is_named_without_a_fitted_n() -> None:
    """A phone gyro's rad/s numbers (0.003 rad/s at 200 Hz) labelled deg/h: the deviation at
    the shortest tau alone bounds N below any real gyro's, with no N read off the curve."""
    sigma, tau0 = 0.003, 1 / 200
    (finding,) = check_coefficients({}, "deg/h", n_ceiling=sigma * math.sqrt(tau0))
    assert "bounds N to <= 3.54e-06 deg/sqrt(h), quieter than any real gyro" in finding.message
    assert "rad/s given as deg/h" in finding.message
    # the same numbers as rad/s are fine
    assert check_coefficients({}, "rad/s", n_ceiling=sigma * math.sqrt(tau0)) == []


def test_rad_s_given_as_deg_h_warned_by_analyze(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """End to end: the phone gyro's numbers as deg/h are named by analyze."""
    rng = np.random.default_rng(31)
    rate = 0.003 * rng.standard_normal(60_000) + 0.001
    path = _write(tmp_path, "phone.npy", rate)
    code, _out, err = _cli(["analyze", path, "--fs", "200", "--units", "deg/h"], capsys)
    assert code == 0
    assert "quieter than any real gyro" in err
    code, _out, err = _cli(["analyze", path, "--fs", "200", "--units", "rad/s"], capsys)
    assert "warning" not in err


def _triad(mean: tuple[float, float, float], sigma: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.asarray(mean) + sigma * rng.standard_normal((40_000, 3))


def test_accelerometer_triad_in_m_s2_given_as_g_and_back(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A still triad reads 1 g: magnitude 9.8 labelled g is m/s^2 given as g, magnitude 1
    labelled m/s^2 is g given as m/s^2; each names the one unit that restores 1 g."""
    ms2 = _triad((0.12, -0.25, 9.79), 0.02, 32)
    path = _write(tmp_path, "acc_ms2.npy", ms2)
    code, _out, err = _cli(["analyze", path, "--fs", "100", "--units", "g"], capsys)
    assert code == 0
    assert "the magnitude of the mean is 9.794 g, not the 1 g of gravity" in err
    assert "m/s^2 given as g: the magnitude would be 0.9987 g; if so, pass --units m/s^2" in err
    code, _out, err = _cli(["analyze", path, "--fs", "100", "--units", "m/s^2"], capsys)
    assert "warning" not in err
    g = ms2 / 9.80665
    path = _write(tmp_path, "acc_g.npy", g)
    code, _out, err = _cli(["analyze", path, "--fs", "100", "--units", "m/s^2"], capsys)
    assert code == 0
    assert "the magnitude of the mean is 0.1018 g" in err
    assert "pass --units g" in err
    code, _out, err = _cli(["analyze", path, "--fs", "100", "--units", "g"], capsys)
    assert "warning" not in err


def test_accelerometer_data_given_as_rad_s_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An accelerometer triad (m/s^2) read as a gyro in rad/s: its mean has gravity's
    magnitude, far beyond a gyro's bias; the accelerometer's unit is named."""
    path = _write(tmp_path, "acc.npy", _triad((0.12, -0.25, 9.79), 0.02, 33))
    code, _out, err = _cli(["analyze", path, "--fs", "100", "--units", "rad/s"], capsys)
    assert code == 0
    assert "accelerometer data given as rad/s? give the accelerometer's unit (--units m/s^2)" in err


def test_logger_mrad_s_given_as_rad_s_draws_no_wrong_suggestion(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A 1 Hz logger's mrad/s labelled rad/s: deg/h, rad/h and mrad/s would all make it
    plausible, so no unit is proposed (deg/h would make N 206x wrong); mrad/s is listed."""
    rng = np.random.default_rng(34)
    mrad_s = 0.5 + 2.0 * rng.standard_normal(20_000)
    path = _write(tmp_path, "logger.npy", mrad_s)
    code, _out, err = _cli(["analyze", path, "--fs", "1", "--units", "rad/s"], capsys)
    assert code == 0
    assert "outside any real gyro's range" in err
    assert "mrad/s given as rad/s" in err
    assert "pass --units deg/h" not in err
    assert "the record alone cannot tell which, so no unit is proposed" in err
