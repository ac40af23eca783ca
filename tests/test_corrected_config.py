"""``diagnose --write-corrected``: what is written and said is what the record supports.

Newcomer review of issue #28: a coefficient the record cannot determine (a rescale fitted at
its search floor) was written as a new number; the fold text stated the added white noise, not
the one written, with the unprojected effect's shrinkage; "to close the gap" was printed for a
file whose re-check leaves a gap. Records come from an independent generator (numpy).
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from allanite.cli import main
from allanite.formats import read_config

pytest.importorskip("yaml")

FS = 100.0
N = 2**15  # 328 s: far too short to see a random walk of the size below


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    root = tmp_path_factory.mktemp("corrected")
    rng = np.random.default_rng(2029)
    n_white = 2e-3  # rad/s/sqrt(Hz); no random walk at all
    np.save(root / "real.npy", rng.standard_normal(N) * n_white * math.sqrt(FS))
    # the white noise right, a random walk far larger than the record shows
    (root / "imu.yaml").write_text(
        "rostopic: /imu0\nupdate_rate: 100.0\n"
        f"gyroscope_noise_density: {n_white}\ngyroscope_random_walk: 1.0e-3\n"
        "accelerometer_noise_density: 2.0e-3\naccelerometer_random_walk: 3.0e-4\n"
    )
    (root / "low.yaml").write_text(
        "rostopic: /imu0\nupdate_rate: 100.0\n"
        f"gyroscope_noise_density: {n_white / 2}\ngyroscope_random_walk: 1.0e-9\n"
        "accelerometer_noise_density: 2.0e-3\naccelerometer_random_walk: 3.0e-4\n"
    )
    return root


def _argv(root, config, out, *more):
    return ["diagnose", str(root / "real.npy"), "--fs", str(FS), "--units", "rad/s",
            "--sim-model", str(config), "--n-mc", "30", "--write-corrected", str(out),
            *more]  # fmt: skip


def test_an_undetermined_random_walk_is_not_written_at_the_search_floor(bench, capsys):
    out = bench / "fixed.yaml"
    assert main(_argv(bench, bench / "imu.yaml", out)) == 0
    captured = capsys.readouterr()
    assert "rescale:rrw" in captured.out  # the diagnosis scales the random walk down
    (walk,) = read_config(out).model("gyro").terms_of_type("rrw")
    # not the floor value (x0.001 of the configured 1e-3), and never more than configured
    assert walk.K > 2e-3 * 1.0e-3
    assert walk.K <= 1.0e-3
    line = next(ln for ln in captured.err.splitlines() if ln.startswith("corrected config"))
    assert "rrw not determined by this 327.7 s record" in line
    assert "written at its upper limit" in line
    length = float(re.search(r"a record of at least ([0-9.e+]+) s", line).group(1))
    assert length >= 0.995 * 4 * N / FS  # several times this record (3 digits shown)
    # the upper limit is one the record allows: the file as written closes the gap, and only
    # then does the text say "to close the gap"
    assert "consistent with chance: the written config closes the gap" in captured.out
    assert "to close the gap, change in imu.yaml" in captured.out


def test_the_white_noise_stated_is_the_one_written_and_the_shrinkage_the_rechecks(bench, capsys):
    out = bench / "white.yaml"
    assert main(_argv(bench, bench / "low.yaml", out, "--json")) == 0
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert data["gap"]["significant"]
    line = next(ln for ln in captured.err.splitlines() if ln.startswith("corrected config"))
    assert "shrinkage" not in line  # the fitted effect's gap is not the file's
    written = read_config(out).model("gyro").terms_of_type("white")[0].N
    shown = written * 180.0 / math.pi * 60.0  # rad/s/sqrt(Hz) -> deg/sqrt(h)
    stated = re.search(r"(?:written |rescale:white \(x[0-9.]+, )N = ([0-9.e+-]+)", line)
    assert stated is not None, line
    assert math.isclose(float(stated.group(1)), shown, rel_tol=1e-3)
    corrected = data["corrected"]
    expect = 1 - corrected["recheck"]["statistic"] / data["gap"]["statistic"]
    assert math.isclose(corrected["shrinkage"], expect, rel_tol=1e-12)


def test_an_sdf_correction_changes_only_the_measured_axis(bench, capsys):
    """One channel measured: the x block is corrected, y and z keep what the file says."""
    white = 2e-3 / 2 * math.sqrt(FS)  # per-sample stddev of half the real white noise

    def noise(std):
        return f"<noise type='gaussian'><stddev>{std}</stddev></noise>"

    blocks = {"x": noise(white), "y": noise(0.0123), "z": noise(0.0456)}
    axes = "".join(f"<{a}>{blocks[a]}</{a}>" for a in "xyz")
    sdf = bench / "imu.sdf"
    sdf.write_text(
        f"<sensor type='imu'><update_rate>{FS}</update_rate><imu><angular_velocity>{axes}"
        "</angular_velocity></imu></sensor>"
    )
    out = bench / "fixed.sdf"
    assert main(_argv(bench, sdf, out)) == 0
    captured = capsys.readouterr()
    text = out.read_text()
    assert blocks["y"].replace("'", '"') in text.replace("'", '"')
    assert blocks["z"].replace("'", '"') in text.replace("'", '"')
    assert "axes y, z were not measured and keep their values" in captured.err
    # the x axis is the one corrected, and the changes list no value the file never held
    fixed = read_config(out).model("gyro").terms_of_type("white")[0].N
    assert fixed > 1.5 * 2e-3 / 2
    changes = captured.out.split(f"change in {sdf.name}", 1)[1]
    assert "(x3)" not in changes
    assert "(x2)" not in changes
