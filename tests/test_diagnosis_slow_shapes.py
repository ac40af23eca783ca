"""Slow effects that imitate each other: a warm-up under Gauss-Markov noise, a random walk
that a long Gauss-Markov process imitates (the validation's designed pairs, fixed seeds).
"""

from __future__ import annotations

import numpy as np
import pytest

import allanite.diagnosis.joint as joint
import benchmark_module
from allanite.diagnosis import diagnose
from allanite.diagnosis.attribution import _bounds, _degenerate
from allanite.diagnosis.candidates import candidate_library
from allanite.diagnosis.holdout import tau_model_for
from allanite.diagnosis.inputs import SimSource
from allanite.diagnosis.level_shape import ramp_shape, warmup_shape
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES
from test_diagnosis_pairs import UNITS, _pair_record, fit_half

T = TERM_TYPES
FS = 100.0


#: designed pair 'warmup + markov' at 5x/5x the clear level (seed 1000 + 17 * 28)
WARMUP_SEED = 1000 + 17 * 28
WARMUP_KW = {"fs": FS, "units": "deg/s", "holdout": None, "n_mc": 60, "seed": WARMUP_SEED + 1}


def _warmup_markov() -> tuple[NoiseModel, np.ndarray, object]:
    warmup = T["warmup"](amplitude=4.904518776089969, tau_w=16.384, duration=655.36)
    gm = T["markov"](sigma=0.10679679985364646, tau_c=2.0)
    base, x = _pair_record(WARMUP_SEED, (warmup, gm))
    return base, fit_half(x), gm


def test_warmup_under_gauss_markov_noise_is_named_with_it() -> None:
    """The tau view alone reads a warm-up under Gauss-Markov noise as a random walk; the step
    scan's located settling steps (``jump`` evidence a random walk leaves) now make the
    warm-up the best single effect. A warm-up fitted alone takes the process's Allan variance
    too; with the warm-up measured on the window means and the process fitted on top of it,
    the set is warm-up + Gauss-Markov (not bias steps at the located settling steps)."""
    base, x, gm = _warmup_markov()
    d = diagnose(x, base, **WARMUP_KW)
    assert d.attribution[0].effect == "warmup"
    by_effect = {a.effect: a for a in d.explanation.effects}
    assert {"warmup", "markov"} <= by_effect.keys(), by_effect.keys()
    assert not by_effect.keys() & {"rrw", "rescale:rrw"}
    # the step scan locates the settling as steps at the start; they are not listed as steps
    assert d.time.steps is not None
    assert d.time.steps.steps
    assert max(s.t_s for s in d.time.steps.steps) < 5 * by_effect["warmup"].params["tau_w"]
    assert d.level_steps == []
    assert d.to_dict(views=False)["level_steps"] == []
    # the process's correlation time within three of its Fisher standard errors
    a = by_effect["markov"]
    rel = a.params_sigma["tau_c"] / a.params["tau_c"]
    assert abs(np.log(a.params["tau_c"] / gm.tau_c)) <= 3 * rel, (a.params, rel)


