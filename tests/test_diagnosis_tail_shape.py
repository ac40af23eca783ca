"""The time view's tail-shape statistic: a scale mixture told from a few spikes (issue 14).

One angle sample in ten dropped at rest makes every tenth rate sample the sum of two
increments (a ``sqrt(2)``-scale mixture); the spike statistic reads its far tail as a few
spikes and a spikes effect then explains the kurtosis too. The tail shape
(:func:`~allanite.diagnosis.time_view.tail_features`,
:func:`~allanite.diagnosis.time_view.tail_test`) scores the moderate deviations (3 to 4.5
robust sigmas), which a few spikes do not reach. Fixed seeds; calibration tolerances from the
binomial law.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import allanite
import benchmark_module
from allanite.diagnosis.null import NullEnsemble
from allanite.diagnosis.time_view import TAIL_BAND, tail_features, tail_test
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

FS = 100.0
N = 2**15
UNITS = {"rate": "deg/s", "time": "s"}
#: the diagnosis' level for one evidence statistic after the effects (alpha / 10)
EVIDENCE_LEVEL = 0.05 / 10


def feats(x: np.ndarray) -> dict[str, np.ndarray]:
    """The features ``tail_test`` reads of one record."""
    return {"tail": tail_features(x), "spike_n": np.array([float(x.size)])}


def ensemble(model: NoiseModel, n_mc: int, seed: int) -> NullEnsemble:
    """The null of ``n_mc`` replicates of ``model`` (as the diagnosis builds it)."""
    x = np.asarray(model.simulate(N, fs=FS, n_channels=n_mc, seed=seed)).reshape(N, -1)
    return NullEnsemble.from_model([feats(np.ascontiguousarray(x[:, j])) for j in range(n_mc)])


@pytest.fixture(scope="module")
def white() -> NoiseModel:
    return NoiseModel((TERM_TYPES["white"](N=0.05),), UNITS)


def mixture(rng: np.random.Generator, share: float = 0.1) -> np.ndarray:
    """Unit Gaussian samples, ``share`` of them with ``sqrt(2)`` times the spread."""
    x = rng.standard_normal(N)
    x[rng.random(N) < share] *= np.sqrt(2.0)
    return x


def test_the_statistic_is_scale_free_and_blind_to_spikes_above_its_band() -> None:
    rng = np.random.default_rng(1)
    x = rng.standard_normal(N)
    base = tail_features(x)
    np.testing.assert_allclose(tail_features(3.0 * x + 5.0), base, rtol=1e-9)
    # 30 spikes of 10 sigmas lie above the band: the score moves only by what the spikes do
    # to their neighbours' running mean (a third of a sigma over 32 samples each)
    spiked = x.copy()
    spiked[rng.choice(N, 30, replace=False)] += 10.0 * rng.choice([-1.0, 1.0], 30)
    assert abs(tail_features(spiked)[0] / base[0] - 1.0) < 0.1
    # a sqrt(2)-scale mixture in one sample in ten raises it far more
    assert tail_features(mixture(rng))[0] > 1.5 * base[0]
    assert TAIL_BAND[1] < 10.0 * (1 - 1 / 33)


def test_a_scale_mixture_is_found_and_spikes_alone_are_not(white: NoiseModel) -> None:
    """Against white noise: 20 mixture records all beyond the evidence level; 60 records with
    20 spikes of 8 sigmas each are as calibrated as null records (binomial bound)."""
    ens = ensemble(white, 60, seed=11)
    rng = np.random.default_rng(12)
    sigma = 0.05 * np.sqrt(FS)
    p_mix = [tail_test(feats(sigma * mixture(rng)), ens)[0] for _ in range(20)]
    assert max(p_mix) < EVIDENCE_LEVEL
    x = np.asarray(white.simulate(N, fs=FS, n_channels=60, seed=13)).reshape(N, -1)
    p_spiked = []
    for j in range(60):
        y = x[:, j].copy()
        y[rng.choice(N, 20, replace=False)] += 8.0 * sigma * rng.choice([-1.0, 1.0], 20)
        p_spiked.append(tail_test(feats(y), ens)[0])
    hits = int(np.sum(np.array(p_spiked) < 0.05))
    assert hits <= stats.binom.isf(1e-3, 60, 0.05)


def test_null_calibration_of_the_tail_shape_small_batch() -> None:
    """Null records of the validation's MEMS base (white, quantization, flicker, rrw) against
    60 replicates each (the calibration benchmark's machinery, 200 trials): the fraction with
    p < 0.05 lies below the binomial bound of a calibrated test, and p < 0.005 is rarer still."""
    cal = benchmark_module.load("calibrate_spike_null")
    row = cal.calibrate("mems", 2**14, [60], 200, seed=5_100, statistic="tail")[0]
    below = round(row["below_0.05"]["fraction"] * 200)
    assert below <= stats.binom.isf(1e-3, 200, 0.05)
    assert round(row["below_0.01"]["fraction"] * 200) <= stats.binom.isf(1e-3, 200, 0.01)


@pytest.mark.slow
def test_null_calibration_of_the_long_record_path() -> None:
    """Records of 2^19 samples judged by replicates of SHORT_LENGTH samples (shares rescaled as
    the scaled null does): calibrated at p < 0.05 within the binomial bound."""
    cal = benchmark_module.load("calibrate_spike_null")
    row = cal.calibrate("navgrade", 2**19, [60], 100, seed=5_200, statistic="tail")[0]
    assert row["replicate_n"] < row["n"]
    assert round(row["below_0.05"]["fraction"] * 100) <= stats.binom.isf(1e-3, 100, 0.05)


@pytest.mark.slow
def test_dropped_angle_samples_are_not_closed_by_spikes() -> None:
    """The OOV suite's dropped_angle record (seed 1202) was read as closed by spikes + white;
    the tail shape stays unexplained after them."""
    vd = benchmark_module.load("validate_diagnosis")
    r = vd.evaluate_oov("dropped_angle", 1202, 60)
    assert not r["closed"]
    assert "tail" in r["evidence"]
    assert "moderate deviations" in r["headline"]


@pytest.mark.slow
def test_a_spikes_only_record_is_still_closed_by_spikes() -> None:
    """The validation's MEMS base with spikes of 7 sample sigmas (the quick suite's medium
    spikes): named spikes, closed, the tail shape not left over."""
    vd = benchmark_module.load("validate_diagnosis")
    base = vd.base_model(FS)
    spikes = TERM_TYPES["spikes"](amplitude=7.0 * 0.05 * np.sqrt(FS), rate=0.02)
    real = NoiseModel((*base.terms, spikes), base.units).simulate(2**16, fs=FS, seed=31)
    d = allanite.diagnose(real, base, fs=FS, units="deg/s", n_mc=60, seed=32)
    assert d.explanation is not None
    assert "spikes" in [a.effect for a in d.explanation.effects]
    assert d.closed
    assert "tail" not in [u.evidence for u in d.unexplained]


def test_a_model_whose_samples_never_reach_the_band_gets_a_p_value():
    """Regression: a quantization-dominated model (bounded samples: none at 3-4.5 spreads)
    gave the tail family p = nan (a gamma law of mean 0), which the false-alarm study's
    tiny-record test caught."""
    terms = (TERM_TYPES["quantization"](Q=7.7e-7), TERM_TYPES["white"](N=1.4e-6))
    model = NoiseModel(terms, {"rate": "rad/s", "time": "s"})
    reps = [np.asarray(model.simulate(4096, fs=100.0, seed=s)).ravel() for s in range(20)]
    feats = np.array([tail_features(r) for r in reps])
    assert not feats[:, 0].any()  # no replicate reaches the band
    n = np.array([4096.0])
    ref = feats.mean(axis=0)
    ens = NullEnsemble(ref={"tail": ref}, null={"tail": feats - ref}, real_scale=1.0)
    same = {"tail": tail_features(reps[0]), "spike_n": n}
    assert tail_test(same, ens)[0] == 1.0
    mixed = np.asarray(model.simulate(4096, fs=100.0, seed=99)).ravel()
    mixed[::10] *= 4.0  # a tenth of the samples far out: the record reaches the band
    heavy = {"tail": tail_features(mixed), "spike_n": n}
    assert heavy["tail"][0] > 0
    assert tail_test(heavy, ens)[0] == pytest.approx(1.0 / 21.0)
