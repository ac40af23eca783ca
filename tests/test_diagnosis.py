"""Sim-to-real diagnosis: bad input, mechanics of the three views, attribution, held-out check.

Statistical cases use fixed seeds; parameter checks use the fit's own uncertainty.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from allanite.diagnosis import Diagnosis, diagnose
from allanite.diagnosis.null import chi2_like_sf, gumbel_sf
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

FS = 100.0
N = 2**15
UNITS = {"rate": "deg/s", "time": "s"}


def term(kind: str, **params: float):
    return TERM_TYPES[kind](**params)


@pytest.fixture(scope="module")
def base() -> NoiseModel:
    return NoiseModel(
        (term("white", N=0.05), term("flicker", B=0.005), term("rrw", K=0.001)), UNITS
    )


def run(real, sim, **kw) -> Diagnosis:
    kw.setdefault("n_mc", 60)
    kw.setdefault("units", "deg/s")
    return diagnose(real, sim, fs=FS, **kw)


# --- bad input ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def null_record(base: NoiseModel) -> np.ndarray:
    return base.simulate(N, fs=FS, seed=11)


def test_units_mismatch_is_an_error(base, null_record):
    with pytest.raises(ValueError, match="unit mismatch"):
        diagnose(null_record, base, fs=FS, units="rad/s", n_mc=20)


def test_sample_rate_mismatch_is_an_error(null_record):
    with pytest.raises(ValueError, match="sample-rate mismatch"):
        diagnose(null_record, null_record, fs=FS, sim_fs=200.0, n_mc=20)


def test_too_short_record_is_an_error(base):
    with pytest.raises(ValueError, match="too short"):
        diagnose(np.zeros(100), base, fs=FS, n_mc=20)


def test_short_sim_record_is_an_error(null_record):
    with pytest.raises(ValueError, match="shorter than the real"):
        diagnose(null_record, null_record[: N // 2], fs=FS, n_mc=20)


@pytest.mark.parametrize("where", ["real", "sim"])
def test_nan_is_an_error(null_record, where):
    bad = null_record.copy()
    bad[123] = np.nan
    real, sim = (bad, null_record) if where == "real" else (null_record, bad)
    with pytest.raises(ValueError, match="NaN"):
        diagnose(real, sim, fs=FS, n_mc=20)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"holdout": 1.5}, "holdout"),
        ({"holdout": 0.99}, "each part"),
        ({"n_mc": 5}, "n_mc"),
        ({"significance": 0.7}, "significance"),
    ],
)
def test_bad_options(base, null_record, kwargs, message):
    with pytest.raises(ValueError, match=message):
        diagnose(null_record, base, fs=FS, **kwargs)


def test_alpha_is_the_deprecated_name_of_significance(base, null_record):
    with pytest.warns(DeprecationWarning, match="significance="):
        old = diagnose(null_record, base, fs=FS, n_mc=20, alpha=0.1)
    new = diagnose(null_record, base, fs=FS, n_mc=20, significance=0.1)
    assert old.p_value == new.p_value
    assert old.meta["significance"] == new.meta["significance"] == 0.1
    with pytest.raises(TypeError, match="give significance= only"):
        diagnose(null_record, base, fs=FS, n_mc=20, alpha=0.1, significance=0.2)


def test_fs_is_keyword_only_and_a_record_brings_its_own(base, null_record):
    from allanite.io import Record

    with pytest.raises(TypeError):
        diagnose(null_record, base, FS)  # type: ignore[misc]
    with pytest.raises(TypeError, match="fs"):
        diagnose(null_record, base)
    record = Record(samples=null_record[:, None], fs=FS, input="rate", units="deg/s")
    from_record = diagnose(record, base, n_mc=20)
    from_array = diagnose(null_record, base, fs=FS, units="deg/s", n_mc=20)
    assert from_record.p_value == from_array.p_value
    with pytest.raises(ValueError, match="contradicts"):
        diagnose(record, base, fs=2 * FS, n_mc=20)


def test_multichannel_real_needs_one_channel(base, null_record):
    with pytest.raises(ValueError, match="one channel"):
        diagnose(np.column_stack([null_record, null_record]), base, fs=FS, n_mc=20)


def test_bad_fs(base, null_record):
    with pytest.raises(ValueError, match="fs"):
        diagnose(null_record, base, fs=-1.0)


# --- calibration helpers -----------------------------------------------------------------------
def test_tail_laws_match_their_targets():
    rng = np.random.default_rng(5)
    chi = rng.chisquare(12, size=4000)
    # P(chi2_12 > 26.2) = 0.01: the matched law from 4000 draws reproduces it (MC error ~0.2)
    assert chi2_like_sf(26.217, chi) == pytest.approx(0.01, abs=0.003)
    maxima = np.abs(rng.standard_normal((4000, 30))).max(axis=1)
    sample = np.abs(rng.standard_normal((20000, 30))).max(axis=1)
    q = float(np.quantile(sample, 0.99))
    # the Gumbel fit of a max of 30 |normals| has a small shape bias: 1 % within a factor 2
    assert 0.005 < gumbel_sf(q, maxima) < 0.02


# --- null case ---------------------------------------------------------------------------------
def test_null_case_is_not_significant(base, null_record):
    d = run(null_record, base, holdout=0.5)
    assert not d.significant
    assert d.attribution == []
    assert d.holdout is None
    assert d.p_value > 0.05
    assert d.statistic >= 0.0
    assert d.tau.correlation.shape == (d.tau.tau.size, d.tau.tau.size)
    # adjacent octaves are positively correlated (about 0.5 for white noise)
    assert np.all(np.diag(d.tau.correlation, 1)[:4] > 0.2)


# --- clear effects -----------------------------------------------------------------------------
def test_sine_line_located_and_attributed(base):
    truth = term("sine", amplitude=0.15, frequency=7.3)
    real = base.plus(truth).simulate(N, fs=FS, seed=21)
    d = run(real, base)
    assert d.significant
    assert d.frequency.lines, "the line must be detected"
    assert d.frequency.lines[0].frequency_hz == pytest.approx(7.3, rel=0.02)
    best = d.best
    assert best is not None
    assert best.effect == "sine"
    sigma = best.params_sigma["amplitude"]
    assert abs(best.params["amplitude"] - 0.15) < 4 * sigma
    assert best.shrinkage > 0.8
    assert best.consistent_after


def test_aliased_line_is_found_at_its_alias(base):
    # 83 Hz sampled at 100 Hz appears at 17 Hz
    truth = term("sine", amplitude=0.15, frequency=83.0)
    real = base.plus(truth).simulate(N, fs=FS, seed=22, allow_aliasing=True)
    d = run(real, base, effects=["sine", "white"])
    line = d.frequency.lines[0]
    assert line.frequency_hz == pytest.approx(17.0, rel=0.02)
    assert any(abs(a - 83.0) < 0.02 * 83.0 for a in line.aliases_hz)


def test_white_noise_too_small_in_the_sim(base):
    truth_n = 0.1  # the sim's N is 2x too small
    real = NoiseModel(
        (term("white", N=truth_n), term("flicker", B=0.005), term("rrw", K=0.001)), UNITS
    ).simulate(N, fs=FS, seed=23)
    d = run(real, base, holdout=0.5)
    assert d.significant
    assert d.tau.bands_s
    assert d.tau.bands_s[0][0] <= 0.01 <= d.tau.bands_s[0][1]
    best = d.best
    assert best is not None
    assert best.effect in ("rescale:white", "white")
    # adding white noise and rescaling it are the same model: equal scores, so each is listed
    # as the other's indistinguishable alternative, and nothing else is
    twin = {"white", "rescale:white"} - {best.effect}
    assert set(best.alternatives) == twin
    n_fit = best.params["N"]
    n_added = truth_n if best.effect == "rescale:white" else np.sqrt(truth_n**2 - 0.05**2)
    sigma_n = best.params_sigma["N"]
    assert abs(n_fit - n_added) < 4 * sigma_n
    assert best.shrinkage > 0.8
    assert best.consistent_after
    assert d.holdout is not None
    assert d.holdout.gap_before > 0
    assert abs(d.holdout.shrinkage - best.shrinkage) < 0.15


def test_bias_step_is_localised(base):
    n = N
    real = base.simulate(n, fs=FS, seed=24)
    t_step = 0.6 * n / FS
    real[int(0.6 * n) :] += 0.5
    d = run(real, base)
    assert d.significant
    assert d.time.change_points_s
    assert any(abs(t - t_step) < d.time.window_s for t in d.time.change_points_s)
    assert any(a <= t_step <= b for a, b in d.time.segments_s)
    assert d.best is not None
    assert d.best.effect == "step"


def test_rate_random_walk_wander_is_not_a_step(base):
    # a real sensor with 15x the sim's K wanders: the window means drift far from the record
    # mean near its ends; the random walk itself must explain that level evidence
    real = NoiseModel(
        (term("white", N=0.05), term("flicker", B=0.005), term("rrw", K=0.015)), UNITS
    ).simulate(N, fs=FS, seed=31)
    d = run(real, base)
    assert d.significant
    assert d.best is not None
    assert d.best.effect in ("rrw", "rescale:rrw")
    assert "level" not in d.best.evidence["unexplained"]


def test_warm_up_is_not_a_staircase_of_steps(base):
    duration = N / FS
    warm = term("warmup", amplitude=1.0, tau_w=0.05 * duration, duration=duration)
    real = base.simulate(N, fs=FS, seed=32) + NoiseModel((warm,), UNITS).simulate(N, fs=FS, seed=1)
    d = run(real, base)
    assert d.significant
    assert d.best is not None
    assert d.best.effect == "warmup"
    tau_w = d.best.params["tau_w"]
    assert 0.5 * warm.tau_w < tau_w < 2.0 * warm.tau_w
    steps = [a for a in d.attribution if a.effect == "step"]
    # the staircase a step needs to follow the exponential pays two parameters per extra step
    assert not steps or steps[0].evidence["level_shape_misfit"] > 2 * 3.84


def test_added_level_variance_matches_the_exact_random_walk():
    from allanite.diagnosis.time_view import added_level_variance

    n, windows, k = 512, 16, 0.3
    rrw = term("rrw", K=k)
    got = added_level_variance(rrw, FS, n, windows, n_rep=4000, seed=3)
    # exact: the sampled walk r[k] = r[k-1] + K sqrt(dt) w[k] is a linear map of i.i.d.
    # innovations, and so is level_w = (mean over window w) - (record mean); its variance is
    # the sum of the squared coefficients times K^2 dt
    length = n // windows
    avg = np.zeros((windows, n))
    for w in range(windows):
        avg[w, w * length : (w + 1) * length] = 1.0 / length
    level = avg - np.full(n, 1.0 / n)
    exact = np.sum((level @ np.tril(np.ones((n, n)))) ** 2, axis=1) * k**2 / FS
    # Monte Carlo variance of a variance from 4000 Gaussian replicates: relative sd sqrt(2/4000)
    np.testing.assert_allclose(got, exact, rtol=4 * np.sqrt(2 / 4000))


def test_spikes_are_found_and_attributed(base):
    real = base.simulate(N, fs=FS, seed=25)
    where = np.array([1000, 9000, 17000, 25000, 31000])
    real[where] += np.array([4.0, -4.0, 4.0, 4.0, -4.0])
    d = run(real, base)
    assert d.significant
    found = np.round(np.array(d.time.spike_times_s) * FS).astype(int)
    assert set(where) <= set(found.tolist())
    assert d.best is not None
    assert d.best.effect == "spikes"


def test_simulated_record_as_sim(base):
    sim = base.simulate(N, fs=FS, seed=26)
    real = base.plus(term("sine", amplitude=0.15, frequency=11.0)).simulate(N, fs=FS, seed=27)
    d = run(real, sim, effects=["sine", "white", "markov"])
    assert d.meta["sim"] == "record"
    assert d.frequency.lines[0].frequency_hz == pytest.approx(11.0, rel=0.02)
    assert d.best is not None
    assert d.best.effect == "sine"


def test_second_record_holdout_and_json(base):
    model = base.plus(term("markov", sigma=0.08, tau_c=1.0))
    real = model.simulate(N, fs=FS, seed=28)
    second = model.simulate(N, fs=FS, seed=29)
    d = run(real, base.to_json(), holdout=second)
    assert d.significant
    assert d.holdout is not None
    assert d.holdout.source == "record"
    data = json.loads(d.to_json())
    assert set(data) >= {"gap", "where", "attribution", "holdout"}
    assert set(data["gap"]) >= {"statistic", "p_value", "significant"}
    assert set(data["where"]) >= {"tau_bands_s", "frequency_lines_hz", "time_segments_s"}
    first = data["attribution"][0]
    assert set(first) >= {
        "effect",
        "params",
        "gap_before",
        "gap_after",
        "shrinkage",
        "consistent_after",
    }
    scores = [a["score"] for a in data["attribution"]]
    assert scores == sorted(scores)
    assert isinstance(data["holdout"]["shrinkage"], float)


def test_diagnosis_figure(base, null_record):
    pytest.importorskip("matplotlib")
    from allanite.plot.diagnosis import diagnosis_figure

    d = run(null_record, base, n_mc=20)
    fig = diagnosis_figure(d)
    assert len(fig.axes) == 3


@pytest.mark.slow
def test_false_alarm_rate_is_calibrated(base):
    """30 null records: false alarms ~ Binomial(30, <= 0.05); 6 or more has probability 0.2 %."""
    from scipy import stats

    n_trials = 30
    alarms = 0
    tau_p = []
    for i in range(n_trials):
        real = base.simulate(2**13, fs=FS, seed=1000 + i)
        d = diagnose(real, base, fs=FS, n_mc=40, seed=2000 + i)
        alarms += d.significant
        tau_p.append(d.tau.p_value)
    assert alarms <= 5
    # the tau-view p-values are not piled up at small values (KS against uniform, 1 % level)
    assert stats.kstest(tau_p, "uniform").pvalue > 0.01
