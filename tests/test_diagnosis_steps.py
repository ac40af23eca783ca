"""Level changes (bias steps): the step scan against a CUSUM of block means (issue #28).

Records come from an independent generator (numpy white noise, FFT-shaped flicker, cumulative
sums for the random walk); the null replicates are the model's own (``NoiseModel.simulate``),
as the diagnosis uses them.
"""

from __future__ import annotations

import numpy as np
import pytest

import benchmark_module
from allanite.diagnosis import diagnose
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES as T

UNITS = {"rate": "deg/h", "time": "s"}


@pytest.fixture(scope="module")
def vs():
    """The step-power suite (``benchmarks/validate_steps.py``): generator and the two judges."""
    return benchmark_module.load("validate_steps")


@pytest.mark.parametrize(
    ("terms", "rec"),
    [
        ((T["white"](N=0.18), T["flicker"](B=0.004)), {"n_white": 0.18, "b": 0.004}),
        ((T["white"](N=0.18), T["rrw"](K=2e-4)), {"n_white": 0.18, "k": 2e-4}),
    ],
    ids=["white+flicker", "white+rrw"],
)
def test_step_scan_has_at_least_the_power_of_a_block_mean_cusum(vs, terms, rec) -> None:
    """3 sigma (half-mean difference) steps at 0.4 T: power >= the reference's, 40 records.

    Both judged at level 0.05 on the same records. The tolerance is two binomial standard
    errors of a difference of two proportions (``sqrt(2 * 0.25 / 40)`` at most); the scan's
    false alarms on the same records without the step stay within two binomial standard
    errors of the level.
    """
    judges = vs.StepJudges(NoiseModel(terms, UNITS), 2**16, 10.0)
    hits = {"scan": [0, 0], "ref": [0, 0]}  # [no step, step]
    for i in range(40):
        for j, size in enumerate((0.0, 3.0 * judges.sd_half)):
            x = vs.independent_record(2**16, 10.0, seed=1000 + i, **rec)
            x[int(0.4 * x.size) :] += size
            hits["scan"][j] += judges.scan_p(x) < 0.05
            hits["ref"][j] += judges.ref_alarm(x)
    assert hits["scan"][1] / 40 >= hits["ref"][1] / 40 - 2.0 * np.sqrt(0.5 / 40), hits
    assert hits["scan"][0] / 40 <= 0.05 + 2.0 * np.sqrt(0.05 * 0.95 / 40), hits


@pytest.mark.slow
def test_issue_fog_step_is_found_located_and_sized(vs) -> None:
    """Issue #28: FOG 12 h at 10 Hz, N 0.003 deg/sqrt(h), B 0.004 deg/h, 0.02 deg/h at 6 h.

    Against its true model (without the step) the diagnosis said "NO GAP, p = 0.091"; now the
    gap is significant, the step's 95 % interval holds 6 h and its size is 0.02 within three
    of its standard errors; the JSON and the CLI text state them.
    """
    fs, n = 10.0, 12 * 3600 * 10
    model = NoiseModel((T["white"](N=0.18), T["flicker"](B=0.004)), UNITS)
    x = vs.independent_record(n, fs, n_white=0.18, b=0.004, seed=1)
    x[6 * 3600 * 10 :] += 0.02
    d = diagnose(x, model, fs=fs, units="deg/h")
    assert d.significant, d.headline
    steps = d.to_dict(views=False)["steps"]["steps"]
    assert len(steps) == 1, steps
    s = steps[0]
    assert s["t_interval_s"][0] <= 21600.0 <= s["t_interval_s"][1], s
    assert abs(s["size"] - 0.02) <= 3.0 * s["size_sd"], s
    from allanite.cli.diagnose import _summary

    assert "level steps" in _summary(d)
