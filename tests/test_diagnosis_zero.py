"""Effects of zero size get no credit (issue 14, reviewers' defect).

A ramp fitted to ``R ~ 1e-12`` "explained" level evidence and bursts fitted to ``N ~ 1e-11``
were ranked first with a shrinkage of 0: the candidates explain their evidence by name, and
nothing checked that the fitted effect has a size. :func:`allanite.diagnosis.attribution.
negligible` is the one rule (tau size below one standard error, unless another view measured
the effect's size); these tests reproduce both cases with the rule switched off and check that
it drops them and only them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from allanite.diagnosis import attribution as attr
from allanite.diagnosis.analysis import Analysis, analyze
from allanite.diagnosis.candidates import Candidate, candidate_library
from allanite.diagnosis.inputs import make_source
from allanite.model import NoiseModel
from allanite.terms import RateRandomWalk, Sine, White

FS = 100.0
N_SAMPLES = 2**14
UNITS = {"rate": "deg/s", "time": "s"}
MODEL = NoiseModel((White(N=0.01), RateRandomWalk(K=1e-5)), UNITS)
ALPHA = 0.05
#: level and noise-level evidence declared significant, as a real record with them would
SIGNIFICANT = {"level": True, "hf": True}
EVIDENCE_P = {"level": 1e-8, "hf": 1e-8}


def _analysis(real: NoiseModel, seed: int) -> Analysis:
    x = np.asarray(real.simulate(N_SAMPLES, fs=FS, seed=seed), dtype=float).ravel()
    source = make_source(MODEL, FS, N_SAMPLES, sim_units=None)
    return analyze(x, source, n_mc=40, seed=1, alpha=ALPHA)


@pytest.fixture(scope="module")
def white_gap() -> Analysis:
    """The real white noise is 1.5x the model's: a ramp cannot help the tau view."""
    return _analysis(NoiseModel((White(N=0.015), RateRandomWalk(K=1e-5)), UNITS), seed=3)


@pytest.fixture(scope="module")
def slow_gap() -> Analysis:
    """The real random walk is 10x the model's: more white noise (bursts) cannot help."""
    return _analysis(NoiseModel((White(N=0.01), RateRandomWalk(K=1e-4)), UNITS), seed=3)


def _candidates() -> dict[str, Candidate]:
    cands, _ = candidate_library(
        SIGNIFICANT, duration=N_SAMPLES / FS, model=MODEL, bursts=(0.1, 20.0)
    )
    return {c.effect: c for c in cands}


def _fit_kw(an: Analysis) -> dict[str, Any]:
    """The keywords the engine gives both ``fit_candidate`` and ``rank``."""
    return {
        "alpha": ALPHA,
        "evidence_p": EVIDENCE_P,
        "significant": SIGNIFICANT,
        "time_view": an.time,
        "duration": N_SAMPLES / FS,
    }


def _fit(effect: str, an: Analysis) -> attr.Attribution | None:
    return attr.fit_candidate(_candidates()[effect], an.tau_model, **_fit_kw(an))


def _rank(an: Analysis) -> list[attr.Attribution]:
    return attr.rank(list(_candidates().values()), an.tau_model, **_fit_kw(an))


def _size(a: attr.Attribution, an: Analysis) -> float:
    return attr.tau_size(a.sim_avar_after - an.tau_model.sim_avar, an.tau_model)


def test_zero_ramp_explained_level_without_the_rule(white_gap, monkeypatch):
    monkeypatch.setattr(attr, "NEGLIGIBLE_SE", 0.0)
    a = _fit("ramp", white_gap)
    assert a is not None
    assert a.params["R"] < 1e-6
    assert "level" in a.evidence["explained"]
    assert a.shrinkage == 0.0
    assert _size(a, white_gap) < 1e-3  # far below one standard error


def test_zero_ramp_gets_no_credit(white_gap):
    assert _fit("ramp", white_gap) is None
    # the real effect is still found, with its size
    best = _rank(white_gap)[0]
    assert best.effect in ("bursts", "white", "rescale:white")
    assert _size(best, white_gap) > 10.0


def test_zero_bursts_ranked_first_without_the_rule(slow_gap, monkeypatch):
    monkeypatch.setattr(attr, "NEGLIGIBLE_SE", 0.0)
    best = _rank(slow_gap)[0]
    assert best.effect == "bursts"
    assert best.params["N"] < 1e-6
    assert best.shrinkage == 0.0


def test_zero_bursts_not_ranked(slow_gap):
    kept = _rank(slow_gap)
    assert "bursts" not in [a.effect for a in kept]
    cands = _candidates()
    for a in kept:  # every named effect has a size the data resolve
        c = cands[a.effect]
        extra = a.sim_avar_after - slow_gap.tau_model.sim_avar
        values = {k: a.params[k] for k in c.free}
        assert not attr.negligible(c, values, extra, slow_gap.tau_model)


