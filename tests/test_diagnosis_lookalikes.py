"""Look-alikes of the joint attribution: the set refitted when an effect joins it.

Designed two-effect records of ``benchmarks/validate_diagnosis.py`` (fixed seeds; the base
model's samples from ``seed``, each effect's from ``seed + 7`` and ``seed + 13``), with a
control each that shows what the rule changes.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import allanite.diagnosis.engine as engine
import allanite.diagnosis.joint as joint
from allanite.diagnosis import diagnose
from allanite.diagnosis.attribution import fit_candidate
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES
from test_diagnosis_pairs import fit_half

UNITS = {"rate": "deg/s", "time": "s"}
T: dict[str, Any] = dict(TERM_TYPES)
FS, N = 100.0, 2**16

#: the designed pair 'resonance + white' at 16x/2x the clear level (validation index 38)
RESONANCE_WHITE_SEED = 1000 + 17 * 38
RESONANCE = T["resonance"](N=0.06802299366452161, frequency=20.0, damping=0.1)
WHITE = T["white"](N=0.014969597007682751)


def _record(seed: int, terms: tuple[Any, ...]) -> tuple[NoiseModel, np.ndarray]:
    """The validation suite's base gyro plus each effect simulated on its own."""
    base = NoiseModel(
        (T["white"](N=0.05), T["quantization"](Q=0.2 / FS), T["flicker"](B=0.01),
         T["rrw"](K=0.0008)),
        UNITS,
    )  # fmt: skip
    x = np.asarray(base.simulate(N, fs=FS, seed=seed), dtype=np.float64).ravel()
    for term, s in zip(terms, (seed + 7, seed + 13), strict=True):
        y = NoiseModel((term,), UNITS).simulate(N, fs=FS, seed=s, allow_aliasing=True)
        x = x + np.asarray(y, dtype=np.float64).ravel()
    return base, x


def _diagnose_seen(
    seed: int, terms: tuple[Any, ...], monkeypatch: pytest.MonkeyPatch
) -> tuple[Any, dict[str, Any]]:
    """Diagnose a designed record; also return the joint step's candidates and inputs."""
    base, x = _record(seed, terms)
    seen: dict[str, Any] = {}
    explain = joint.explain  # the function the engine calls

    def spy(best: Any, cands: Any, tm: Any, **kw: Any) -> Any:
        seen.update(cands=cands, tm=tm, kw=kw)
        return explain(best, cands, tm, **kw)

    monkeypatch.setattr(engine, "explain", spy)
    d = diagnose(fit_half(x), base, fs=FS, units="deg/s", n_mc=60, seed=seed + 1)
    return d, seen


def _named(d: Any) -> set[str]:
    return {a.effect for a in d.explanation.effects}


def test_resonance_next_to_white_noise_is_not_a_low_pass_lookalike(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A resonance fitted alone takes part of the extra white noise next to it (its level
    1.3 Fisher sigmas above the truth) and overshoots the shortest taus; on top of it a
    Gauss-Markov process of ``tau_c`` ~ 1.3 samples (white noise that falls off above
    12 Hz) fitted that overshoot better than the white noise itself, and the set read
    ``markov + resonance``. Refitted with the white noise on top, the resonance's level
    returns to the truth and the set is ``resonance + white``, closed in all three views."""
    d, seen = _diagnose_seen(RESONANCE_WHITE_SEED, (RESONANCE, WHITE), monkeypatch)
    named = _named(d)
    assert "resonance" in named
    assert named & {"white", "rescale:white"}
    assert "markov" not in named
    assert d.closed
    reso = next(a for a in d.explanation.effects if a.effect == "resonance")
    n_true = RESONANCE.values()["N"]
    assert abs(reso.params["N"] - n_true) < 3.0 * reso.params_sigma["N"]

    # the backfitting sweep itself: the white noise on top of the resonance fitted alone
    tm, cands, kw = seen["tm"], seen["cands"], seen["kw"]
    fit_kw = {k: v for k, v in kw.items() if k != "frequency"}
    by = {c.effect: c for c in cands}
    alone = fit_candidate(by["resonance"], tm, **fit_kw)
    assert alone is not None
    e_alone = by["resonance"].extra_avar({"N": alone.params["N"]}, tm.tau, tm.dt)
    white = fit_candidate(by["white"], joint.with_background(tm, e_alone), **fit_kw)
    assert white is not None
    got = joint._backfit(white, by["white"], [alone], [by["resonance"]], tm, fit_kw,
                         kw["significant"])  # fmt: skip
    assert got is not None
    white2, (reso2,) = got
    assert white2 is not None
    assert reso2.params["N"] < alone.params["N"]
    # it moves by more than its own standard error (a smaller move keeps the set as fitted)
    assert joint._moved(reso2, alone, by["resonance"])
    before = e_alone + by["white"].extra_avar({"N": white.params["N"]}, tm.tau, tm.dt)
    after = by["resonance"].extra_avar({"N": reso2.params["N"]}, tm.tau, tm.dt) + by[
        "white"
    ].extra_avar({"N": white2.params["N"]}, tm.tau, tm.dt)
    assert tm.statistic(after) < tm.statistic(before)


def test_without_the_refit_the_resonance_reads_as_markov_plus_resonance(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The control: the same record with the set kept as fitted (no backfitting sweep) names
    the low-pass look-alike instead of the white noise."""
    monkeypatch.setattr(joint, "_backfit", lambda *args, **kwargs: None)
    d, _ = _diagnose_seen(RESONANCE_WHITE_SEED, (RESONANCE, WHITE), monkeypatch)
    named = _named(d)
    assert "resonance" in named
    assert "markov" in named
    assert not named & {"white", "rescale:white"}
