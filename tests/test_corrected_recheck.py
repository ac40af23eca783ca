"""``diagnose --write-corrected``: the written config is re-checked as written (issue #28).

A config format may hold the diagnosed effect only as a projection (Kalibr holds a
Gauss-Markov bias as a random walk): the summary must give the gap the file leaves on the same
record, with the projection's Allan-deviation error, never the unprojected effect's shrinkage.
The real record comes from an independent generator (numpy white noise, an AR(1) bias
through scipy.signal.lfilter).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.signal import lfilter

from allanite.cli import main
from allanite.formats import read_config

pytest.importorskip("yaml")

FS = 100.0
N = 2**14


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    root = tmp_path_factory.mktemp("recheck")
    rng = np.random.default_rng(2028)
    n_white = 2e-3  # rad/s/sqrt(Hz)
    sigma, tau_c = 0.02, 2.0  # a Gauss-Markov bias (rad/s, s) the config lacks
    phi = math.exp(-1.0 / (FS * tau_c))
    drive = rng.standard_normal(N) * sigma * math.sqrt(1 - phi**2)
    bias = lfilter([1.0], [1.0, -phi], drive)
    real = rng.standard_normal(N) * n_white * math.sqrt(FS) + bias
    np.save(root / "real.npy", real)
    (root / "imu.yaml").write_text(
        "rostopic: /imu0\nupdate_rate: 100.0\n"
        f"gyroscope_noise_density: {n_white}\ngyroscope_random_walk: 1.0e-6\n"
        "accelerometer_noise_density: 2.0e-3\naccelerometer_random_walk: 3.0e-4\n"
    )
    return root


def _argv(root, config, *more):
    return ["diagnose", str(root / "real.npy"), "--fs", str(FS), "--units", "rad/s",
            "--sim-model", str(config), "--n-mc", "40", *more]  # fmt: skip


def test_a_projected_correction_states_the_gap_it_leaves(bench, capsys):
    out = bench / "fixed.yaml"
    assert main(_argv(bench, bench / "imu.yaml", "--write-corrected", str(out), "--json")) == 0
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert data["gap"]["significant"]
    corrected = data["corrected"]
    assert corrected["path"] == str(out)
    # Kalibr holds the Gauss-Markov bias only as a random walk: projected, with its error
    (projected,) = [p for p in corrected["projections"] if p.startswith("projected gyro:")]
    assert "markov" in projected.split(" -> ")[0]
    assert corrected["adev_error"] > 0.05
    # the error read back from the file is the one the projection itself states
    stated = float(projected.rsplit("largest ADEV error ", 1)[1].split(" %")[0])
    assert abs(100 * corrected["adev_error"] - stated) < 0.05 * stated
    # the shrinkage of the unprojected effect is not claimed for the file
    line = next(ln for ln in captured.err.splitlines() if ln.startswith("corrected config"))
    assert "shrinkage" not in line
    # the re-check is what a diagnosis of the written file says (same record, n_mc, seed)
    recheck = corrected["recheck"]
    assert main(_argv(bench, out, "--json")) == 0
    again = json.loads(capsys.readouterr().out)
    assert math.isclose(recheck["p_value"], again["gap"]["p_value"], rel_tol=1e-12)
    assert math.isclose(recheck["statistic"], again["gap"]["statistic"], rel_tol=1e-12)
    assert recheck["significant"] == again["gap"]["significant"]
    # the model read back under Kalibr's law is what was compared: a random walk, no markov
    fixed = read_config(out).model("gyro")
    assert not fixed.terms_of_type("markov")


def test_the_text_summary_gives_the_projection_error_and_the_recheck(bench, capsys):
    out = bench / "fixed_text.yaml"
    assert main(_argv(bench, bench / "imu.yaml", "--write-corrected", str(out))) == 0
    text = capsys.readouterr().out
    assert f"corrected config {out} (kalibr), re-checked as written:" in text
    assert "the file holds a projection: its Allan deviation differs" in text
    assert "gap against the same record as written: G = " in text
    assert ", p = " in text.split("as written: G = ", 1)[1].splitlines()[0]
