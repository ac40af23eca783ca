"""The original work's coefficients, simulated as 30-minute angle records, are recovered.

The records come from ``NoiseModel.simulate`` (allanite.simulation), so this also checks that
the simulator and the fit agree.
"""

from __future__ import annotations

import numpy as np
import pytest

import allanite
from allanite.model import NoiseModel
from allanite.terms import Flicker, Quantization, RateRamp, RateRandomWalk, White

FS = 100.0
ORIGINAL = NoiseModel(
    (
        Quantization(Q=2.45e-3),
        White(N=6.153e-3),
        Flicker(B=6.619e-5),
        RateRandomWalk(K=8.1e-4),
        RateRamp(R=1.039e-8),
    ),
    {"rate": "deg/s", "time": "s"},
)
RECORDS = 20


@pytest.fixture(scope="module")
def angle_records() -> np.ndarray:
    """Twenty 30-minute angle records (deg) from the library's own simulator."""
    return ORIGINAL.simulate(int(1800 * FS), fs=FS, output="angle", n_channels=RECORDS, seed=2024)


@pytest.mark.slow
def test_original_coefficients_within_their_intervals(angle_records):
    """Each coefficient inside its 95 % interval in >= 16 of 20 records.

    For calibrated intervals the count is Binomial(20, 0.95); P(count < 16) = 1.6 %.
    """
    truth = ORIGINAL.coefficients()
    res = allanite.avar(angle_records, fs=FS, input="angle", taus="octave", units="deg/s")
    inside = dict.fromkeys(truth, 0)
    for c in range(RECORDS):
        fitted = allanite.fit(res.channel(c), ["Q", "N", "B", "K", "R"])
        for name, value in truth.items():
            lo, hi = fitted[name].ci(0.95)
            inside[name] += lo <= value <= hi
    assert all(v >= 16 for v in inside.values()), inside


def test_one_record_table_and_classic_readouts(angle_records):
    res = allanite.avar(angle_records[:, 0], fs=FS, input="angle", taus="octave", units="deg/s")
    fitted = allanite.fit(res, ["Q", "N", "B", "K", "R"])
    rows = {r["name"]: r for r in fitted.table("deg/h")}
    assert rows["N"]["unit"] == "deg/sqrt(h)"
    assert rows["K"]["unit"] == "deg/h/sqrt(h)"
    # N = 6.153e-3 deg/sqrt(s) = 0.369 deg/sqrt(h); Q and N are sharply determined here
    assert rows["N"]["low"] <= 0.36918 <= rows["N"]["high"]
    assert rows["Q"]["low"] <= 2.45e-3 <= rows["Q"]["high"]
    # the slope method reads the -1 and -1/2 lines (labelled, no uncertainty)
    assert "slope method" in fitted.classic.label
    assert fitted.classic.values["Q"] == pytest.approx(2.45e-3, rel=0.1)
    assert fitted.classic.values["N"] is not None


def test_seed_method_reproduces_the_original_fit_form(angle_records):
    res = allanite.avar(angle_records[:, 0], fs=FS, input="angle", taus="log", units="deg/s")
    seed = allanite.fit(res, method="seed")
    assert seed.method == "seed"
    assert set(seed.coefficients) == {"Q", "N", "B", "K", "R"}
    raw = seed.meta["raw"]
    # sigma^2 = r^2 tau^2 + k^2 tau + b^2 + n^2/tau + q^2/tau^2, coefficients from r, k, b, n, q
    tau = np.array([0.1, 10.0])
    poly = sum(raw[k] ** 2 * tau**p for k, p in zip("rkbnq", (2, 1, 0, -1, -2), strict=True))
    assert np.allclose(seed.model.avar(tau, 1 / FS), poly, rtol=0.02)
    lo, hi = seed["Q"].ci(0.95)
    assert lo <= seed["Q"].value <= hi
    assert seed.meta["raw_bounds_95"]["q"][0] < raw["q"] < seed.meta["raw_bounds_95"]["q"][1]
    assert seed["Q"].value == pytest.approx(2.45e-3, rel=0.05)
