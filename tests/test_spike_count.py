"""Every spike is counted; only the listing is capped, and it lists the largest."""

from __future__ import annotations

import numpy as np

from allanite.diagnosis import diagnose
from allanite.diagnosis.time_view import MAX_SPIKES, largest_spikes
from allanite.model import NoiseModel
from allanite.terms import White

FS = 100.0
SIGMA = 0.01


def test_largest_spikes_picks_by_size_in_time_order():
    amps = [1.0, -9.0, 2.0, 8.0, -3.0]
    assert largest_spikes(amps, 2) == [1, 3]
    assert largest_spikes(amps, 10) == [0, 1, 2, 3, 4]


def test_a_record_with_thousands_of_spikes_counts_them_all():
    # independent generator: white noise with 3000 spikes of 30 sigma every 40 samples in the
    # first 90 % and ten of 100 sigma in the last tenth (before: counting stopped at 200 and
    # the listing was the first seconds)
    n = 2**17
    rng = np.random.default_rng(5)
    x = SIGMA * rng.standard_normal(n)
    small = np.arange(100, 100 + 40 * 2900, 40)
    big = np.linspace(0.92 * n, 0.99 * n, 10).astype(int)
    x[small] += 30 * SIGMA * rng.choice([-1.0, 1.0], small.size)
    x[big] += 100 * SIGMA
    model = NoiseModel((White(N=SIGMA / np.sqrt(FS)),), {"rate": "deg/s", "time": "s"})
    d = diagnose(x, model, fs=FS, n_mc=20, seed=2)
    assert len(d.time.spike_times_s) == small.size + big.size > MAX_SPIKES
    item = next(u for u in d.unexplained if u.evidence == "spike")
    assert item.size["count"] == small.size + big.size
    assert item.size["listed"] < item.size["count"]
    listed = {round(a * FS) for a, _ in item.where["time_segments_s"]}
    assert set(big.tolist()) <= listed
    assert f"{small.size + big.size:,} found; the 50 largest of" in item.text
