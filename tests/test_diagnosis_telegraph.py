"""The telegraph's two-level test: two levels against the Gaussian twin of the same spectrum.

Fixed seeds; each test has a control (the Gaussian twin, a Gauss-Markov process of the same
standard deviation and correlation time, in place of the telegraph; the null without the
effects already chosen; the twin at the fit alone instead of every plausible twin).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from scipy import stats

import allanite.diagnosis.attribution as attribution
import benchmark_module
from allanite.diagnosis import diagnose
from allanite.diagnosis.attribution import TWIN, _refuted_twins
from allanite.diagnosis.two_level import (
    MAX_BLOCKS,
    MIN_BLOCKS,
    matched_block,
    two_level_context,
    two_level_p,
    with_set,
)
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES
from test_diagnosis_pairs import fit_half

UNITS = {"rate": "deg/s", "time": "s"}
T = TERM_TYPES
FS, N = 100.0, 2**15
#: the evidence level of the diagnosis (significance 0.05 over its eight pieces of evidence)
LEVEL = 0.05 / 8


def base_model() -> NoiseModel:
    """The validation suite's MEMS-like gyro (white, quantization, flicker, random walk)."""
    model: NoiseModel = benchmark_module.load("validate_diagnosis").base_model(FS)
    return model


def _record(slow: object, seed: int) -> np.ndarray:
    """Base sensor + extra white noise (N 0.0185) + a slow process ``slow``."""
    x = base_model().simulate(N, fs=FS, seed=seed)
    for k, term in enumerate((T["white"](N=0.0185), slow)):
        one = NoiseModel((term,), UNITS).simulate(N, fs=FS, seed=seed + 7 + k, allow_aliasing=True)
        x = x + one
    return np.asarray(x, dtype=np.float64).ravel()


@pytest.fixture(scope="module")
def context() -> dict[str, object]:
    """The sensor replicates of the test (one set, reused with each record's block means)."""
    x = _record(T["telegraph"](amplitude=0.08, tau_c=3.0), seed=11)
    return two_level_context(x, base_model(), FS, seed=5)


def _p(x: np.ndarray, ctx: dict[str, object], amplitude: float = 0.08, tau_c: float = 3.0):  # type: ignore[no-untyped-def]
    means = x.reshape(-1, 8).mean(axis=1)
    return two_level_p(T["telegraph"](amplitude=amplitude, tau_c=tau_c), {**ctx, "means": means})


def test_matched_block_follows_the_correlation_time() -> None:
    assert matched_block(3.0, FS, N) == 72  # 0.75 s rounded to 8-sample blocks
    assert matched_block(0.01, FS, N) == N // MAX_BLOCKS  # at most MAX_BLOCKS blocks
    assert matched_block(100.0, FS, N) is None  # fewer than MIN_BLOCKS blocks
    assert N // matched_block(3.0, FS, N) >= MIN_BLOCKS  # type: ignore[operator]


def test_two_levels_shown_for_a_telegraph_not_for_its_gaussian_twin(context) -> None:  # type: ignore[no-untyped-def]
    """A telegraph (+-0.08, 3 s) under white noise of twice its block-mean spread at T_c/4.

    Its block-mean kurtosis alone stands out by ~2 sigma; the likelihood ratio of two levels
    shows it far below the evidence level, while the Gaussian twin stays at chance.
    """
    tele = _p(_record(T["telegraph"](amplitude=0.08, tau_c=3.0), seed=11), context)
    twin = _p(_record(T["markov"](sigma=0.08, tau_c=3.0), seed=11), context)
    assert tele is not None
    assert twin is not None
    assert tele[0] < LEVEL / 10
    assert tele[1] > LEVEL  # the telegraph explains what it shows
    assert twin[0] > LEVEL


def test_two_level_null_is_calibrated_on_gaussian_twins(context) -> None:  # type: ignore[no-untyped-def]
    """p_gauss of 24 Gauss-Markov records: uniform under the null.

    At most the binomial 99.9 % quantile of them below 0.1 (the normal tail is conservative
    for the ratio's lighter upper tail, so fewer are expected), none below the evidence level
    but with the binomial allowance, and at least the binomial 0.1 % quantile below 0.9 (a
    null too wide would put them all above).
    """
    p = np.array(
        [
            _p(_record(T["markov"](sigma=0.08, tau_c=3.0), seed=100 + 3 * k), context)[0]  # type: ignore[index]
            for k in range(24)
        ]
    )
    assert np.sum(p < 0.1) <= stats.binom.isf(1e-3, p.size, 0.1)
    assert np.sum(p < LEVEL) <= stats.binom.isf(1e-3, p.size, LEVEL)
    assert np.sum(p < 0.9) >= stats.binom.ppf(1e-3, p.size, 0.9)


