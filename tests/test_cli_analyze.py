"""``allanite analyze`` end to end on every format, and on malformed files (exit 2, one line)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import allanite
from allanite.cli import main
from allanite.confidence import DEFAULT_LEVEL

RNG = np.random.default_rng(11)
FS = 100.0
N = 3000
COUNTS = RNG.integers(-200, 200, size=(N, 2)).astype(np.int16)
SCALE = 0.05
RATE = COUNTS * SCALE


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def _text(tmp_path: Path) -> tuple[Path, list[str]]:
    t = np.arange(N) / FS
    rows = "\n".join(f"{a:.6f},{b},{c}" for a, (b, c) in zip(t, COUNTS, strict=True))
    path = tmp_path / "rec.csv"
    path.write_text("time,gx,gy\n" + rows + "\n")
    return path, ["--time-column", "time"]


def _npy(tmp_path: Path) -> tuple[Path, list[str]]:
    path = tmp_path / "rec.npy"
    np.save(path, COUNTS)
    return path, ["--fs", str(FS)]


def _npz(tmp_path: Path) -> tuple[Path, list[str]]:
    path = tmp_path / "rec.npz"
    np.savez(path, gyro_counts=COUNTS, other=np.zeros(3))
    return path, ["--fs", str(FS), "--key", "gyro_counts"]


def _raw(tmp_path: Path) -> tuple[Path, list[str]]:
    path = tmp_path / "rec.bin"
    path.write_bytes(b"\0" * 16 + COUNTS.astype(">i2").tobytes())
    return path, [
        "--fs",
        str(FS),
        "--dtype",
        "int16",
        "--n-channels",
        "2",
        "--byte-order",
        "big",
        "--offset",
        "16",
    ]


def _hdf5(tmp_path: Path) -> tuple[Path, list[str]]:
    h5py = pytest.importorskip("h5py")
    path = tmp_path / "rec.h5"
    with h5py.File(path, "w") as handle:
        handle["gyro"] = COUNTS
    return path, ["--fs", str(FS)]


def _parquet(tmp_path: Path) -> tuple[Path, list[str]]:
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    path = tmp_path / "rec.parquet"
    pd.DataFrame({"gx": COUNTS[:, 0], "gy": COUNTS[:, 1]}).to_parquet(path)
    return path, ["--fs", str(FS)]


WRITERS: dict[str, Callable[[Path], tuple[Path, list[str]]]] = {
    "text": _text,
    "npy": _npy,
    "npz": _npz,
    "raw": _raw,
    "hdf5": _hdf5,
    "parquet": _parquet,
}


@pytest.mark.parametrize("fmt", list(WRITERS))
def test_analyze_every_format_matches_library(
    fmt: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, extra = WRITERS[fmt](tmp_path)
    argv = [
        "analyze",
        str(path),
        *extra,
        "--scale",
        str(SCALE),
        "--units",
        "deg/s",
        "--points",
        "12",
        "--json",
    ]
    code, out, err = _run(argv, capsys)
    assert code == 0, err
    data = json.loads(out)
    expected = allanite.avar(RATE, fs=FS, points=12, units="deg/s")
    np.testing.assert_allclose(data["allan"]["tau"], expected.tau)
    np.testing.assert_allclose(data["allan"]["dev"], expected.dev, rtol=1e-12)
    lo, hi = expected.ci(DEFAULT_LEVEL)  # the CLI's --level default
    np.testing.assert_allclose(data["allan"]["dev_low"], lo, rtol=1e-12)
    np.testing.assert_allclose(data["allan"]["dev_high"], hi, rtol=1e-12)
    assert data["allan"]["units"] == "deg/s"
    assert data["record"]["fs"] == pytest.approx(FS)
    assert data["record"]["n_samples"] == N


@pytest.mark.parametrize("dtype", ["float64", "float32", "int16", "int32", "int64"])
@pytest.mark.parametrize("suffix", [".bin", ".i16"])
def test_raw_binary_every_dtype_loads_without_scale(
    dtype: str, suffix: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: little-endian raw files failed with 'unsupported dtype float64' unless
    --scale converted them, and --dtype was ignored for suffixes other than .bin."""
    samples = COUNTS.astype(dtype)
    path = tmp_path / f"rec{suffix}"
    samples.astype(np.dtype(dtype).newbyteorder("<")).tofile(path)
    argv = ["analyze", str(path), "--dtype", dtype, "--n-channels", "2", "--fs", str(FS)]
    code, out, err = _run([*argv, "--points", "12", "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    expected = allanite.avar(samples, fs=FS, points=12)
    np.testing.assert_allclose(data["allan"]["dev"], expected.dev, rtol=1e-12)
    assert data["record"]["n_samples"] == N


def test_raw_options_with_a_self_describing_file_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, extra = _npy(tmp_path)
    code, out, err = _run(["analyze", str(path), *extra, "--offset", "16"], capsys)
    assert code == 2
    assert out == ""
    assert "--offset describe raw binary, but the file is npy" in err
    text, extra = _text(tmp_path)
    code, out, err = _run(["analyze", str(text), *extra, "--dtype", "int16"], capsys)
    assert code == 2
    assert out == ""
    assert "--dtype describe raw binary, but the file is plain text" in err


def test_analyze_text_table_channels_kind_and_outputs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, extra = _text(tmp_path)
    csv_out = tmp_path / "adev.csv"
    png_out = tmp_path / "adev.png"
    argv = [
        "analyze",
        str(path),
        *extra,
        "--channels",
        "gy",
        "--scale",
        str(SCALE),
        "--kind",
        "modified",
        "--taus",
        "octave",
        "-o",
        str(csv_out),
        "--plot",
        str(png_out),
    ]
    code, out, err = _run(argv, capsys)
    assert code == 0, err
    expected = allanite.avar(RATE[:, 1], fs=FS, kind="modified", taus="octave")
    assert "modified Allan deviation" in out
    assert "channel gy:" in out
    table = np.loadtxt(csv_out, delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], expected.tau)
    header = csv_out.read_text().splitlines()[0].split(",")
    np.testing.assert_allclose(table[:, header.index("dev")], expected.dev, rtol=1e-12)
    assert png_out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_angle_input_and_points(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    angle = np.cumsum(RATE[:, 0]) / FS
    path = tmp_path / "angle.txt"
    np.savetxt(path, angle, fmt="%.17g")
    code, out, err = _run(
        [
            "analyze",
            str(path),
            "--fs",
            "100",
            "--input",
            "angle",
            "--units",
            "deg",
            "--points",
            "30",
            "--json",
        ],
        capsys,
    )
    assert code == 0, err
    data = json.loads(out)
    expected = allanite.avar(angle, fs=FS, input="angle", points=30)
    np.testing.assert_allclose(data["allan"]["dev"], expected.dev, rtol=1e-12)
    assert data["allan"]["units"] == "deg/s"
    assert len(data["allan"]["tau"]) == len(allanite.variance.taus.log_grid(N, 30))


def _truncated_npy(tmp_path: Path) -> Path:
    path = tmp_path / "trunc.npy"
    np.save(path, RNG.normal(size=(1000, 3)))
    path.write_bytes(path.read_bytes()[:3000])
    return path


def _write(name: str, text: str) -> Callable[[Path], Path]:
    def make(tmp_path: Path) -> Path:
        path = tmp_path / name
        path.write_text(text)
        return path

    return make


MALFORMED: dict[str, tuple[Callable[[Path], Path], list[str], list[str]]] = {
    "truncated npy": (_truncated_npy, ["--fs", "100"], ["trunc.npy", "truncated", "copy"]),
    "wrong delimiter": (
        _write("semi.csv", "1;2\n3;4\n5;6\n7;8\n"),
        ["--fs", "100", "--delimiter", ","],
        ["semi.csv", "line 1", "field 1", "separated by ';'", "--delimiter"],
    ),
    "non-numeric cell": (
        _write("cells.csv", "t,gx\n0,1\n0.01,2\n0.02,x7\n0.03,1\n"),
        ["--time-column", "t"],
        ["cells.csv", "line 4", "field 2", "'x7'", "correct or remove the row"],
    ),
    "empty file": (_write("empty.txt", ""), ["--fs", "100"], ["empty.txt", "empty"]),
    "only comments": (
        _write("comments.txt", "# nothing\n"),
        ["--fs", "100"],
        ["comments.txt", "no data rows"],
    ),
    "unsorted stamps": (
        _write("unsorted.csv", "t,gx\n0,1\n0.02,2\n0.01,3\n0.03,1\n"),
        ["--time-column", "t"],
        ["unsorted.csv", "line 4", "not sorted", "sort the rows"],
    ),
    "duplicated stamps": (
        _write("dup.csv", "t,gx\n0,1\n0.01,2\n0.01,3\n0.02,1\n"),
        ["--time-column", "t"],
        ["dup.csv", "line 4", "duplicated time stamp", "remove the repeated rows"],
    ),
    "gaps without policy": (
        _write("gap.csv", "t,gx\n0,1\n0.01,2\n0.02,3\n0.05,1\n0.06,1\n"),
        ["--time-column", "t"],
        ["gap.csv", "line 5", "--gaps split", "--gaps fill"],
    ),
    "ragged rows": (
        _write("ragged.csv", "1,2\n3,4\n5\n7,8\n"),
        ["--fs", "100"],
        ["ragged.csv", "line 3", "1 field(s)", "2 columns"],
    ),
    "nan sample": (
        _write("nan.txt", "1\n2\nnan\n4\n"),
        ["--fs", "1"],
        ["nan.txt", "line 3", "remove or repair"],
    ),
    "missing fs": (_write("nofs.txt", "1\n2\n3\n4\n"), [], ["nofs.txt", "--fs HZ"]),
    "unknown column": (
        _write("cols.csv", "a,b\n1,2\n3,4\n5,6\n"),
        ["--fs", "1", "--channels", "c"],
        ["cols.csv", "no column named 'c'", "available: a, b"],
    ),
    "missing file": (lambda p: p / "absent.csv", ["--fs", "1"], ["absent.csv", "no such file"]),
}


@pytest.mark.parametrize("case", list(MALFORMED))
def test_malformed_input_one_line_exit_2_no_output(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    make, extra, needles = MALFORMED[case]
    path = make(tmp_path)
    outdir = tmp_path / "out"
    outdir.mkdir()
    argv = [
        "analyze",
        str(path),
        *extra,
        "-o",
        str(outdir / "r.json"),
        "--plot",
        str(outdir / "r.png"),
    ]
    code, out, err = _run(argv, capsys)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("allanite analyze: error: ")
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    assert list(outdir.iterdir()) == []


def test_failure_after_plot_leaves_no_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, extra = _npy(tmp_path)
    plot = tmp_path / "ok.png"
    code, _, err = _run(
        ["analyze", str(path), *extra, "--plot", str(plot), "-o", str(tmp_path / "table.xlsx")],
        capsys,
    )
    assert code == 2
    assert "use a .csv or .json" in err
    assert not (tmp_path / "table.xlsx").exists()
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_help_has_examples(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["analyze", "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "examples:" in out
    assert "--example" in out
    assert "--points" in out


def test_example_record(capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("allanite.examples", reason="the example record (issue 4) is not built")
    code, out, err = _run(["analyze", "--example", "--points", "10", "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    assert data["record"]["fs"] == 100.0
    assert data["record"]["input"] == "angle"
    assert data["record"]["duration_s"] == pytest.approx(1800.0)
    assert np.all(np.isfinite(data["allan"]["dev"]))


def test_console_script_runs(tmp_path: Path) -> None:
    path, extra = _npy(tmp_path)
    proc = subprocess.run(
        [sys.executable, "-m", "allanite", "analyze", str(path), *extra, "--points", "5"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert "tau [s]" in proc.stdout
    bad = subprocess.run(
        [sys.executable, "-m", "allanite", "analyze", str(tmp_path / "nope.npy"), "--fs", "1"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1
    assert "nope.npy" in bad.stderr


def test_closed_pipe_is_not_an_error(tmp_path: Path) -> None:
    path, extra = _npy(tmp_path)
    # --taus all prints ~3000 rows, more than a pipe buffer: the writer hits a closed pipe
    proc = subprocess.Popen(
        [sys.executable, "-m", "allanite", "analyze", str(path), *extra, "--taus", "all"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    assert proc.stdout.readline().startswith("record:")
    proc.stdout.close()
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0
    assert "error" not in err


def test_first_screen_summary_above_the_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """White rate noise N: one -1/2 region, N read at tau = 1 s, the fit command, the table."""
    n_true = 0.01  # deg/s/sqrt(Hz) = deg/sqrt(s)
    x = np.random.default_rng(8).standard_normal(200_000) * n_true * np.sqrt(FS)
    path = tmp_path / "white.npy"
    np.save(path, x)
    code, out, err = _run(["analyze", str(path), "--fs", "100", "--units", "deg/s"], capsys)
    assert code == 0, err
    lines = out.splitlines()
    summary = lines.index("  slope regions of the curve:")
    table = next(i for i, line in enumerate(lines) if "tau [s]" in line)
    assert summary < table
    assert "(−1/2): angle random walk" in lines[summary + 1]
    assert "slope-method readouts (IEEE 952 graphical reading, no uncertainty; not a fit):" in out
    n_line = next(line for line in lines if line.startswith("    N = "))
    value = float(n_line.split()[2])
    assert n_line.split()[3] == "deg/sqrt(h)"
    # the readout of a white-noise curve at tau = 1 s is N itself (1 deg/sqrt(s) = 60 deg/sqrt(h))
    assert value == pytest.approx(60 * n_true, rel=0.05)
    assert "read at tau = 1 s" in n_line
    assert "    B: —  (no region of slope 0 in the table above)" in lines
    fit_line = next(line for line in lines if "fitted coefficients with intervals:" in line)
    command = fit_line.split(": ", 1)[1].split()
    assert command[:3] == ["allanite", "fit", str(path)]
    code, fit_out, err = _run([*command[1:], "--json"], capsys)
    assert code == 0, err
    assert json.loads(fit_out)["channels"][0]["coefficients"]
    # the same summary in the JSON, in the record's units (N in deg/s*sqrt(s) = deg/sqrt(s))
    code, out, _ = _run(["analyze", str(path), "--fs", "100", "--json"], capsys)
    (summary,) = json.loads(out)["summary"]
    assert summary["channel"] == "col0"
    assert [row["term"] for row in summary["slopes"]] == ["angle random walk (white rate noise)"]
    assert summary["readouts"]["N"] == pytest.approx(value / 60, rel=1e-3)
    assert summary["readouts"]["B"] is None
    assert "no uncertainty" in summary["readouts"]["label"]
    # --table: the table alone (no summary); --summary: the summary alone
    code, out, _ = _run(["analyze", str(path), "--fs", "100", "--table"], capsys)
    assert "slope regions" not in out
    assert "tau [s]" in out
    code, out, _ = _run(["analyze", str(path), "--fs", "100", "--summary"], capsys)
    assert "slope regions" in out
    assert "tau [s]" not in out
    assert "N = " in out
    assert "(rate unit)*sqrt(s)" in out


def test_flat_minimum_readout_is_an_upper_bound(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """White + rate random walk, no flicker: the flat minimum is the N-K crossover, so the
    slope-method B is printed as an upper bound, never as B = (the fit has no B there)."""
    rng = np.random.default_rng(21)
    n, k = 0.01, 1e-3  # deg/sqrt(s), deg/s/sqrt(s)
    dt = 1 / FS
    x = rng.standard_normal(400_000) * n / np.sqrt(dt)
    x += np.cumsum(rng.standard_normal(x.size)) * k * np.sqrt(dt)
    path = tmp_path / "white_rrw.npy"
    np.save(path, x)
    code, out, err = _run(["analyze", str(path), "--fs", "100", "--units", "deg/s"], capsys)
    assert code == 0, err
    (b_line,) = [line for line in out.splitlines() if line.startswith("    B ")]
    assert b_line.startswith("    B <= ")
    assert "upper bound" in b_line
    assert not any(line.startswith("    B = ") for line in out.splitlines())


def test_too_short_for_a_fit_names_the_fit_rule(tmp_path, capsys):
    """The summary's advice is the fit's own minimum (min_auto_samples, from AUTO_MIN_POINTS
    and fit_factors): one sample fewer is refused by the fit, that many is fitted; on a longer
    record a too sparse grid is named instead."""
    import allanite
    from allanite.errors import RecordTooShortError
    from allanite.fit.api import AUTO_MIN_POINTS, min_auto_samples

    need = min_auto_samples()
    x = np.random.default_rng(3).standard_normal(4000) * 0.01
    path = tmp_path / "rec.npy"
    np.save(path, x[: need - 1])
    assert main(["analyze", str(path), "--fs", "100", "--units", "deg/s"]) == 0
    out = capsys.readouterr().out
    assert f"too short for a fit ({need - 1} samples" in out
    assert f"{AUTO_MIN_POINTS} usable taus, {need} samples or more" in out
    with pytest.raises(RecordTooShortError):
        allanite.fit(x[: need - 1], fs=100.0)
    np.save(path, x[:need])
    assert main(["analyze", str(path), "--fs", "100", "--units", "deg/s"]) == 0
    assert "fitted coefficients with intervals: allanite fit " in capsys.readouterr().out
    assert allanite.fit(x[:need], fs=100.0).model.terms
    np.save(path, x)
    assert main(["analyze", str(path), "--fs", "100", "--units", "deg/s", "--points", "2"]) == 0
    out = capsys.readouterr().out
    assert "the tau grid gives only 1 usable tau for a fit (choosing the terms needs 3)" in out


def test_accelerometer_readouts_use_accelerometer_words_and_units(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 30 item 7: an accelerometer in g is read as fit and report read it: "velocity
    random walk" in the region table, N in m/s/sqrt(h) (not "angle random walk", (g)*sqrt(s)).
    """
    import re

    rng = np.random.default_rng(7)
    sigma = 8.5e-4  # g at 100 Hz: N = sigma * sqrt(0.01 s) = 8.5e-5 g*sqrt(s)
    path = tmp_path / "acc.npy"
    np.save(path, 1.0 + sigma * rng.standard_normal(100_000))
    code, out, _err = _run(["analyze", str(path), "--fs", "100", "--units", "g"], capsys)
    assert code == 0
    assert "velocity random walk (white acceleration noise)" in out
    assert "angle random walk" not in out
    match = re.search(r"N = ([0-9.e+-]+) m/s/sqrt\(h\)", out)
    assert match is not None, out
    expected = sigma * 0.1 * 9.80665 * 60.0  # m/s/sqrt(h)
    # the readout at tau = 1 s has EDF ~ 1.5 * 1e5 / 100 = 1500: 3 sigma = 3/sqrt(2*1500)
    assert float(match.group(1)) == pytest.approx(expected, rel=3 / math.sqrt(3000))


def _white_and_flicker(n: int, ratio: float, seed: int) -> np.ndarray:
    """Unit white noise plus flicker (numpy: white shaped by 1/sqrt(f) in the FFT)."""
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n)
    f[0] = f[1]
    flicker = np.fft.irfft(np.fft.rfft(rng.standard_normal(n)) / np.sqrt(f), n)
    return np.random.default_rng(100 + seed).standard_normal(n) + ratio * 0.05 * (
        flicker / flicker.std()
    )


@pytest.mark.parametrize(("seed", "ratio"), [(0, 2.0), (0, 0.5), (3, 1.0), (5, 1.0)])
def test_bias_region_and_b_readout_agree(
    seed: int, ratio: float, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 30 item 8: a region named "bias instability" comes with a B readout and a B
    readout with such a region (one rule). (0, 2.0) is the issue's case: the curve still falls
    a little (-0.19) at its last reliable tau, so the lowest point is the last one and the old
    rule (an interior minimum) printed "B: — (no flat minimum)" under a bias-instability row."""
    path = tmp_path / "fl.npy"
    np.save(path, _white_and_flicker(200_000, ratio, seed))
    code, out, _err = _run(["analyze", str(path), "--fs", "10", "--units", "deg/s"], capsys)
    assert code == 0
    region = "bias instability (flicker rate noise)" in out
    readout = "    B <= " in out
    assert region == readout, out
    assert region or "B: —  (no region of slope 0 in the table above)" in out
    if (seed, ratio) == (0, 2.0):
        assert region  # the case, which the old rule left without B


def test_arcsec_records_show_datasheet_units_and_display_units_chooses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 30 item 9: a record in arcsec/s prints N in deg/sqrt(h) (as datasheets quote it)
    in analyze, fit and report; --display-units arcsec shows arcsec/sqrt(h); a unit that is not
    an angle is refused by name."""
    path = tmp_path / "rlg.npy"
    np.save(path, 36.0 * np.random.default_rng(9).standard_normal(60_000))  # arcsec/s, 100 Hz
    base = [str(path), "--fs", "100", "--units", "arcsec/s"]
    # N = 36 arcsec/s * sqrt(0.01 s) = 3.6 arcsec/sqrt(s) = 216 arcsec/sqrt(h) = 0.06 deg/sqrt(h)
    for command in ("analyze", "fit"):
        code, out, _err = _run([command, *base], capsys)
        assert code == 0
        assert "deg/sqrt(h)" in out, out
        assert "arcsec/sqrt(h)" not in out
        code, out, _err = _run([command, *base, "--display-units", "arcsec"], capsys)
        assert code == 0
        assert "arcsec/sqrt(h)" in out, out
        assert "deg/sqrt(h)" not in out
    html = tmp_path / "r.html"
    code, _out, _err = _run(["report", *base, "-o", str(html)], capsys)
    assert code == 0
    assert "deg/sqrt(h)" in html.read_text() or "deg/√h" in html.read_text()
    code, _out, err = _run(["fit", *base, "--display-units", "m/s"], capsys)
    assert code == 2
    assert "--display-units takes an angle unit" in err
