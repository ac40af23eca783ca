"""The diagnosis null of long records: exact tau covariance, rescaled short replicates, decimation.

Every check compares the cheap null with what it stands for (Monte Carlo of the real length or
rate, or a known law), with fixed seeds and tolerances from the estimates' own uncertainty.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from allanite.diagnosis.decimation import COARSE_LENGTH, decimation
from allanite.diagnosis.null import NullEnsemble, rescaled, rescaled_log_gamma
from allanite.diagnosis.scaled_null import FULL_REPLICATES_MAX, uses_scaled_null
from allanite.diagnosis.tau_view import (
    build_tau_model,
    gaussian_tau_null,
    octave_factors,
    tau_features,
)
from allanite.diagnosis.time_view import TimePlan, time_features, time_plan
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

UNITS = {"rate": "deg/s", "time": "s"}


def model(*extra) -> NoiseModel:  # type: ignore[no-untyped-def]
    t = TERM_TYPES
    return NoiseModel((t["white"](N=0.05), t["flicker"](B=0.01), t["rrw"](K=0.0008), *extra), UNITS)


def test_gaussian_tau_null_matches_monte_carlo_and_T_is_calibrated() -> None:
    """Mean and spread of log AVAR and the law of T from the model equal Monte Carlo's."""
    fs, n, reps = 100.0, 2**14, 240
    mod = model()
    m = octave_factors(n)
    ref, avar, draws = gaussian_tau_null(mod, m, fs, n, n_draw=4000, seed=3)
    x = mod.simulate(n, fs=fs, n_channels=reps, seed=11)
    mc = np.stack([tau_features(np.ascontiguousarray(x[:, j]), fs, m) for j in range(reps)])
    sd_mc = mc.std(axis=0, ddof=1)
    # mean: within 3.5 standard errors at every tau (familywise over ~11 taus)
    z = (mc.mean(axis=0) - ref) / (sd_mc / np.sqrt(reps))
    assert np.all(np.abs(z) < 3.5), z
    # spread: the ratio of standard deviations within the 99.9 % chi-square band of reps - 1 dof
    lo, hi = (np.sqrt(stats.chi2.ppf(q, reps - 1) / (reps - 1)) for q in (0.0005, 0.9995))
    ratio = sd_mc / draws.std(axis=0, ddof=1)
    assert np.all((ratio > lo) & (ratio < hi)), ratio
    # T of the Monte Carlo records against the draws' covariance: mean near T0, p-values uniform
    ens = NullEnsemble(
        ref={"log_avar": ref, "avar_lin": avar}, null={"log_avar": draws}, real_scale=1.0
    )
    ts, ps = [], []
    for j in range(reps):
        tm = build_tau_model({"log_avar": mc[j]}, ens, m / fs, 1.0 / fs, avar, n / fs, loo=False)
        ts.append(tm.statistic())
        ps.append(tm.p_value())
    se = np.std(ts, ddof=1) / np.sqrt(reps)
    assert abs(np.mean(ts) - tm.t0) < 3.5 * se
    rejected = np.mean(np.asarray(ps) < 0.05)
    assert rejected < 0.05 + 3.0 * np.sqrt(0.05 * 0.95 / reps)
    assert stats.kstest(ps, "uniform").pvalue > 0.001


def test_rescaled_log_mean_matches_longer_replicates() -> None:
    """Log of a mean over k pieces: the short null, rescaled, is the null of 16x more pieces."""
    rng = np.random.default_rng(5)
    k_s, k, n_s, n_l, bins = 64, 1024, 200, 400, 50

    def feature(pieces: int, count: int) -> np.ndarray:
        return np.log(rng.exponential(size=(count, pieces, bins)).mean(axis=1))

    ens = NullEnsemble.from_model([{"f": f} for f in feature(k_s, n_s)])
    ref, null = rescaled(ens, "f", k_s / k, log_mean=True)
    long = feature(k, n_l)
    # the reference is the long mean (the short mean is biased by (var_s - var)/2 = 0.007,
    # about four standard errors of the long mean, so dropping the correction fails)
    err = np.sqrt(long.var(axis=0, ddof=1) / n_l + ens.null["f"].var(axis=0, ddof=1) / n_s**2)
    z = (long.mean(axis=0) - ref.mean()) / (err / np.sqrt(bins))
    assert np.all(np.abs(z.mean()) < 3.0)
    # the null spread is the long spread plus the reference's own error
    expected = np.sqrt(long.var(axis=0, ddof=1).mean() + 1.0 / (k_s * n_s))
    assert null.std(axis=0, ddof=1).mean() == pytest.approx(expected, rel=0.03)