def test_too_short_a_record_for_the_correlation_time_gives_no_test(context) -> None:  # type: ignore[no-untyped-def]
    x = _record(T["telegraph"](amplitude=0.08, tau_c=3.0), seed=11)
    assert _p(x, context, tau_c=100.0) is None


def test_twin_penalised_only_when_two_levels_are_shown() -> None:
    """The Gauss-Markov attribution pays ``-2 ln p_gauss`` next to a telegraph that showed
    its two levels at a matching correlation time; a distant one or one not shown leaves it."""
    from dataclasses import replace

    from allanite.diagnosis.attribution import Attribution

    def att(effect: str, tau_c: float, p_gauss: float | None = None) -> Attribution:
        ev: dict[str, object] = {"explained": [], "unexplained": []}
        if p_gauss is not None:
            ev["two_level"] = {"p_gauss": p_gauss, "p_own": 0.5, "block_samples": 72.0}
        level = "sigma" if effect == TWIN else "amplitude"
        return Attribution(effect, {}, {level: 0.08, "tau_c": tau_c}, {}, 1.0, 0.0, 1.0, True,
                           0.5, 10.0, ev, np.zeros(3))  # fmt: skip

    gm = att(TWIN, 3.0)
    shown = _refuted_twins([att("telegraph", 2.8, 1e-5), gm], 0.05, 8)
    assert shown[1].score == pytest.approx(10.0 - 2.0 * np.log(1e-5))
    assert shown[1].evidence["two_level_unexplained"]["p_gauss"] == 1e-5
    weak = _refuted_twins([att("telegraph", 2.8, 0.01), gm], 0.05, 8)  # above 0.05 / 8
    assert weak[1].score == 10.0
    far = _refuted_twins([att("telegraph", 30.0, 1e-5), gm], 0.05, 8)  # > DISTINCT_FACTOR
    assert far[1].score == 10.0
    paid = replace(gm, evidence={"explained": [], "unexplained": ["kurt_lf"]})
    assert _refuted_twins([att("telegraph", 2.8, 1e-5), paid], 0.05, 8)[1].score == 10.0


#: the telegraph's amplitude in that case
AMPLITUDE = 0.08092731335895058


def _diagnosed(slow: object) -> set[str]:
    """The validation's telegraph + white pair at 5x / 5x (pair seed 1578), or its twin."""
    seed = 1578
    x = base_model().simulate(2 * N, fs=FS, seed=seed)
    x = x + NoiseModel((slow,), UNITS).simulate(2 * N, fs=FS, seed=seed + 7, allow_aliasing=True)
    white = T["white"](N=0.018483015723988635)
    x = x + NoiseModel((white,), UNITS).simulate(2 * N, fs=FS, seed=seed + 13, allow_aliasing=True)
    x = fit_half(np.ravel(x))
    d = diagnose(x, base_model(), fs=FS, units="deg/s", holdout=None, n_mc=60, seed=seed + 1)
    assert d.explanation is not None
    return {a.effect for a in d.explanation.effects}


@pytest.mark.slow
def test_diagnosis_names_a_diluted_telegraph() -> None:
    """The designed telegraph + white case whose block-mean kurtosis missed the evidence level
    (p 0.0063 > 0.05 / 8): the set names the telegraph, not its Gaussian twin."""
    tele = _diagnosed(T["telegraph"](amplitude=AMPLITUDE, tau_c=3.0))
    assert "telegraph" in tele
    assert "markov" not in tele


@pytest.mark.slow
def test_diagnosis_names_no_telegraph_for_its_gaussian_twin() -> None:
    """Control: the same record with the Gaussian twin in the telegraph's place."""
    twin = _diagnosed(T["markov"](sigma=AMPLITUDE, tau_c=3.0))
    assert "telegraph" not in twin


