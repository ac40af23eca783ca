"""The designed two-effect grid of benchmarks/validate_diagnosis.py (issue 14).

The design only (no diagnosis): each effect of every designed pair is clearly in the record
next to the other by the validation's own clear rule, and the pair types left out are the ones
whose laws one another imitate in the tau and frequency views.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import benchmark_module

FS, N = 100.0, 2**16


@pytest.fixture(scope="module")
def vd() -> Any:
    return benchmark_module.load("validate_diagnosis")


@pytest.fixture(scope="module")
def tm(vd: Any) -> Any:
    return vd.design_tau_model(FS, N)


def test_every_designed_pair_shows_both_effects(vd: Any, tm: Any) -> None:
    cases = vd.designed_pair_cases(FS, N, tm)
    assert len(cases) == len(vd.PAIRS) * len(vd.DESIGN_LEVELS)
    dt, half = 1.0 / FS, N // 2
    for case in cases:
        a, b = str(case.effect)[5:].split("+")
        levels = tuple(float(x) for x in case.strength[1:].split("-"))
        terms = (case.extra, case.extra2)
        shares = (case.truth["shares"][a], case.truth["shares"][b])
        avars = [
            sh * vd.effect_avar(t, tm.tau, dt, half) for sh, t in zip(shares, terms, strict=True)
        ]
        for i, name in enumerate((a, b)):
            lam = vd.tau_noncentrality(avars[i], tm.sim_avar + avars[1 - i], tm.cov_inv)
            assert vd.effect_clear(name, terms[i], lam, FS), (case.name, name, lam)
            if name == "spikes":  # clear by the time view: 5 to 10 sample sigmas
                sigmas = terms[i].amplitude / (0.05 * np.sqrt(FS))
                assert sigmas == pytest.approx(vd.SPIKE_SIGMAS[levels[i]])
            else:  # the designed noncentrality, next to the other effect at its size
                assert lam == pytest.approx(levels[i] * vd.CLEAR_LAMBDA, rel=0.05), case.name
                assert case.truth["lambda_design"][name] == pytest.approx(lam, rel=1e-2)


def test_the_first_grid_hid_effects_the_design_shows(vd: Any, tm: Any) -> None:
    # the legacy grid (--legacy-pairs) at medium strength: the step next to white noise and
    # the ramp next to a Gauss-Markov process are below the clear level in expectation
    dt, half = 1.0 / FS, N // 2
    legacy = {str(c.effect): c for c in vd.legacy_pair_cases(FS, N)}
    assert len(legacy) == len(vd.PAIRS)
    for pair in ("pair:ramp+markov", "pair:telegraph+white"):
        case = legacy[pair]
        avars = [vd.effect_avar(t, tm.tau, dt, half) for t in (case.extra, case.extra2)]
        lam = vd.tau_noncentrality(avars[0], tm.sim_avar + avars[1], tm.cov_inv)
        assert lam < vd.CLEAR_LAMBDA, (pair, lam)


def test_excluded_pairs_imitate_each_other(vd: Any, tm: Any) -> None:
    # chance level of the tau-view noncentrality: about the number of taus (12)
    chance = float(tm.tau.size)
    for a, b in vd.EXCLUDED_PAIRS:
        m = vd.pair_mimicry(a, b, FS, N, tm)
        assert m["tau"] < 0.1 * chance, (a, b, m)
        assert m["psd_db"] is None or m["psd_db"] < 0.5, (a, b, m)
    for a, b in vd.PAIRS:  # the grid's: the one cannot stand in for the other
        m = vd.pair_mimicry(a, b, FS, N, tm)
        assert m["tau"] > 2.0 * chance, (a, b, m)


def test_bursts_are_designed_on_the_bursts_the_record_holds(vd: Any, tm: Any) -> None:
    # the fitted half holds about two bursts: the design sizes them on the share it realises
    # (it used the expected share; two of the three records held a tenth to a fifth of it)
    import allanite

    dt, half = 1.0 / FS, N // 2
    cases = vd.designed_pair_cases(FS, N, tm, pairs=[("bursts", "rrw")])
    shares = []
    for case in cases:
        seed = vd.pair_seed(1000, case.truth["index"])
        _, bursts, _ = vd.simulate_case(case, seed)
        on = int(np.count_nonzero(bursts[:half]))
        share = on / half / case.extra.duty
        assert case.truth["shares"]["bursts"] == pytest.approx(share, rel=1e-12)
        shares.append(share)
        # the shortest tau: mean of d^2/2 over the ~on differences, relative sd sqrt(3 / on)
        got = allanite.avar(bursts[:half], fs=FS, taus=np.array([dt])).var[0]
        want = share * vd.effect_avar(case.extra, np.array([dt]), dt, half)[0]
        assert abs(got / want - 1.0) < 4.0 * np.sqrt(3.0 / on), (case.name, got / want)
    assert min(shares) < 0.5  # the case the expected share would have designed wrongly


def test_drifting_line_law_is_the_fitted_halfs(vd: Any) -> None:
    # the line sweeps only the first half of its band in the fitted half
    import allanite

    dt, half = 1.0 / FS, N // 2
    term = vd.pair_shapes(FS, N)["drifting_line"]
    tau = np.array([0.02, 0.05, 0.1, 0.2, 0.5])
    sims = np.array([
        allanite.avar(
            vd.NoiseModel((term,), vd.UNITS).simulate(N, fs=FS, seed=s)[:half], fs=FS, taus=tau
        ).var
        for s in range(8)
    ])  # fmt: skip
    mean, se = sims.mean(axis=0), sims.std(axis=0, ddof=1) / np.sqrt(len(sims))
    # the law is quasi-static (|f_e - f_s| tau^2 / D: 2e-4 at 0.2 s, 8e-4 at 0.5 s); measured
    # 0.1 % and 0.4 % off there, allowed 1 %
    law = vd.effect_avar(term, tau, dt, half)
    assert np.all(np.abs(mean - law) < 4.0 * se + 0.01 * law), mean / law
    whole = np.asarray(term.avar(tau, dt))  # the whole record's law, the old design's
    assert np.any(np.abs(mean - whole) > 4.0 * se + 0.1 * whole), mean / whole


def test_oov_table_without_null_cases(vd: Any) -> None:
    """``--oov --nulls 0``: the null rates are over no cases, reported n/a (not a crash)."""
    row = {"kind": "bursts", "handled": True, "closed": False, "false_closed": False,
           "expected": "bursts", "expected_named": True, "named": ["bursts"], "lines_hz": [],
           "view_lines_hz": [], "significant": True}  # fmt: skip
    summary = vd.summarize_oov([row])
    assert summary["null_false_alarm_rate"] is None
    text = vd.oov_table(summary)
    assert "| null cases: false alarms (significant) | n/a of 0 |" in text
    assert "| handled (not fully explained, or the right candidate named) | 1.000 of 1 |" in text
