"""Equivalent degrees of freedom and noise identification (allanite.edf)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from allantools import ci as at_ci

import allanite
from allanite import _core, edf

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
    res = allanite.avar(x, 1.0, input=input_kind, kind="overlapping", m=[1, 4, 16, 64])
    np.testing.assert_array_equal(res.alpha, alpha)


def test_hadamard_identifies_random_run_fm() -> None:
    rng = np.random.default_rng(9)
    rate = np.cumsum(np.cumsum(rng.standard_normal(20_000)))  # alpha = -4
    res = allanite.avar(rate, 1.0, kind="hadamard", m=[1, 4, 16])
    np.testing.assert_array_equal(res.alpha, -4)
    # the Allan variance cannot measure them: clipped to random-walk FM
    res2 = allanite.avar(rate, 1.0, kind="overlapping", m=[1, 4, 16])
    np.testing.assert_array_equal(res2.alpha, -2)


def test_b1_identification_with_few_points() -> None:
    """Fewer than 30 averages: the B1 ratio (and R(n)) separates the noise types."""
    rng = np.random.default_rng(31)
    agree = {}
    for alpha in (2, 0, -2):
        hits = 0
        for _ in range(20):
            phase = _power_law_phase(rng, alpha, 2001, 1)[:, 0]
            res = allanite.avar(phase, 1.0, input="angle", kind="modified", m=[100])
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
    res = allanite.avar(rng.standard_normal(5000), 1.0, taus="octave", alpha=0)
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
        res = allanite.avar(rng.standard_normal(n), 1.0, kind=kind, m=[m], alpha=0)
        lo, hi = res.var_ci(0.683)
        covered += int(lo[0] <= truth[kind] <= hi[0])
    se = math.sqrt(0.683 * 0.317 / reps)
    assert abs(covered / reps - 0.683) < 4 * se, covered / reps