def test_measured_sizes_are_exempt(white_gap):
    tm = white_gap.tau_model
    zero = np.zeros_like(tm.sim_avar)
    # every parameter fixed by the time view (spikes): the view measured it
    spikes = Candidate("spikes", White, free=(), fixed={"N": 1e-9})
    assert not attr.negligible(spikes, {}, zero, tm)
    # a weak line: amplitude started at the detected line's and fitted near it
    line = Candidate("sine", Sine, free=("amplitude",), fixed={"frequency": 7.0},
                     start={"amplitude": 1e-3}, measured=("amplitude",))  # fmt: skip
    assert not attr.negligible(line, {"amplitude": 5e-4}, zero, tm)
    # ... but not when the fit ran away to zero from it
    assert attr.negligible(line, {"amplitude": 1e-12}, zero, tm)
    # a free size of no tau size is negligible; the same term at a real size is not
    white = _candidates()["white"]
    assert attr.negligible(white, {"N": 1e-9}, White(N=1e-9).avar(tm.tau, tm.dt), tm)
    assert not attr.negligible(white, {"N": 0.01}, White(N=0.01).avar(tm.tau, tm.dt), tm)


# --- dropped angle samples at rest: the sample-level kurtosis (the OOV suite's false "closed")

BASE = NoiseModel(
    (White(N=0.05), RateRandomWalk(K=0.0008)), {"rate": "deg/s", "time": "s"}
)  # fmt: skip


def _dropped_angle(seed: int, n: int) -> np.ndarray:
    """Angle samples at rest with one in ten dropped (runs of one): every tenth increment
    spans two periods, i.e. one rate sample in ten has sqrt(2) times the noise."""
    x = np.asarray(BASE.simulate(n, fs=FS, seed=seed), dtype=float).ravel()
    angle = np.concatenate([[0.0], np.cumsum(x) / FS])
    rng = np.random.default_rng(seed + 11)
    keep = rng.random(angle.size) >= 0.1
    keep[0] = True
    return angle[keep]


def test_dropped_angle_samples_at_rest_are_not_closed():
    from allanite.diagnosis import diagnose

    d = diagnose(_dropped_angle(1101, 2**15), BASE, fs=FS, units="deg/s", input="angle",
                 n_mc=60, seed=2)  # fmt: skip
    assert not d.closed
    kurt = [u for u in d.unexplained if u.evidence == "kurt_hf"]
    assert kurt, [u.evidence for u in d.unexplained]
    size = kurt[0].size
    # the samples carry the scale mixture's excess (~0.2), the differences half of it
    excess_samples = size["excess_kurtosis_samples_real"] - size["excess_kurtosis_samples_sim"]
    excess_diff = size["excess_kurtosis_real"] - size["excess_kurtosis_sim"]
    assert excess_samples > excess_diff > 0.0
    assert "of the samples: real" in kurt[0].text


def test_white_drift_size_is_its_measured_ratio(white_gap):
    """white_drift keeps the mean level (tau size ~0): its size is the time view's ratio,
    carried by the candidate (``view_size``) and judged by the one rule, not by its name."""
    from allanite.diagnosis.noise_level import DriftShape
    from allanite.terms import TERM_TYPES

    tm = white_gap.tau_model
    zero = np.zeros_like(tm.sim_avar)
    model = NoiseModel((White(N=0.01),), {"rate": "deg/s", "time": "s"})
    for ratio, small in ((0.978, True), (1.02, True), (1.5, False), (0.6, False)):
        drift = DriftShape(ratio=ratio, t_start=10.0, t_end=100.0, chi2=30.0, n_windows=32)
        cands, _ = candidate_library({"hf": True}, duration=163.84, model=model,
                                     effects=["white_drift"], drift=drift)  # fmt: skip
        (cand,) = cands
        assert cand.view_size == pytest.approx(abs(ratio - 1.0))
        assert attr.negligible(cand, {"N": 0.01}, zero, tm) is small
        # the same measured size on any other candidate gets the same verdict (one rule)
        other = Candidate(
            "bursts",
            TERM_TYPES["white_bursts"],
            free=("N",),
            fixed={"duty": 0.2, "burst_s": 5.0},
            view_size=abs(ratio - 1.0),
        )
        assert attr.negligible(other, {"N": 0.01}, zero, tm) is small
    # without a measured size a zero tau size is negligible
    bare = Candidate("bursts", TERM_TYPES["white_bursts"], free=("N",),
                     fixed={"duty": 0.2, "burst_s": 5.0})  # fmt: skip
    assert attr.negligible(bare, {"N": 0.01}, zero, tm)