@pytest.mark.slow
def test_warmup_under_gauss_markov_noise_control(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """The control of the test above: without the warm-up + partner opening the warm-up fitted
    alone (it takes the process's Allan variance too) leaves room for a third effect, and
    without the step scan in the jump evidence as well the set is the random walk, no warm-up
    (the reading before the step scan)."""
    import allanite.diagnosis.time_view as time_view

    base, x, _ = _warmup_markov()
    monkeypatch.setattr(joint, "_shape_and_noise", lambda *args, **kwargs: [])
    named1 = [a.effect for a in diagnose(x, base, **WARMUP_KW).explanation.effects]
    assert named1[0] == "warmup"
    assert len(named1) == 3, named1
    monkeypatch.setattr(time_view, "step_scan", _no_steps(time_view.step_scan))
    named0 = {a.effect for a in diagnose(x, base, **WARMUP_KW).explanation.effects}
    assert "warmup" not in named0
    assert named0 & {"rrw", "rescale:rrw"}


def _no_steps(scan):  # type: ignore[no-untyped-def]
    """The step scan with its p-value at 1 and no located steps (the jump family without it)."""
    import dataclasses

    def wrapped(*args, **kwargs):  # type: ignore[no-untyped-def]
        out = scan(*args, **kwargs)
        return dataclasses.replace(out, p_value=1.0, steps=[], jumps=out.jumps[:0])

    return wrapped


def tw_total(view: object) -> float:
    """Duration of the time view's windows together."""
    return float(view.window_s * view.level.size)  # type: ignore[attr-defined]


#: designed pair 'ramp + markov' at 2x/16x the clear level (seed 1000 + 17 * 21)
RAMP_SEED = 1000 + 17 * 21
RAMP_KW = {**WARMUP_KW, "seed": RAMP_SEED + 1}


def _ramp_markov() -> tuple[NoiseModel, np.ndarray, object, object]:
    ramp = T["ramp"](R=0.017007719341042296)
    gm = T["markov"](sigma=0.13458598142172354, tau_c=2.0)
    base, x = _pair_record(RAMP_SEED, (ramp, gm))
    return base, fit_half(x), ramp, gm


def test_ramp_under_gauss_markov_noise_is_named_with_it() -> None:
    """A ramp under strong Gauss-Markov noise: the tau view reads the pair as a random walk
    (the best single effect). With the ramp's slope measured on the window means and the
    process fitted on top of it, the set is ramp + Gauss-Markov, the slope within three of
    its standard errors on the window means."""
    base, x, _, _ = _ramp_markov()
    d = diagnose(x, base, **RAMP_KW)
    assert d.attribution[0].effect in ("rrw", "rescale:rrw")  # the look-alike of the two
    by_effect = {a.effect: a for a in d.explanation.effects}
    assert {"ramp", "markov"} <= by_effect.keys(), by_effect.keys()
    assert not by_effect.keys() & {"rrw", "rescale:rrw"}
    # the slope is the window means' least-squares slope of the record (weighted by the
    # null spreads, which vary by a few per cent between windows: the unweighted slope of the
    # raw window means agrees to within a tenth of its spread between records, 1.7e-4)
    view = d.time
    n, w = x.size, view.level.size
    t = view.t_s - view.window_s * w / 2
    means = x[: n - n % w].reshape(w, -1).mean(axis=1)
    ols = float(t @ (means - means.mean()) / (t @ t))
    assert by_effect["ramp"].params["R"] == pytest.approx(ols, abs=1.7e-5)
    assert by_effect["ramp"].params["R"] == pytest.approx(ramp_shape(view, tw_total(view))[0])


@pytest.mark.slow
def test_ramp_under_gauss_markov_noise_control(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """The control: without the measured-shape + partner opening the ramp is named only by the
    joint attribution's backfitting sweep (the Gauss-Markov process refitted with the ramp on
    top, a second route to the same set); without both it is not named."""
    base, x, _, _ = _ramp_markov()
    monkeypatch.setattr(joint, "_shape_and_noise", lambda *args, **kwargs: [])
    named_backfit = {a.effect for a in diagnose(x, base, **RAMP_KW).explanation.effects}
    assert {"ramp", "markov"} <= named_backfit
    monkeypatch.setattr(joint, "_moved", lambda *args, **kwargs: False)  # no refit adopted
    named0 = {a.effect for a in diagnose(x, base, **RAMP_KW).explanation.effects}
    assert "ramp" not in named0


def test_a_process_whose_allan_variance_still_rises_at_the_longest_tau_is_degenerate() -> None:
    """Its turnover (a Gauss-Markov process peaks at 1.89 tau_c) lies beyond the measured
    taus: over them it is a random walk with a parameter the record does not determine."""
    model = NoiseModel((T["white"](N=0.05),), UNITS)
    x = np.asarray(model.simulate(2**14, fs=FS, seed=1), dtype=np.float64).ravel()
    tm = tau_model_for(x, SimSource(fs=FS, model=model), n_mc=20, seed=2)
    cands, _ = candidate_library({"kurt_lf": True}, duration=2**14 / FS, model=model)
    by_effect = {c.effect: c for c in cands}
    for effect, amp in (("markov", "sigma"), ("telegraph", "amplitude")):
        c = by_effect[effect]
        lo, hi = _bounds(c, tm)
        for tau_c, rising in ((3 * tm.tau[-1], True), (tm.tau[-1] / 4, False)):
            logp = np.log([0.1 if n == amp else tau_c for n in c.free])
            extra = np.asarray(c.extra_avar({amp: 0.1, "tau_c": tau_c}, tm.tau, tm.dt))
            assert bool(extra[-1] >= extra.max()) is rising
            assert _degenerate(c, logp, lo, tm.dt, hi, extra) is rising
            assert not _degenerate(c, logp, lo, tm.dt, hi)  # without the curve: the old rule
    # a random walk rises at every tau and has no time to identify: not degenerate
    rrw = by_effect["rrw"]
    lo, hi = _bounds(rrw, tm)
    extra = np.asarray(rrw.extra_avar({"K": 0.01}, tm.tau, tm.dt))
    assert not _degenerate(rrw, np.log([0.01]), lo, tm.dt, hi, extra)


def test_random_walk_next_to_noise_bursts_is_not_a_long_gauss_markov_process() -> None:
    """Designed pair 'bursts + rrw' at 2x/16x the clear level (seed 1000 + 17 * 45): the
    walk was read as a Gauss-Markov process of tau_c 27 s, whose Allan variance still rises
    at the longest tau (20 s); now the walk is named."""
    seed = 1000 + 17 * 45
    bursts = T["white_bursts"](N=0.10899058294204789, duty=0.1, burst_s=16.384)
    walk = T["rrw"](K=0.07717463723772397)
    base, x = _pair_record(seed, (bursts, walk))
    d = diagnose(fit_half(x), base, fs=FS, units="deg/s", n_mc=60, seed=seed + 1)
    named = {a.effect for a in d.explanation.effects}
    assert "bursts" in named
    assert named & {"rrw", "rescale:rrw"}
    assert not named & {"markov", "telegraph"}


def _quick_case(name: str) -> tuple[NoiseModel, np.ndarray, dict[str, object]]:
    """A single-effect case of the validation's quick suite, as it simulates it."""
    vd = benchmark_module.load("validate_diagnosis")
    cases = vd.make_cases(True)
    i = next(i for i, c in enumerate(cases) if c.name == name)
    seed = vd.pair_seed(1000, i)
    real, _, _ = vd.simulate_case(cases[i], seed)
    kw = {"fs": FS, "units": "deg/s", "holdout": None, "n_mc": 60, "seed": seed + 1}
    return cases[i].base, fit_half(np.asarray(real, dtype=np.float64)), kw


def test_a_bias_step_is_not_a_warmup_that_never_settles() -> None:
    """The quick suite's strong bias step: the window means' best warm-up has the record's
    length as its time constant (a drift, not a transient), so the warm-up + partner opening
    is not tried and the step stays the explanation."""
    base, x, kw = _quick_case("step-strong-fs100")
    d = diagnose(x, base, **kw)
    duration = x.size / FS
    tau_w = warmup_shape(d.time, duration)[0]
    assert tau_w * joint.WARMUP_SETTLES > duration
    assert [a.effect for a in d.explanation.effects] == ["step"]


@pytest.mark.slow
def test_a_bias_step_is_not_a_warmup_that_never_settles_control(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """The control: without the settling rule the step reads as a slow warm-up + random walk."""
    base, x, kw = _quick_case("step-strong-fs100")
    monkeypatch.setattr(joint, "WARMUP_SETTLES", 0.0)
    named = {a.effect for a in diagnose(x, base, **kw).explanation.effects}
    assert "warmup" in named
    assert "step" not in named