def test_rescaled_rejects_bad_ratio() -> None:
    ens = NullEnsemble.from_model([{"f": np.zeros(3) + j} for j in range(20)])
    with pytest.raises(ValueError, match="ratio"):
        rescaled(ens, "f", 1.5, log_mean=False)


def test_decimation_factor_respects_time_scales() -> None:
    n, fs = 2**23, 1000.0
    assert decimation(model(), n, fs) * COARSE_LENGTH == n
    # a 50 Hz line must stay below a fifth of the coarse rate: D <= 1000 / 250
    assert decimation(model(TERM_TYPES["sine"](amplitude=0.1, frequency=50.0)), n, fs) == 4
    # spikes are not rate-free: no decimation
    assert decimation(model(TERM_TYPES["spikes"](amplitude=1.0, rate=0.1)), n, fs) == 1
    assert not uses_scaled_null(model(), FULL_REPLICATES_MAX)
    assert uses_scaled_null(model(), FULL_REPLICATES_MAX + 1)
    warm = TERM_TYPES["warmup"](amplitude=0.1, tau_w=60.0, duration=600.0)
    assert not uses_scaled_null(model(warm), 2**22)


def test_window_statistics_of_decimated_replicates_match_the_real_rate() -> None:
    """level, jump and dyn spreads: records at fs/8 over the same duration equal those at fs."""
    fs, n, d, reps = 1000.0, 2**17, 8, 60
    mod = model()
    plan = time_plan(n)
    plan_d = TimePlan(plan.n_windows, plan.length // d, (plan.length // d) // 16)
    full = mod.simulate(n, fs=fs, n_channels=reps, seed=21)
    coarse = mod.simulate(n // d, fs=fs / d, n_channels=reps, seed=22)
    f = [time_features(np.ascontiguousarray(full[:, j]), plan) for j in range(reps)]
    c = [time_features(np.ascontiguousarray(coarse[:, j]), plan_d) for j in range(reps)]
    # F test of the pooled spreads over the windows (windows share the law up to the ends)
    lo, hi = stats.f.ppf([0.0005, 0.9995], reps - 1, reps - 1)
    for name in ("level", "jump", "dyn"):
        a = np.stack([x[name] for x in f])
        b = np.stack([x[name] for x in c])
        ratio = a.var(axis=0, ddof=1).mean() / b.var(axis=0, ddof=1).mean()
        assert lo < ratio < hi, (name, ratio)


def test_rescaled_log_gamma_moves_mean_spread_and_skewness() -> None:
    """Log of a mean of exponentials: the mapped short null has the long law's three moments."""
    rng = np.random.default_rng(13)
    k_s, k, n_s, n_l, bins = 8, 128, 400, 400, 40

    def feature(pieces: int, count: int) -> np.ndarray:
        return np.log(rng.exponential(size=(count, pieces, bins)).mean(axis=1))

    ens = NullEnsemble.from_model([{"f": f} for f in feature(k_s, n_s)])
    ref, null = rescaled_log_gamma(ens, "f", k_s / k)
    long = feature(k, n_l)
    # mean (pooled over bins): the short mean is biased by ~(1/8 - 1/128)/2 = 0.06 against it
    se = np.sqrt(long.var(ddof=1) / (n_l * bins) + ens.null["f"].var(ddof=1) / (n_s * bins))
    assert abs(long.mean() - ref.mean()) < 3.5 * se
    # spread: the long spread plus the reference error of n_s short replicates
    expected = np.sqrt(long.var(axis=0, ddof=1).mean() + 1.0 / (k_s * n_s))
    assert null.std(axis=0, ddof=1).mean() == pytest.approx(expected, rel=0.03)
    # skewness ~ -1/sqrt(k): pooled over bins, within 3.5 standard errors (sqrt(6 / count));
    # plain scaling keeps the short skewness (about -0.37) and fails
    count = null.size
    skew_null = stats.skew(null.ravel())
    skew_long = stats.skew((long - long.mean(axis=0)).ravel())
    assert abs(skew_null - skew_long) < 3.5 * np.sqrt(6.0 / count + 6.0 / long.size)
    assert abs(stats.skew(ens.null["f"].ravel()) - skew_long) > 3.5 * np.sqrt(6.0 / count)


def test_scaled_null_is_the_same_for_any_number_of_worker_threads(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Replicate batches run on threads (seeded by their first replicate, collected in order):
    the diagnosis of a long record with a gap, re-analysis included, must not depend on it."""
    import json

    import allanite.diagnosis.scaled_null as sn
    from allanite.diagnosis import diagnose

    n = 2 * FULL_REPLICATES_MAX
    real = model().without("white").plus(TERM_TYPES["white"](N=0.06))
    x = np.asarray(real.simulate(n, fs=1000.0, seed=1), dtype=np.float64).ravel()
    shared = []
    adding = sn.ReplicateStore.adding

    def spy(self, added):  # type: ignore[no-untyped-def]
        shared.append([t.type for t in added.terms])
        return adding(self, added)

    monkeypatch.setattr(sn.ReplicateStore, "adding", spy)
    out = []
    steps: list[tuple[str, int, int]] = []
    # threads, and the memory kept for the re-analysis (none: every block simulated again)
    for workers, budget in ((1, sn.SHARED_BYTES), (3, sn.SHARED_BYTES), (2, 0)):
        monkeypatch.setattr(sn, "WORKERS", workers)
        monkeypatch.setattr(sn, "SHARED_BYTES", budget)
        d = diagnose(
            x, model(), fs=1000.0, units="deg/s", n_mc=20, seed=3,
            progress=(lambda *step: steps.append(step)) if not out else None,
        )  # fmt: skip
        out.append(json.dumps(d.to_dict(), sort_keys=True, default=str))
    assert d.significant, "the record has a gap, so the re-analysis ran too"
    # every long phase reports, the replicate phases about ten times each
    stages = [s for s, _, _ in steps]
    for stage in ("null replicates", "features of the record", "fitting candidate effects",
                  "re-analysis with the effects"):  # fmt: skip
        assert stage in stages, stage
    assert stages.count("null replicates") >= 10
    assert stages.count("re-analysis with the effects") >= 10
    assert ("re-analysis with the effects", 40, 40) in steps
    assert shared == [["white"]] * 3, "the re-analysis added the effect to the null's replicates"
    assert out[0] == out[1] == out[2]


def test_shared_replicates_with_added_effects_are_replicates_of_the_augmented_model() -> None:
    """The re-analysis adds the effects' own streams to the null's replicate blocks: each block
    is the kept block plus one of the effects (seeded ``ADDED_SEED`` on), and in law a
    replicate of the model with the effects (N 0.05 -> hypot(0.05, 0.04)): the mean square of
    its first differences agrees with fresh replicates of that model within their error."""
    from allanite.diagnosis.inputs import simulate_model
    from allanite.diagnosis.scaled_null import ADDED_SEED, ReplicateStore

    n, fs, k, seed = 2**15, 1000.0, 16, 5
    base = model()
    added = NoiseModel((TERM_TYPES["white"](N=0.04),), UNITS)
    combined = base.without("white").plus(TERM_TYPES["white"](N=float(np.hypot(0.05, 0.04))))
    store = ReplicateStore(base)
    kept = store.simulator(lambda m: m)(n, fs, seed, k)
    assert store.kept_bytes == kept.nbytes
    block = store.adding(added).simulator(lambda m: m)(n, fs, seed, k)
    np.testing.assert_array_equal(
        block, kept + simulate_model(added, n, fs, seed + ADDED_SEED, n_channels=k)
    )
    assert store.kept_bytes == kept.nbytes, "the re-analysis keeps nothing of its own"
    fresh = simulate_model(combined, n, fs, 99, n_channels=k)
    d2 = [np.mean(np.diff(b, axis=0) ** 2, axis=0) for b in (block, fresh, kept)]
    # k channels of n - 1 differences: the mean square has relative sd ~ sqrt(3 / (k n))
    se = np.sqrt(3.0 / (k * n)) * d2[1].mean()
    assert abs(d2[0].mean() - d2[1].mean()) < 4 * np.sqrt(2.0) * se
    assert abs(d2[2].mean() - d2[1].mean()) > 20 * se  # the base alone lacks the effect
    # a budget of 0 keeps nothing, and the blocks are the same
    none = ReplicateStore(base, budget=0)
    np.testing.assert_array_equal(none.adding(added).simulator(lambda m: m)(n, fs, seed, k), block)
    assert none.kept_bytes == 0
    with pytest.raises(ValueError, match="budget"):
        ReplicateStore(base, budget=-1)


def test_long_record_block_kurtosis_is_judged_piece_by_piece(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """White noise + a rate ramp, 300 000 samples, against its own model (a null record).

    Over the whole record the 8-sample block means follow the ramp (the uniform law's excess
    kurtosis -1.2) while the short replicates of the scaled null hold a ramp's short stretch:
    judged whole, p was 1e-140 and the record a false alarm (the false-alarm study's smallest
    reproducer); judged piece by piece, as the replicates are, it is a null record.
    """
    import allanite
    import allanite.diagnosis.analysis as analysis
    from allanite.diagnosis.scaled_null import piecewise_block_kurtosis

    mod = NoiseModel((TERM_TYPES["white"](N=0.01), TERM_TYPES["ramp"](R=4.5e-4)), UNITS)
    x = mod.simulate(300_000, fs=100.0, seed=900)
    assert uses_scaled_null(mod, x.size)
    d = allanite.diagnose(x, mod, fs=100.0, units="deg/s", n_mc=60)
    # a null record: the family at its own level (alpha / 3 / number of time statistics)
    assert d.time.family_p["kurt_lf"] > 0.05 / 3 / 8
    assert not d.significant
    # the whole-record statistic is the uniform law of the ramp's whole span; the pieces' is
    # that of the short replicates (mean of two pieces: within 5 of its standard errors)
    from allanite.diagnosis.scaled_null import SHORT_LENGTH
    from allanite.diagnosis.time_view import block_kurtosis

    n_used = (x.size // 32) * 32
    whole_k = block_kurtosis(x[:n_used].reshape(32, -1), 8)
    reps = mod.simulate(SHORT_LENGTH, fs=100.0, n_channels=16, seed=5)
    k = np.array([piecewise_block_kurtosis(reps[:, i], 8) for i in range(16)])
    piece_k = piecewise_block_kurtosis(x, 8)
    assert abs(piece_k - k.mean()) < 5 * k.std(ddof=1) / np.sqrt(2)
    assert whole_k < k.mean() - 10 * k.std(ddof=1)  # 15 of them: the p of 1e-140
    # control: judged whole (the piecewise statistic replaced by the whole record's), p collapses
    monkeypatch.setattr(
        analysis,
        "piecewise_block_kurtosis",
        lambda y, b: block_kurtosis(y[:n_used].reshape(32, -1), b),
    )
    whole = allanite.diagnose(x, mod, fs=100.0, units="deg/s", n_mc=60)
    assert whole.time.family_p["kurt_lf"] < 1e-6