def _twin_p_values(background: tuple[object, ...]) -> np.ndarray:
    """p_gauss of 12 records: base + white + the Gaussian twin + a slow Gauss-Markov process
    (30 s, sigma 0.1: an effect the set already has), with ``background`` in the null."""
    slow = T["markov"](sigma=0.1, tau_c=30.0)
    ctx = {**two_level_context(np.zeros(N), base_model(), FS, seed=5), "background": background}
    p = []
    for k in range(12):
        x = base_model().simulate(N, fs=FS, seed=200 + k)
        for j, term in enumerate((T["white"](N=0.0185), T["markov"](sigma=0.08, tau_c=3.0), slow)):
            one = NoiseModel((term,), UNITS).simulate(N, fs=FS, seed=300 + 7 * k + j,
                                                      allow_aliasing=True)  # fmt: skip
            x = x + one
        got = two_level_p(
            T["telegraph"](amplitude=0.08, tau_c=3.0),
            {**ctx, "means": np.ravel(x).reshape(-1, 8).mean(axis=1)},
        )
        assert got is not None
        p.append(got[0])
    return np.array(p)


def test_the_null_holds_the_effects_already_chosen() -> None:
    """Next to a slow Gauss-Markov process the set already has, the twin's p-values are uniform
    only when the null holds that process too (:func:`with_set`); control: with the null of
    the sensor alone (the process taken for white noise) they pile up near 1."""
    slow = T["markov"](sigma=0.1, tau_c=30.0)
    with_it = _twin_p_values((slow,))
    assert stats.kstest(with_it, "uniform").pvalue > 1e-3
    without = _twin_p_values(())
    assert stats.kstest(without, "uniform").pvalue < 1e-3
    assert np.median(without) > np.median(with_it)


@dataclass(frozen=True)
class _View:
    """A stand-in for the time view: the only field :func:`with_set` reads."""

    lf_kurtosis: dict[str, object]


def test_with_set_adds_the_chosen_processes_to_the_context(context) -> None:  # type: ignore[no-untyped-def]
    view = _View({"two_level": context})
    slow = T["markov"](sigma=0.1, tau_c=30.0)
    got = with_set(view, [slow])
    assert got.lf_kurtosis["two_level"]["background"] == (slow,)
    assert "background" not in context  # a copy, not a change
    bare = _View({})
    assert with_set(bare, [slow]) is bare  # no two-level context: unchanged
    assert with_set(None, [slow]) is None


def _two_markov() -> set[str]:
    """The two-process record of tests/test_diagnosis_repeat.py: white-noise model, a fast
    (0.02 s) and a slow (5 s) Gauss-Markov process; the effects named."""
    model = NoiseModel((T["white"](N=0.05),), UNITS)
    fast = T["markov"](sigma=0.25, tau_c=0.02)
    slow = T["markov"](sigma=0.05, tau_c=5.0)
    x = np.asarray(model.plus(fast, slow).simulate(2**16, fs=FS, seed=11), dtype=np.float64)
    d = diagnose(fit_half(np.ravel(x)), model, fs=FS, units="deg/s", n_mc=60, seed=12)
    assert d.explanation is not None
    return {a.effect for a in d.explanation.effects}


@pytest.mark.slow
def test_two_gauss_markov_processes_are_not_read_as_a_telegraph() -> None:
    """On top of the fast process, the slow one's telegraph fit is rejected against its Gaussian
    twin at the fit (p 0.0014: this record's slow path is flat-topped) but not against every
    twin the fit's uncertainty allows: both processes are named, no telegraph."""
    assert _two_markov() == {"markov"}


@pytest.mark.slow
def test_two_gauss_markov_processes_control(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Control: with the plausible twins collapsed on the fit (the reverted test's null), a
    telegraph is named in place of the slow process."""
    monkeypatch.setattr(attribution, "TWIN_SIGMAS", 0.0)
    assert "telegraph" in _two_markov()


def _pure(slow: object) -> set[str]:
    """Base sensor + one slow process (no extra white noise), 2 x 2^15 samples, half held out."""
    x = base_model().simulate(2 * N, fs=FS, seed=41)
    x = x + NoiseModel((slow,), UNITS).simulate(2 * N, fs=FS, seed=48, allow_aliasing=True)
    d = diagnose(fit_half(np.ravel(x)), base_model(), fs=FS, units="deg/s", n_mc=60, seed=42)
    assert d.explanation is not None
    return {a.effect for a in d.explanation.effects}


@pytest.mark.slow
def test_a_pure_gauss_markov_record_is_not_read_as_a_telegraph() -> None:
    assert "telegraph" not in _pure(T["markov"](sigma=0.08, tau_c=3.0))


@pytest.mark.slow
def test_a_pure_telegraph_record_is_named() -> None:
    """Control of the pure Gauss-Markov record: a telegraph in its place is named."""
    named = _pure(T["telegraph"](amplitude=0.08, tau_c=3.0))
    assert "telegraph" in named
    assert "markov" not in named
