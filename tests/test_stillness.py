"""Motion in a record that should be still: found, named, and the still part analysed.

Records come from generators written here (numpy/scipy only): still noise of several kinds
(white, white + rate random walk, a pure random walk, white + flicker by spectral shaping, a
low-pass filtered white, a quantized rate), and a still hour with a minute of handling (up to
9.7 rad/s) plus robot-bag style motion at the start and the end.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import signal

from allanite.cli import main
from allanite.stillness import find_motion

FS = 50.0
SIGMA = 1e-3  # rad/s per sample: N = SIGMA / sqrt(FS) rad/sqrt(s)
HANDLING = (1500.0, 1560.0)


def _still(kind: str, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    w = SIGMA * rng.standard_normal(n)
    if kind == "white":
        return w
    if kind == "rrw":
        return w + np.cumsum(2e-5 * rng.standard_normal(n))
    if kind == "random walk":
        return np.cumsum(1e-4 * rng.standard_normal(n))
    if kind == "flicker":
        f = np.fft.rfftfreq(n, 1.0 / FS)
        f[0] = f[1]
        pink = np.fft.irfft(np.fft.rfft(rng.standard_normal(n)) / np.sqrt(f), n)
        return w + 3.0 * SIGMA * pink / np.std(pink)
    if kind == "lowpass":
        b, a = signal.butter(2, 5.0 / (FS / 2.0))
        return 3.0 * signal.lfilter(b, a, w)
    if kind == "quantized":
        return np.rint((w + np.cumsum(1e-5 * rng.standard_normal(n))) / 4e-4) * 4e-4
    raise ValueError(kind)


def _handled(seed: int, duration: float = 3600.0) -> np.ndarray:
    """A still record with a minute of handling and robot-bag motion at both ends."""
    n = int(duration * FS)
    x = _still("rrw", n, seed)
    t = np.arange(n) / FS
    a, b = int(HANDLING[0] * FS), int(HANDLING[1] * FS)
    tt = t[a:b] - t[a]
    x[a:b] += 9.7 * np.sin(np.pi * tt / 60.0) ** 2 * np.sin(2.0 * np.pi * 0.4 * tt)
    s = int(20 * FS)  # driving off: a slow turn in the first 20 s
    x[:s] += 0.5 * np.sin(np.pi * t[:s] / 20.0)
    e = int(15 * FS)  # and parking in the last 15 s
    x[-e:] += 0.4 * np.sin(2.0 * np.pi * 0.2 * t[:e])
    return x


@pytest.mark.parametrize("kind", ["white", "rrw", "random walk", "flicker", "lowpass",
                                  "quantized"])  # fmt: skip
def test_still_noise_is_not_motion(kind):
    # the windows are calibrated against the record's own spread at a family-wise false
    # alarm of 1e-3: no seed of any noise kind may be called moving
    for seed in range(4):
        found = find_motion(_still(kind, int(3600 * FS), seed), fs=FS)
        assert not found.has_motion, (kind, seed, found.moving)
        assert found.still == ((0, int(3600 * FS)),)


def test_handling_and_driving_are_found_with_their_times():
    found = find_motion(_handled(1), fs=FS)
    assert found.has_motion
    window = 1.0  # s: the detector's resolution, one window each side
    moving = [(a / FS, b / FS) for a, b in found.moving]
    assert len(moving) == 3
    assert moving[0][0] == 0.0
    assert 20.0 <= moving[0][1] <= 20.0 + 3 * window
    assert HANDLING[0] - 3 * window <= moving[1][0] <= HANDLING[0]
    assert HANDLING[1] <= moving[1][1] <= HANDLING[1] + 3 * window
    assert 3600.0 - 15.0 - 3 * window <= moving[2][0]
    assert moving[2][1] == 3600.0
    longest = found.still[0]
    assert longest[0] / FS == pytest.approx(HANDLING[1], abs=3 * window)
    assert "1560" in found.message() or "1561" in found.message() or "1562" in found.message()


def test_motion_of_an_accelerometer_triad_is_seen_in_its_magnitude():
    # a slow rotation at rest turns g between the axes, a push changes the magnitude
    n = int(600 * FS)
    rng = np.random.default_rng(3)
    f = 1e-2 * rng.standard_normal((n, 3)) + np.array([0.0, 0.0, -9.81])
    a, b = int(300 * FS), int(310 * FS)
    f[a:b, 0] += 2.0 * np.hanning(b - a)
    found = find_motion(f, fs=FS, accelerometer_triad=True)
    assert len(found.moving) == 1
    assert abs(found.moving[0][0] / FS - 300.0) <= 3.0


def _fit_json(path, capsys, *extra):
    rc = main(["fit", str(path), "--fs", f"{FS:g}", "--units", "rad/s", "--json", *extra])
    assert rc == 0
    captured = capsys.readouterr()
    return json.loads(captured.out), captured.err


@pytest.mark.slow
def test_fit_warns_and_still_auto_recovers_n(tmp_path, capsys):
    path = tmp_path / "handled.npy"
    np.save(path, _handled(1))
    truth = SIGMA / np.sqrt(FS) * 180.0 / np.pi * 60.0  # deg/sqrt(h)
    data, err = _fit_json(path, capsys)
    # before: no word about the motion (and the fit read the motion as noise)
    assert "the record contains motion" in err
    assert any("still segments: 1561" in w or "still segments: 1562" in w
               for w in data["record"]["warnings"])  # fmt: skip
    data, err = _fit_json(path, capsys, "--still", "auto")
    assert "--still auto: analysing the longest still segment, 156" in err
    assert data["record"]["duration_s"] == pytest.approx(3600 - 15 - HANDLING[1], abs=4.0)
    coef = {c["symbol"]: c for c in data["channels"][0]["coefficients"]}
    assert coef["N"]["low"] <= truth <= coef["N"]["high"]
    data, err = _fit_json(path, capsys, "--still", "off")
    assert "motion" not in err


def test_analyze_diagnose_and_report_warn(tmp_path, capsys):
    path = tmp_path / "handled.npy"
    x = _handled(2, duration=1800.0)[: int(600 * FS)]  # driving off for 20 s, then still
    np.save(path, x)
    args = [str(path), "--fs", f"{FS:g}", "--units", "rad/s"]
    assert main(["analyze", *args]) == 0
    out = capsys.readouterr().out
    assert "warning: the record contains motion" in out
    assert "still segments: 2" in out
    model = tmp_path / "model.json"
    white = {"type": "white", "N": SIGMA / np.sqrt(FS)}
    model.write_text(json.dumps({"units": {"rate": "rad/s", "time": "s"}, "terms": [white]}))
    assert main(["diagnose", *args, "--sim-model", str(model), "--n-mc", "20"]) in (0, 1)
    assert "the record contains motion" in capsys.readouterr().err
    assert main(["report", *args, "-o", str(tmp_path / "r.html")]) == 0
    assert "the record contains motion" in capsys.readouterr().err
    assert main(["analyze", *args, "--still", "auto"]) == 0
    assert "analysing the longest still segment, 2" in capsys.readouterr().out


def test_real_static_records_are_still(shared_data):
    # the static logs of the shared data: an outlier burst (MTi-G) and quantized counts
    # (ADIS16405, gyro and accelerometer triads) are not motion
    x = np.load(shared_data / "imu" / "mtig" / "cont_imu1_gyro_x.npy")
    assert not find_motion(x, fs=100.0).has_motion
    z = np.load(shared_data / "imu" / "adis16405" / "run1.npz")
    assert not find_motion(z["gyro_counts"] * 0.05, fs=100.0).has_motion
    accel = z["accel_counts"] * 0.00333 * 9.80665
    assert not find_motion(accel, fs=100.0, accelerometer_triad=True).has_motion
