"""Spikes next to a strong random walk: the spike statistic of the time view (issue 14).

A few spikes of 5 sample sigmas of the white noise are hardly larger than the largest of
2^15 Gaussian samples, so the largest deviation alone does not find them; the k-th largest
deviations (:data:`allanite.diagnosis.time_view.SPIKE_ORDERS`) against the law of a k-th
largest do. Each case has a control without the spikes. Fixed seeds; the law itself and its
calibration are tested in ``test_diagnosis_spike_null.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

import benchmark_module
from allanite.diagnosis import diagnose
from allanite.diagnosis.analysis import Plan, analyze
from allanite.diagnosis.inputs import SimSource
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

FS = 100.0
N = 2**15
UNITS = {"rate": "deg/s", "time": "s"}
#: the spikes' height: 5 sample sigmas of the base's white noise (N sqrt(fs))
HEIGHT = 5.0 * 0.05 * np.sqrt(FS)
#: the spikes of the designed spikes+rrw pair (validate_diagnosis, sizes 2+16), fitted half
SPIKES_AT = np.array([5311, 7220, 13891, 14894, 28096, 28172])
SIGNS = np.array([-1.0, -1.0, 1.0, 1.0, -1.0, -1.0])


def term(kind: str, **params: float):
    return TERM_TYPES[kind](**params)


@pytest.fixture(scope="module")
def base() -> NoiseModel:
    """The validation's MEMS-like gyro (white, quantization, flicker, rrw)."""
    return benchmark_module.load("validate_diagnosis").base_model(FS)


@pytest.fixture(scope="module")
def walk(base: NoiseModel) -> np.ndarray:
    """The base plus a random walk 93 times the base's (tau-view noncentrality ~800)."""
    x = base.simulate(N, fs=FS, seed=1510)
    walk = NoiseModel((term("rrw", K=0.0746),), UNITS).simulate(N, fs=FS, seed=1523)
    return np.asarray(x + walk)


def with_spikes(x: np.ndarray) -> np.ndarray:
    y = x.copy()
    y[SPIKES_AT] += HEIGHT * SIGNS
    return y


def test_spikes_of_five_sigma_next_to_a_walk_are_found(base, walk) -> None:
    real = with_spikes(walk)
    source = SimSource(fs=FS, model=base)
    a = analyze(real, source, n_mc=60, seed=7, alpha=0.05)
    view_alpha = 0.05 / 3.0 / 8.0  # the time view's share of the level (see time_view)
    assert a.time.family_p["spike"] < view_alpha
    found = np.round(np.array(a.time.spike_times_s) * FS).astype(int)
    assert len(found) >= 2
    assert set(found.tolist()) <= set(SPIKES_AT.tolist())  # every located one is a spike
    # control: the same record without the spikes shows none
    c = analyze(walk, source, n_mc=60, seed=7, alpha=0.05)
    assert c.time.family_p["spike"] > 0.05
    assert c.time.spike_times_s == []


def test_spike_statistic_is_the_orders_of_the_peak_deviations(base) -> None:
    """The k-th largest deviations among the peaks (the largest within the running median's
    window), in units of the robust spread."""
    from scipy import ndimage

    from allanite.diagnosis.time_view import SPIKE_MEDIAN, SPIKE_ORDERS, highpass, time_features

    x = base.simulate(N, fs=FS, seed=3)
    f = time_features(x, Plan.for_length(N, FS).time)
    assert f["spike"].shape == (len(SPIKE_ORDERS),)
    assert np.all(np.diff(f["spike"]) <= 0)
    hp = np.abs(highpass(x))
    mad = 1.4826 * np.median(np.abs(highpass(x) - np.median(highpass(x))))
    assert f["spike"][0] == pytest.approx(hp.max() / mad, rel=1e-12)
    peaks = np.sort(hp[hp == ndimage.maximum_filter1d(hp, SPIKE_MEDIAN, mode="nearest")])
    for value, k in zip(f["spike"], SPIKE_ORDERS, strict=True):
        assert value == pytest.approx(peaks[-k] / mad, rel=1e-12)


def test_spikes_and_walk_are_both_named(base, walk) -> None:
    real = with_spikes(walk)
    d = diagnose(real, base, fs=FS, units="deg/s", n_mc=60, seed=11)
    assert d.explanation is not None
    named = {a.effect for a in d.explanation.effects}
    assert "spikes" in named
    assert named & {"rrw", "rescale:rrw"}


def test_control_the_walk_alone_is_not_read_as_spikes(base, walk) -> None:
    c = diagnose(walk, base, fs=FS, units="deg/s", n_mc=60, seed=11)
    assert c.explanation is not None
    named = {a.effect for a in c.explanation.effects}
    assert "spikes" not in named
    assert named & {"rrw", "rescale:rrw"}


def test_a_bias_step_next_to_the_walk_is_not_read_as_spikes(base, walk) -> None:
    """A step of 10 sample sigmas moves the running median with it: no deviation stands out."""
    real = walk.copy()
    real[N // 3 :] += 10.0 * 0.05 * np.sqrt(FS)
    a = analyze(real, SimSource(fs=FS, model=base), n_mc=60, seed=7, alpha=0.05)
    assert a.time.spike_times_s == []
    assert a.time.family_p["spike"] > 0.05 / 3.0 / 8.0
    # control: the step itself is seen (a level jump)
    assert a.time.family_p["jump"] < 1e-6
