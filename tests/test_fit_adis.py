"""The fit on real data: the ADIS16405 static gyro runs.

The ADIS16405 rate samples are quantised (0.05 deg/s) and come out of the sensor's internal
averaging filter. The default fit finds that filter on X and Y (a moving average near 37 Hz,
the curve's roll-off at the shortest taus) and then describes the whole curve with N, B, K
of the unfiltered sensor; before, it was rejected on every axis with N 5 % low. The Z axes'
shortest taus fall as tau^-2.7 (a tone near the Nyquist frequency): no filter fits them, and
there the fit must say so (p-value, a model discrepancy, the taus it misses) instead of
letting those points push a term far above the rest of the curve. On every axis the fitted
model lies inside the data's own confidence band over the range declared good, the flicker
coefficient is consistent with the ADEV floor, every interval contains its estimate.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

import allanite
import allanite.examples
from allanite.terms import LowPassWhite

LSB = 0.05  # deg/s per count
FS = 100.0
CHANNELS = [(run, axis) for run in (1, 2, 3) for axis in range(3)]


@pytest.fixture(scope="module")
def curves(shared_data):
    out = {}
    for run in (1, 2, 3):
        counts = np.load(shared_data / "imu" / "adis16405" / f"run{run}.npz")["gyro_counts"]
        res = allanite.avar(counts * LSB, fs=FS, taus="octave", units="deg/s")
        for axis in range(3):
            out[run, axis] = res.channel(axis)
    return out


@pytest.fixture(scope="module")
def fits(curves):
    return {key: allanite.fit(curve) for key, curve in curves.items()}


def _ids(key):
    return f"run{key[0]}-{'XYZ'[key[1]]}"


@pytest.mark.parametrize("key", [k for k in CHANNELS if k[1] < 2], ids=_ids)
def test_default_fit_finds_the_sensors_filter_and_the_unfiltered_n(curves, fits, key):
    """X and Y: a moving average near 37 Hz, and N as the fit above its roll-off reads it."""
    fitted = fits[key]
    (term,) = [t for t in fitted.model.terms if isinstance(t, LowPassWhite)]
    assert term.filter == "moving_average"
    assert 30.0 < term.bandwidth < 45.0
    assert "sensor output filter: moving average low-pass" in fitted.format_table()
    # an independent route: the power laws alone on the taus far above the roll-off
    above = allanite.fit(curves[key], ["white", "flicker", "rrw"], tau_range=(0.5, 1e9))
    lo, hi = above["N"].ci(0.99)
    assert lo <= fitted["N"].value <= hi


@pytest.mark.parametrize("key", [k for k in CHANNELS if k[1] == 2], ids=_ids)
def test_misfit_is_flagged_and_carried_by_a_discrepancy(fits, key):
    fitted = fits[key]
    assert fitted.p_value < fitted.misfit_level
    assert fitted.misspecified
    assert fitted.discrepancy > 0
    assert fitted.misfit[0]  # the shortest tau, inside the sensor's filter, is missed
    assert "model REJECTED" in fitted.format_table()


@pytest.mark.parametrize("key", CHANNELS, ids=_ids)
def test_every_interval_contains_its_estimate(fits, key):
    for coef in fits[key].coefficients.values():
        for level in (0.68, 0.95, 0.99):
            lo, hi = coef.ci(level)
            assert lo <= coef.value <= hi, (coef, level, lo, hi)
            assert hi > lo


@pytest.mark.parametrize("key", CHANNELS, ids=_ids)
def test_model_inside_the_data_band_over_the_good_range(curves, fits, key):
    """Over the declared good range the model lies in the data's own (EDF) confidence band.

    The band is the chi-square interval of each estimate at the simultaneous level of the
    per-tau misfit test (Bonferroni over the fitted taus); it does not use the fit.
    """
    curve, fitted = curves[key], fits[key]
    good = fitted.good_range
    assert good is not None
    assert good[1] >= 100.0  # the long taus, where B and K are read, are described
    level = 1.0 - fitted.misfit_level / fitted.tau.size
    lo, hi = curve.var_ci(level)
    idx = np.searchsorted(curve.tau, fitted.tau)
    inside = (fitted.tau >= good[0]) & (fitted.tau <= good[1])
    assert np.all(fitted.fitted[inside] >= lo[idx][inside])
    assert np.all(fitted.fitted[inside] <= hi[idx][inside])


@pytest.mark.parametrize("key", [k for k in CHANNELS if k[1] < 2], ids=_ids)
def test_flicker_consistent_with_the_adev_floor(curves, fits, key):
    """X and Y show a flat floor: B is selected, 0.664 B does not exceed the floor's 95 %
    band (white noise and the random walk add to it there), and the model matches it."""
    curve, fitted = curves[key], fits[key]
    assert "B" in fitted.coefficients
    used = curve.m <= 0.125 * curve.n_samples
    i = int(np.argmin(np.where(used, curve.dev, np.inf)))
    floor_hi = float(curve.ci(0.95)[1][i])
    b_lo, _ = fitted["B"].ci(0.95)
    assert 0.664 * b_lo <= floor_hi
    # the model at the floor lies in the floor's band at the misfit test's simultaneous level
    # (the minimum of noisy estimates sits low, so the 95 % band is not the right yardstick)
    band = curve.ci(1.0 - fitted.misfit_level / fitted.tau.size)
    model_dev = np.sqrt(fitted.model.avar(curve.tau[i : i + 1], 1 / FS))[0]
    assert band[0][i] <= model_dev <= band[1][i]


def test_explicit_rrw_is_bounded_not_runaway(curves):
    """white + flicker + rrw on run 1 X: K is small with a real (non-degenerate) interval."""
    curve = curves[1, 0]
    fitted = allanite.fit(curve, ["white", "flicker", "rrw"])
    lo, hi = fitted["K"].ci(0.95)
    assert lo <= fitted["K"].value <= hi
    assert hi > 0
    # K alone may not exceed the longest fitted tau's upper band: K^2 tau / 3 <= var_hi
    tau_max = fitted.tau[-1]
    _, var_hi = curve.var_ci(0.95)
    assert fitted["K"].value ** 2 * tau_max / 3 <= var_hi[np.searchsorted(curve.tau, tau_max)]


def test_dense_grid_uses_an_octave_like_subset(shared_data, fits):
    counts = np.load(shared_data / "imu" / "adis16405" / "run1.npz")["gyro_counts"][:, 0]
    dense = allanite.avar(counts * LSB, fs=FS, taus="log", points=100, units="deg/s")
    assert dense.tau.size > 60
    fitted = allanite.fit(dense)
    assert np.all(fitted.tau[1:] / fitted.tau[:-1] >= 2.0 * (1 - 1e-9))
    octave = fits[1, 0]
    for name in ("N", "B"):  # the two answers agree within their intervals
        lo, hi = octave[name].ci(0.95)
        dense_lo, dense_hi = fitted[name].ci(0.95)
        assert dense_lo <= hi
        assert lo <= dense_hi
    every = allanite.fit(dense, ["white", "flicker"], min_ratio=1.0)
    assert every.tau.size == int(np.sum(dense.m <= 0.125 * dense.n_samples))


def test_example_record_fits_without_discrepancy():
    """The example record (simulated angle, the original work's model) is well specified."""
    x, fs = allanite.examples.example_record()
    curve = allanite.avar(x, fs=fs, input="angle", taus="octave", units="deg/s")
    fitted = allanite.fit(curve)
    assert fitted.p_value > fitted.misfit_level
    assert fitted.discrepancy == 0
    assert not fitted.misfit.any()
    assert fitted.good_range == (fitted.tau[0], fitted.tau[-1])
    truth = allanite.examples.example_model().coefficients()
    for name, coef in fitted.coefficients.items():
        lo, hi = coef.ci(0.99)
        assert lo <= coef.value <= hi
        assert lo <= truth[name] <= hi


def test_discrepancy_stops_a_runaway_term_on_filtered_white_noise():
    """White noise through a 4-tap moving average: the IEEE terms miss the short taus.

    Without the discrepancy (``misfit_level=0``) the precise short-tau points drive N to 0
    and a flicker term more than 5 times above the curve at the long taus. With it the model
    stays within a factor 2 of the data there and the short taus are flagged. (The filter
    takes 16x off the variance at tau = dt, so those points still pull N about 35 % low: an
    independent-per-tau discrepancy cannot tell a few wild points from a general misfit; the
    ``misfit`` flags show which taus to distrust.)
    """
    rng = np.random.default_rng(3)
    w = rng.standard_normal(2**18 + 3) * 0.04 / np.sqrt(0.01)
    x = np.round(signal.lfilter(np.ones(4) / 4, [1.0], w)[3:] / LSB) * LSB
    curve = allanite.avar(x, fs=FS, taus="octave", units="deg/s")
    naive = allanite.fit(curve, ["white", "flicker"], misfit_level=0)
    fitted = allanite.fit(curve, ["white", "flicker"])
    long = fitted.tau >= 5.0
    ratio = np.sqrt(fitted.fitted / fitted.var)[long]
    naive_ratio = np.sqrt(naive.fitted / naive.var)[long]
    assert naive.discrepancy == 0
    assert np.max(naive_ratio) > 5
    assert fitted.misspecified
    assert fitted.discrepancy > 0
    assert np.all((ratio > 0.5) & (ratio < 2.0))
    assert fitted.misfit[:3].all()
