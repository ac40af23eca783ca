"""A Gauss-Markov bias whose turnover lies beyond the tau grid but whose bend does not.

Issue #14 context (newcomer's Gazebo case): SDF white noise plus a Gauss-Markov bias of
``sigma`` 2e-4 rad/s and ``tau_c`` 100 s, 1200 s at 200 Hz. The tau grid stops at a tenth of
the record (82 s) while the process's Allan variance peaks at ``1.89 tau_c`` (189 s), so its
fitted curve still rises at the longest tau and the candidate was dropped as degenerate (a
random walk with an undetermined correlation time): "no candidate effect explains" with
``effects=["markov"]``, a random walk of K 313 deg/h/sqrt(h) otherwise. Its bend away from
the walk's slope is measured, and the likelihood-ratio test against the walk now keeps it.
"""

from __future__ import annotations

import numpy as np
import pytest

from allanite.diagnosis import diagnose
from allanite.diagnosis.attribution import Attribution, fit_candidate
from allanite.diagnosis.candidates import candidate_library
from allanite.diagnosis.holdout import tau_model_for
from allanite.diagnosis.inputs import SimSource
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES, Term

T = TERM_TYPES
FS = 200.0
N_SAMPLES = 240_000
UNITS = {"rate": "rad/s", "time": "s"}
#: the SDF's gyro white noise: stddev 0.0009 rad/s per sample at 200 Hz
SIM = NoiseModel((T["white"](N=0.0009 / np.sqrt(FS)),), UNITS)
ALPHA = 0.01
#: the fitted parameter lies within this many of its own Fisher sigmas of the truth
N_SIGMA = 3.0


def _fits(extra: Term) -> dict[str, Attribution | None]:
    """Fit every tau-view candidate of the simulated sensor to ``SIM`` + ``extra``."""
    real = NoiseModel((*SIM.terms, extra), UNITS)
    x = np.asarray(real.simulate(N_SAMPLES, fs=FS, output="rate", seed=11), dtype=np.float64)
    x = x.ravel()
    tm = tau_model_for(x, SimSource(fs=FS, model=SIM), n_mc=40, seed=12)
    assert tm.tau[-1] < 1.89 * 100.0  # the turnover lies beyond the grid
    cands, _ = candidate_library({}, duration=N_SAMPLES / FS, model=SIM, effects=["markov", "rrw"])
    return {
        c.effect: fit_candidate(c, tm, alpha=ALPHA, evidence_p={}, significant={}) for c in cands
    }


def test_gauss_markov_bias_turning_over_beyond_the_grid_is_kept_and_beats_the_walk() -> None:
    fits = _fits(T["markov"](sigma=2e-4, tau_c=100.0))
    gm, walk = fits["markov"], fits["rrw"]
    assert gm is not None, "the Gauss-Markov candidate was dropped"
    for name, truth in (("sigma", 2e-4), ("tau_c", 100.0)):
        assert gm.params[name] == pytest.approx(truth, abs=N_SIGMA * gm.params_sigma[name])
    assert gm.consistent_after
    assert walk is not None
    assert gm.score < walk.score


def test_control_a_random_walk_still_reads_as_a_walk() -> None:
    """The walk's curve rises at every tau and has no bend: the Gauss-Markov candidate is a
    walk with an undetermined correlation time (dropped), the walk is kept."""
    # the K whose short-tau Allan variance equals the Gauss-Markov case's (2 sigma^2 / tau_c)
    fits = _fits(T["rrw"](K=2e-4 * np.sqrt(2.0 / 100.0)))
    walk = fits["rrw"]
    assert walk is not None
    assert walk.consistent_after
    assert fits["markov"] is None


def _diagnosed(extra: Term) -> list[str]:
    real = NoiseModel((*SIM.terms, extra), UNITS)
    x = np.asarray(real.simulate(N_SAMPLES, fs=FS, output="rate", seed=11), dtype=np.float64)
    d = diagnose(x.ravel(), SIM, fs=FS, units="rad/s", n_mc=40, seed=12)
    assert d.explanation is not None
    return [a.effect for a in d.explanation.effects]


@pytest.mark.slow
def test_diagnose_names_the_gauss_markov_bias_not_a_walk() -> None:
    """End to end (~16 s): the named explanation was a random walk of K 313 deg/h/sqrt(h)."""
    assert _diagnosed(T["markov"](sigma=2e-4, tau_c=100.0)) == ["markov"]


@pytest.mark.slow
def test_diagnose_control_names_the_walk() -> None:
    named = _diagnosed(T["rrw"](K=2e-4 * np.sqrt(2.0 / 100.0)))
    assert "rrw" in named
    assert "markov" not in named
