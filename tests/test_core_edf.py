"""Equivalent degrees of freedom and noise identification (allanite.variance.edf)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from allantools import ci as at_ci

import allanite
from allanite import _core
from allanite.variance import edf

SHAPES = {
    "overlapping": (2, True, False),
    "standard": (2, False, False),
    "modified": (2, True, True),
    "hadamard": (3, True, False),
    "standard_hadamard": (3, False, False),
}


def _cases() -> list[tuple[str, int, int, int]]:
    out = []
    for kind, (d, _, modified) in SHAPES.items():
        for alpha in range(2 - 2 * d + 1 if d == 2 else -4, 3):
            for m in (1, 3, 16, 50, 400):
                for n in (1000, 100_000):
                    if (m / (1 if modified else m)) + m * d <= n:
                        out.append((kind, alpha, m, n))
    return out


@pytest.mark.parametrize(("kind", "alpha", "m", "n"), _cases())
def test_greenhall_edf_agrees_with_allantools(kind: str, alpha: int, m: int, n: int) -> None:
    """Independent implementation of the same paper (allantools.ci.edf_greenhall)."""
    d, overlapping, modified = SHAPES[kind]
    if alpha < 2 - 2 * d + 1:
        pytest.skip("outside the estimator's range")
    ours = edf.greenhall_edf(alpha, d, m, n, overlapping=overlapping, modified=modified)
    try:
        theirs = at_ci.edf_greenhall(alpha, d, m, n, overlapping=overlapping, modified=modified)
    except NotImplementedError:
        pytest.skip("allantools lacks case 4 with K <= d (tested below)")
    assert ours == pytest.approx(theirs, rel=1e-9)


def test_white_pm_short_record_case_four() -> None:
    """Case 4 with K = ceil(r) <= d (not in allantools): 1/edf = (1 + 2 sum ...) / M."""
    # filter length L = 1 + d m = 21 for m = 10; C(4, 1)^2 / C(4, 2)^2 = 16 / 36
    # standard AVAR, N = 31: M = 1 + floor((31 - 21) / 10) = 2, r = 2, K = 2
    got = edf.greenhall_edf(2, 2, 10, 31, overlapping=False, modified=False)
    assert got == pytest.approx(2.0 / (1.0 + 2.0 * (1.0 - 1.0 / 2.0) * 16.0 / 36.0))
    # overlapping AVAR, N = 35: M = 1 + floor(10 (35 - 21) / 10) = 15, r = 1.5, K = 2
    got = edf.greenhall_edf(2, 2, 10, 35, overlapping=True, modified=False)
    assert got == pytest.approx(15.0 / (1.0 + 2.0 * (1.0 - 1.0 / 1.5) * 16.0 / 36.0))
    # overlapping AVAR, N = 23: M = 3, r = 0.3, K = 1: edf = M
    assert edf.greenhall_edf(2, 2, 10, 23, overlapping=True, modified=False) == pytest.approx(3.0)
    # overlapping AVAR, N = 45: M = 25, r = 2.5, K = 3 > d: Table 2, (35/18 - 1/r) / M
    got = edf.greenhall_edf(2, 2, 10, 45, overlapping=True, modified=False)
    assert got == pytest.approx(25.0 / (35.0 / 18.0 - 1.0 / 2.5))


def test_totvar_edf_formulas() -> None:
    n = 1001
    assert edf.totvar_edf(0, 10, n) == pytest.approx(1.5 * 1000 / 10)
    assert edf.totvar_edf(-1, 10, n) == pytest.approx(1.17 * 100 - 0.22)
    assert edf.totvar_edf(-2, 10, n) == pytest.approx(0.93 * 100 - 0.36)
    assert edf.totvar_edf(2, 10, n) == pytest.approx(1002 * 981 / (2 * 991))
    flicker = math.exp(math.sqrt(math.log(1000 / 20) * math.log(21 * 1000 / 4)))
    assert edf.totvar_edf(1, 10, n) == pytest.approx(flicker)
    with pytest.raises(ValueError, match="alpha"):
        edf.totvar_edf(-3, 10, n)


def test_greenhall_rejects_what_it_cannot_measure() -> None:
    with pytest.raises(ValueError, match=r"alpha \+ 2d > 1"):
        edf.greenhall_edf(-3, 2, 4, 1000, overlapping=True, modified=False)
    with pytest.raises(ValueError, match="filter length"):
        edf.greenhall_edf(0, 2, 500, 1000, overlapping=True, modified=False)


# --- Monte Carlo: the chi-square model var(v) = 2 E(v)^2 / edf -----------------------------


def _power_law_phase(rng: np.random.Generator, alpha: int, n: int, reps: int) -> np.ndarray:
    """Phase (n, reps) of pure white PM (2), white FM (0) or random-walk FM (-2) noise."""
    w = rng.standard_normal((n, reps))
    if alpha == 2:
        return w
    if alpha == 0:
        return np.cumsum(w, axis=0)
    if alpha == -2:
        return np.cumsum(np.cumsum(w, axis=0), axis=0)
    raise AssertionError(alpha)


MC_CASES = [
    ("overlapping", 0, 8),
    ("overlapping", 2, 4),
    ("overlapping", -2, 8),
    ("standard", 0, 8),
    ("modified", 2, 4),
    ("modified", 0, 8),
    ("hadamard", 0, 8),
    ("standard_hadamard", -2, 4),
]


@pytest.mark.parametrize(("kind", "alpha", "m"), MC_CASES)
def test_edf_matches_monte_carlo(kind: str, alpha: int, m: int) -> None:
    n, reps = 257, 3000
    rng = np.random.default_rng(1000 + 17 * m + alpha)
    phase = _power_law_phase(rng, alpha, n, reps)
    v = _core.variance(np.ascontiguousarray(phase), [m], kind, 1)[0]
    mean, var = float(np.mean(v)), float(np.var(v, ddof=1))
    mc_edf = 2.0 * mean**2 / var
    # standard error of the sample variance from the fourth moment, and of the mean
    mu4 = float(np.mean((v - mean) ** 4))
    rel_se = math.sqrt((mu4 / var**2 - 1.0) / reps + 4.0 * var / (reps * mean**2))
    d, overlapping, modified = SHAPES[kind]
    model = edf.greenhall_edf(alpha, d, m, n, overlapping=overlapping, modified=modified)
    assert abs(mc_edf / model - 1.0) < 4.0 * rel_se, (mc_edf, model, rel_se)


def test_totvar_edf_matches_monte_carlo_for_white_fm() -> None:
    n, reps, m = 257, 2000, 16
    rng = np.random.default_rng(77)
    phase = _power_law_phase(rng, 0, n, reps)
    v = _core.variance(np.ascontiguousarray(phase), [m], "total", 1)[0]
    mean, var = float(np.mean(v)), float(np.var(v, ddof=1))
    mu4 = float(np.mean((v - mean) ** 4))
    rel_se = math.sqrt((mu4 / var**2 - 1.0) / reps + 4.0 * var / (reps * mean**2))
    # SP1065's empirical formula is itself approximate (~10 %); both errors combined
    assert abs(2.0 * mean**2 / var / edf.totvar_edf(0, m, n) - 1.0) < 4.0 * rel_se + 0.1


# --- noise identification -------------------------------------------------------------------


def _flicker_fm_rate(rng: np.random.Generator, n: int) -> np.ndarray:
    """Flicker FM by shaping white noise with 1/sqrt(f) in the frequency domain."""
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n)
    f[0] = f[1]
    return np.fft.irfft(spec / np.sqrt(f), n)


@pytest.mark.parametrize(
    ("alpha", "input_kind"),
    [
        (2, "angle"),
        (0, "angle"),
        (-2, "angle"),
        (0, "rate"),
        (-2, "rate"),
        (2, "rate"),
        (-1, "rate"),
    ],
)
def test_lag1_identification_of_pure_noises(alpha: int, input_kind: str) -> None:
    rng = np.random.default_rng(2024 + alpha)
    n = 20_000
    if alpha == -1:
        x = _flicker_fm_rate(rng, n)
    else:
        phase = _power_law_phase(rng, alpha, n + 1, 1)[:, 0]
        x = phase if input_kind == "angle" else np.diff(phase)
    res = allanite.avar(x, fs=1.0, input=input_kind, kind="overlapping", m=[1, 4, 16, 64])
    np.testing.assert_array_equal(res.alpha, alpha)


def test_hadamard_identifies_random_run_fm() -> None:
    rng = np.random.default_rng(9)
    rate = np.cumsum(np.cumsum(rng.standard_normal(20_000)))  # alpha = -4
    res = allanite.avar(rate, fs=1.0, kind="hadamard", m=[1, 4, 16])
    np.testing.assert_array_equal(res.alpha, -4)
    # the Allan variance cannot measure them: clipped to random-walk FM
    res2 = allanite.avar(rate, fs=1.0, kind="overlapping", m=[1, 4, 16])
    np.testing.assert_array_equal(res2.alpha, -2)


def test_b1_identification_with_few_points() -> None:
    """Fewer than 30 averages: the B1 ratio (and R(n)) separates the noise types."""
    rng = np.random.default_rng(31)
    agree = {}
    for alpha in (2, 0, -2):
        hits = 0
        for _ in range(20):
            phase = _power_law_phase(rng, alpha, 2001, 1)[:, 0]
            res = allanite.avar(phase, fs=1.0, input="angle", kind="modified", m=[100])
            hits += int(res.alpha[0] == alpha)
        agree[alpha] = hits
    # 20 averages per record: B1 picks the right type in most records
    assert all(h >= 14 for h in agree.values()), agree


def test_lag1_acf_definition() -> None:
    z = np.array([1.0, 2.0, 3.0, 4.0])
    z0 = z - z.mean()
    want = np.dot(z0[:-1], z0[1:]) / np.dot(z0, z0) * 3 / 4
    assert edf.lag1_acf(z) == pytest.approx(want)
    assert edf.lag1_acf(np.ones(5)) == 0.0


def test_equivalent_dof_shapes_and_clipping() -> None:
    m = np.array([1, 2, 4])
    alpha = np.array([[2, -4], [0, 0], [-3, 1]])
    out = edf.equivalent_dof("overlapping", alpha, m, 1000)
    assert out.shape == (3, 2)
    # -4 and -3 are clipped to -2 for the Allan variance
    clip = edf.greenhall_edf(-2, 2, 1, 1000, overlapping=True, modified=False)
    assert out[0, 1] == pytest.approx(clip)
    with pytest.raises(ValueError, match="rows"):
        edf.equivalent_dof("overlapping", alpha[:2], m, 1000)
    with pytest.raises(ValueError, match="unknown kind"):
        edf.equivalent_dof("allan", alpha, m, 1000)


def test_ci_limits_follow_chi_square() -> None:
    from scipy import stats

    rng = np.random.default_rng(3)
    res = allanite.avar(rng.standard_normal(5000), fs=1.0, taus="octave", alpha=0)
    lo, hi = res.var_ci(0.9)
    np.testing.assert_allclose(lo, res.var * res.edf / stats.chi2.ppf(0.95, res.edf))
    np.testing.assert_allclose(hi, res.var * res.edf / stats.chi2.ppf(0.05, res.edf))
    assert np.all(lo < res.var)
    assert np.all(res.var < hi)


@pytest.mark.parametrize(
    "kind", ["overlapping", "standard", "modified", "hadamard", "standard_hadamard", "total"]
)
@pytest.mark.parametrize("n_phase", [10, 57, 1001])
def test_edf_is_finite_and_positive_at_every_admissible_factor(kind: str, n_phase: int) -> None:
    top = _core.max_m(kind, n_phase)
    m = np.unique(np.r_[np.arange(1, top + 1, 1 if n_phase < 100 else 13), top])
    lo = -2 if kind in ("overlapping", "standard", "modified", "total") else -4
    for alpha in range(lo, 3):
        out = edf.equivalent_dof(kind, np.full((m.size, 1), alpha), m, n_phase)
        assert np.all(np.isfinite(out)), (kind, alpha)
        assert np.all(out > 0), (kind, alpha)


@pytest.mark.parametrize("kind", ["overlapping", "modified", "hadamard", "total"])
def test_confidence_interval_coverage_for_white_fm(kind: str) -> None:
    """The 68.3 % interval covers the true white-FM value in 68.3 % of records (binomial SE)."""
    rng = np.random.default_rng(4242)
    reps, n, m = 400, 1000, 16
    truth = {"overlapping": 1.0 / m, "total": 1.0 / m, "hadamard": 1.0 / m}
    # modified AVAR of discrete white FM: sum of squared window weights / (2 m^4)
    weights = np.convolve(np.ones(m), np.r_[1.0, np.zeros(m - 1), -1.0])  # m-sample averages
    truth["modified"] = float(np.sum(np.convolve(weights, np.ones(m)) ** 2)) / (2 * m**4)
    covered = 0
    for _ in range(reps):
        res = allanite.avar(rng.standard_normal(n), fs=1.0, kind=kind, m=[m], alpha=0)
        lo, hi = res.var_ci(0.683)
        covered += int(lo[0] <= truth[kind] <= hi[0])
    se = math.sqrt(0.683 * 0.317 / reps)
    assert abs(covered / reps - 0.683) < 4 * se, covered / reps


# --------------------------------------------------------------------------------------------
# Noise identification: compiled streaming statistics, bounded memory, no variance/oracle.py


def _numpy_levels(series: np.ndarray, levels: int) -> list[float]:
    out = []
    for _ in range(levels):
        out.append(edf.lag1_acf(series))
        series = np.diff(series)
    return out


@pytest.mark.parametrize("series", ["phase", "frequency"])
@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int16, np.int32, np.int64])
def test_lag1_acf_kernel_equals_numpy_definition(series: str, dtype: type) -> None:
    """_core.lag1_acf = lag1_acf of x[::m] (or its m-averages) and its differences."""
    rng = np.random.default_rng(77)
    walk = np.cumsum(rng.standard_normal((30_001, 6)), axis=0) * 50 + 1000.0
    base = walk.astype(dtype)[::2, ::2]  # strided rows and columns, no copy
    ms = [1, 2, 5, 64, 333]
    got = np.asarray(_core.lag1_acf(base, ms, series, 4, 2)).reshape(len(ms), 3, 4)
    for t, m in enumerate(ms):
        for c in range(3):
            x = base[:, c].astype(np.float64)
            z = x[::m] if series == "phase" else np.diff(x[: (x.size - 1) // m * m + 1 : m]) / m
            np.testing.assert_allclose(got[t, c], _numpy_levels(z, 4), rtol=0, atol=1e-12)
    for threads in (1, 3, 4):  # grouping of the factors never changes a bit
        again = np.asarray(_core.lag1_acf(base, ms, series, 4, threads))
        assert np.array_equal(again.reshape(got.shape), got)
    for levels in (1, 2, 3):  # identify_alpha's lazy levels: a level's sums never change
        fewer = np.asarray(_core.lag1_acf(base, ms, series, levels, 2))
        assert np.array_equal(fewer.reshape(len(ms), 3, levels), got[:, :, :levels])


@pytest.mark.parametrize("series", ["phase", "frequency"])
def test_lag1_acf_contiguous_small_factors_equal_numpy_and_strided(series: str) -> None:
    """A contiguous float64 column (the phase of a one-channel record): its points at factors
    1 to 4 are copied with constant strides (noise_id.hpp gather_points), or read in place in
    the first pass; the statistics are those of the definition and bit for bit those of a
    strided view of the same values."""
    rng = np.random.default_rng(78)
    walk = np.cumsum(rng.standard_normal(20_003)) + 1e6  # odd length: ragged last blocks
    contiguous = walk.reshape(-1, 1)
    wide = np.zeros((walk.size, 2))
    wide[:, 1] = walk
    strided = wide[:, 1:]  # the same values, row stride 2
    ms = [1, 2, 3, 4, 7]
    got = np.asarray(_core.lag1_acf(contiguous, ms, series, 4, 1)).reshape(len(ms), 4)
    for t, m in enumerate(ms):
        z = walk[::m] if series == "phase" else np.diff(walk[: (walk.size - 1) // m * m + 1 : m])
        np.testing.assert_allclose(got[t], _numpy_levels(z, 4), rtol=0, atol=1e-12)
    again = np.asarray(_core.lag1_acf(strided, ms, series, 4, 2)).reshape(got.shape)
    assert np.array_equal(again, got)
    # one level (identify_alpha's first pass; frequency points read in place, unit and
    # other strides): the level's sums of the deeper pass, bit for bit
    for view in (contiguous, strided):
        first = np.asarray(_core.lag1_acf(view, ms, series, 1, 1)).reshape(len(ms))
        assert np.array_equal(first, got[:, 0])


def test_lag1_acf_kernel_bad_arguments() -> None:
    x = np.random.default_rng(1).standard_normal((100, 1))
    with pytest.raises(ValueError, match="levels"):
        _core.lag1_acf(x, [1], "phase", 5)
    with pytest.raises(ValueError, match="at least 1"):
        _core.lag1_acf(x, [0], "phase", 3)
    with pytest.raises(ValueError, match="difference levels"):
        _core.lag1_acf(x, [40], "frequency", 3)
    with pytest.raises(ValueError, match="series"):
        _core.lag1_acf(x, [1], "rate", 3)
    with pytest.raises(ValueError, match="at least 1"):
        edf.identify_alpha(x, np.array([0]), "overlapping")


def test_mvar_avar_ratio_kernel_equals_reference() -> None:
    """R(n) from the compiled modified and overlapping variances = reference MVAR / AVAR."""
    from allanite.variance import oracle

    rng = np.random.default_rng(12)
    phase = np.cumsum(rng.standard_normal((4001, 3)), axis=0) + 1e3 * np.arange(4001)[:, None]
    ms = [1, 2, 17, 400, 1333]
    got = np.asarray(_core.mvar_avar_ratio(phase, ms, 2))
    mvar, avar = oracle.modified_variance, oracle.overlapping_variance
    want = [[mvar(phase[:, c], m) / avar(phase[:, c], m) for c in range(3)] for m in ms]
    np.testing.assert_allclose(got, want, rtol=1e-10)
    for threads in (1, 3):
        assert np.array_equal(np.asarray(_core.mvar_avar_ratio(phase, ms, threads)), got)
    assert np.isnan(np.asarray(_core.mvar_avar_ratio(np.zeros((30, 1)), [5]))).all()
    with pytest.raises(ValueError, match="3m <= M"):
        _core.mvar_avar_ratio(phase, [1334])


def _identify_by_definition(x: np.ndarray, factors: np.ndarray, kind: str, data: str) -> np.ndarray:
    """Stable32's rule written out with numpy and variance/oracle.py (the test oracle)."""
    from allanite.variance import oracle

    shape = edf.estimator_shape(kind)
    lo, hi = (-2, 2) if kind == "total" else (2 - 2 * shape.d, 2)
    out = np.empty((factors.size, x.shape[1]), dtype=np.int64)
    for c in range(x.shape[1]):
        col = x[:, c].astype(np.float64)
        longest_acf, cap = 0, hi
        for i, m in sorted(enumerate(factors.tolist()), key=lambda im: im[1]):
            ybar = np.diff(col[: (col.size - 1) // m * m + 1 : m]) / m
            series = col[::m] if data == "phase" else ybar
            if series.size >= edf.ACF_MIN_POINTS:
                alpha = edf.acf_noise_id(series, shape.d, phase=data == "phase")
                if m >= longest_acf:
                    longest_acf, cap = m, alpha
            else:
                ratio = None
                if 3 * m <= col.size:  # second differences ignore the trend of phase data
                    av = oracle.overlapping_variance(col, m)
                    ratio = oracle.modified_variance(col, m) / av if av else None
                alpha = edf.b1_noise_id(ybar, m, ratio)
                if longest_acf:  # beyond the lag-1 range: at most the last lag-1 exponent
                    alpha = min(alpha, cap)
            out[i, c] = min(max(alpha, lo), hi)
    return out


def test_few_point_exponents_are_capped_beyond_the_lag1_range() -> None:
    factors = np.array([1, 10, 100, 1000, 3000, 50])
    points = np.array([9000, 900, 90, 9, 3, 180])
    alpha = np.array([[2, 2], [0, 1], [-1, 0], [1, -2], [2, 2], [0, 1]])
    got = edf.cap_few_point_alpha(alpha, factors, points)
    # the longest lag-1 factor is 100 (alpha -1 and 0): 1000 and 3000 are capped there
    np.testing.assert_array_equal(got, [[2, 2], [0, 1], [-1, 0], [-1, -2], [-1, 0], [0, 1]])
    assert np.array_equal(alpha[3], [1, -2])  # the input is not modified
    # nothing to cap when every factor (or none) has the lag-1 method
    np.testing.assert_array_equal(edf.cap_few_point_alpha(alpha, factors, points + 10**4), alpha)
    np.testing.assert_array_equal(edf.cap_few_point_alpha(alpha, factors, points * 0), alpha)


def test_example_record_has_no_isolated_edf_jumps() -> None:
    """B1/R(n) read the example's long taus as phase noise twice (EDF 127 and 55 among ~5)."""
    from allanite.examples import example_record

    x, fs = example_record()
    res = allanite.avar(x, fs=fs, input="angle")
    few = (res.n_samples - 1) // res.m < edf.ACF_MIN_POINTS
    assert few.sum() >= 5
    edf_few = res.edf[few]
    # beyond the lag-1 range the EDF falls with tau (fewer points, no jump back to phase noise)
    assert np.all(np.diff(edf_few) <= 0), edf_few
    assert np.all(res.alpha[few] <= res.alpha[~few][-1])


@pytest.mark.parametrize("kind", ["overlapping", "hadamard", "modified", "total"])
def test_identify_alpha_equals_the_definition(kind: str) -> None:
    """Compiled identification = the plain definition, for every noise type and both data."""
    rng = np.random.default_rng(505)
    n = 3000
    white = rng.standard_normal((n + 2, 5))
    rate = np.column_stack(
        [
            np.diff(white[:, 0])[:n],  # white PM (as rate)
            white[:n, 1],  # white FM
            np.cumsum(white[:n, 2]),  # random walk FM
            np.cumsum(np.cumsum(white[:n, 3])),  # random run FM
            white[:n, 4] + 0.01 * np.cumsum(white[:n, 4]),  # mixture
        ]
    )
    top = _core.max_m(kind, n + 1)
    factors = np.unique(np.r_[1, 2, 3, np.geomspace(1, top, 30).astype(np.int64), top])
    phase = np.asarray(_core.phase(rate, "rate"))
    got = edf.identify_alpha(phase, factors, kind, data="frequency")
    np.testing.assert_array_equal(got, _identify_by_definition(phase, factors, kind, "frequency"))
    # phase data as recorded (integer counts with a drift), R(n) from the detrended phase
    walk = np.cumsum(rate, axis=0)
    walk *= 1e5 / np.max(np.abs(walk), axis=0)
    angle = np.round(walk + 30.0 * np.arange(n)[:, None]).astype(np.int32)
    detrended = np.asarray(_core.phase(angle, "angle"))
    got = edf.identify_alpha(angle, factors, kind, data="phase", detrended=detrended)
    np.testing.assert_array_equal(got, _identify_by_definition(angle, factors, kind, "phase"))


def test_identification_memory_is_bounded() -> None:
    """No copy of the record or of a decimated series (numpy allocations traced)."""
    import tracemalloc

    x = np.random.default_rng(8).standard_normal(2_000_000)
    phase = np.asarray(_core.phase(x.reshape(-1, 1), "rate"))
    factors = np.unique(np.ceil(np.logspace(0, 6, 60)).astype(np.int64))
    tracemalloc.start()
    try:
        edf.identify_alpha(phase, factors, "hadamard", data="frequency")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 0.05 * phase.nbytes, peak  # the old path allocated 2-3 copies (32-48 MB)


@pytest.mark.parametrize("kind", ["hadamard", "modified", "standard_hadamard", "total"])
@pytest.mark.parametrize("input_kind", ["rate", "angle"])
def test_large_records_never_use_the_reference_oracle(
    kind: str, input_kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """2e5 x 3 samples: the library path is compiled only (the oracle would take minutes)."""
    from allanite.variance import oracle

    def forbidden(*args: object, **kwargs: object) -> None:
        raise AssertionError("the library path called variance/oracle.py")

    for name in dir(oracle):
        if not name.startswith("__") and callable(getattr(oracle, name)):
            monkeypatch.setattr(oracle, name, forbidden)
    rng = np.random.default_rng(200)
    x = rng.standard_normal((200_000, 3))
    res = allanite.avar(x, fs=100.0, input=input_kind, kind=kind)
    assert res.alpha.shape == res.var.shape == (res.m.size, 3)
    assert np.all(np.isfinite(res.edf))
    assert np.all(res.edf > 0)
    # white noise: white FM (rate) / white PM (angle) at the taus the lag-1 method covers
    want = 0 if input_kind == "rate" else 2
    n_series = (200_000 - 1) // res.m
    assert np.mean(res.alpha[n_series >= 1000] == want) > 0.95


# --- isolated flips of the identified noise type (issue: EDF 3801 -> 13196 -> 3031) -------------


def test_smooth_isolated_alpha_replaces_single_flips_only():
    from allanite.variance.edf import smooth_isolated_alpha

    alpha = np.array([[0], [0], [1], [0], [-1], [-1], [-2], [-1], [-1], [-2]])
    factors = np.arange(1, alpha.shape[0] + 1)
    smoothed = smooth_isolated_alpha(alpha, factors)
    # the flips at index 2 and 6 go; the step 0 -> -1 and the last value stay
    assert smoothed[:, 0].tolist() == [0, 0, 0, 0, -1, -1, -1, -1, -1, -2]
    # order of the factors does not matter
    perm = np.array([3, 0, 9, 5, 1, 8, 2, 7, 4, 6])
    np.testing.assert_array_equal(smooth_isolated_alpha(alpha[perm], factors[perm]), smoothed[perm])


def test_example_record_edf_does_not_jump_at_one_tau():
    from allanite.examples import example_record

    x, fs = example_record()
    smoothed = allanite.avar(x, fs=fs, input="angle")
    stable32 = allanite.avar(x, fs=fs, input="angle", alpha="stable32")
    flips = np.flatnonzero(smoothed.alpha != stable32.alpha)
    # Stable32's rule flips at one tau near 0.79 s in this record; the default smooths it
    assert flips.size >= 1
    assert np.any(np.isclose(stable32.tau[flips], 0.79, rtol=0.05))
    # no EDF in the default result is more than twice both its neighbours'
    edf = smoothed.edf
    inner = edf[1:-1]
    assert not np.any((inner > 2 * edf[:-2]) & (inner > 2 * edf[2:]))
    # with Stable32's rule the jump is there (the regression this guards)
    e32 = stable32.edf
    assert np.any((e32[1:-1] > 2 * e32[:-2]) & (e32[1:-1] > 2 * e32[2:]))


def test_out_of_core_smooths_like_in_memory(tmp_path):
    from allanite.examples import example_record

    x, fs = example_record()
    path = tmp_path / "x.npy"
    np.save(path, x)
    mem = allanite.avar(x, fs=fs, input="angle")
    big = allanite.avar_large(str(path), fs=fs, input="angle")
    np.testing.assert_array_equal(mem.alpha, big.alpha)


def test_unknown_alpha_string_is_refused():
    with pytest.raises(TypeError, match="stable32"):
        allanite.avar(np.random.default_rng(0).standard_normal(1000), fs=1.0, alpha="stable")


def test_rn_skipped_only_where_the_cap_decides(monkeypatch: pytest.MonkeyPatch) -> None:
    """identify_alpha skips R(n) where cap_few_point_alpha's cap (<= 1) decides: the result
    equals the one with every ratio computed, and white FM needs no ratio at all."""
    rng = np.random.default_rng(31)
    n = 40_000
    records = {
        "white FM": _core.phase(rng.standard_normal((n, 2)), "rate"),
        "white PM": rng.standard_normal((n, 2)),
        "mixed": np.column_stack([rng.standard_normal(n), np.cumsum(rng.standard_normal(n))]),
    }
    factors = np.unique(np.geomspace(1, n // 4, 40).astype(np.int64))
    calls: list[list[int]] = []
    real_ratios = edf._mvar_avar_ratios

    def counted(phase: np.ndarray, ms: list[int], threads: int) -> dict:
        calls.append(ms)
        return real_ratios(phase, ms, threads)

    monkeypatch.setattr(edf, "_mvar_avar_ratios", counted)
    for name, x in records.items():
        for kind in ("overlapping", "hadamard", "total"):
            for data in ("frequency", "phase"):
                calls.clear()
                lazy = edf.identify_alpha(x, factors, kind, data=data)
                lazy_calls = len(calls)
                with monkeypatch.context() as m:
                    m.setattr(edf, "_uncapped", lambda pending, *_: pending)
                    full = edf.identify_alpha(x, factors, kind, data=data)
                assert np.array_equal(lazy, full), (name, kind, data)
                if name == "white FM" and data == "frequency":
                    assert lazy_calls == 0, (kind, calls)
