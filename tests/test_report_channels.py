"""``allanite report --sim-model``: one story per channel (issue #28).

Every channel of the record is diagnosed, each gets one verdict (one badge: a gap the effects
close is still a gap of the simulated sensor), and the config changes are listed. Records from
plain numpy white noise (an independent generator).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from allanite.cli import main

pytest.importorskip("yaml")
pytest.importorskip("matplotlib")

FS = 100.0
N = 2**14


def test_report_diagnoses_every_channel_with_one_verdict_each(tmp_path, capsys):
    n = 1e-3  # rad/s/sqrt(Hz), the config's white noise
    rng = np.random.default_rng(28)
    white = rng.standard_normal((N, 3)) * n * math.sqrt(FS)
    white[:, 0] *= 3.0  # channel 0's white noise is 3x the config's: a gap that rescaling closes
    np.save(tmp_path / "real.npy", white)
    (tmp_path / "imu.yaml").write_text(
        "rostopic: /imu0\nupdate_rate: 100.0\n"
        f"gyroscope_noise_density: {n}\ngyroscope_random_walk: 1.0e-9\n"
        "accelerometer_noise_density: 2.0e-3\naccelerometer_random_walk: 3.0e-4\n"
    )
    out = tmp_path / "r.html"
    argv = ["report", str(tmp_path / "real.npy"), "--fs", "100", "--units", "rad/s", "--no-fit",
            "--n-mc", "20", "--sim-model", str(tmp_path / "imu.yaml"), "-o", str(out)]  # fmt: skip
    assert main(argv) == 0, capsys.readouterr().err
    html = out.read_text()
    section = html[html.index("<h2>Sim-to-real diagnosis</h2>") :]
    parts = re.split(r"<h3>Channel ", section)
    overview, channels = parts[0], parts[1:]
    assert len(channels) == 3  # every channel, not only the first
    assert overview.count('class="badge ') == 3  # one verdict per channel in the overview
    statuses = []
    for text in channels:
        badges = set(re.findall(r'class="badge (\w+)"', text))
        assert len(badges) == 1, badges  # never a PASS and a FAIL for the same channel
        statuses.append(badges.pop())
        label = {"pass": "no gap", "fail": "gap, ", "marginal": "no gap in the noise"}
        assert label[statuses[-1]] in text  # the badge and the words say the same
    assert statuses[0] == "fail"
    assert "gap, closed by the effects below" in channels[0]
    # the overview gives each channel the verdict of its section
    assert re.findall(r'class="badge (\w+)"', overview) == statuses
    # the config change that closes channel 0's gap is listed, in the config's own terms
    assert "To close the gap, change in imu.yaml" in channels[0]
    change = re.search(r"<code>gyroscope_noise_density: ([^<]*?)  -&gt;  "
                       r"gyroscope_noise_density: ([0-9.e+-]+)", channels[0])  # fmt: skip
    assert change is not None, channels[0]
    assert abs(float(change.group(2)) / n - 3.0) < 0.3  # ~3x, within the fit's few-% error
    for text, status in zip(channels, statuses, strict=True):
        assert status == "fail" or "To close the gap" not in text  # no change without a gap
    # the three views of each channel are embedded: one Allan plot plus three diagnosis figures
    assert len(re.findall(r'<img src="data:image/png;base64,', html)) == 4
