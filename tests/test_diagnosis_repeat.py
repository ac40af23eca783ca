"""Joint attribution of two processes of one kind, and correlation times at the fit's bound.

A Gauss-Markov process with a distinct correlation time, or a resonance whose band does not
overlap, next to one the set already has is a second effect (issue 14, real-base cases); a
Gauss-Markov or telegraph process whose correlation time runs into the fit's upper bound (four
times the record) is a drift.
Fixed seeds; tolerances from the fits' own Fisher uncertainties.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

import benchmark_module
from allanite.diagnosis import diagnose
from allanite.diagnosis.attribution import Attribution, _bounds, _degenerate, rank
from allanite.diagnosis.band_shape import BandShape, band_shapes
from allanite.diagnosis.candidates import Candidate, candidate_library
from allanite.diagnosis.holdout import tau_model_for
from allanite.diagnosis.inputs import SimSource
from allanite.diagnosis.joint import DISTINCT_FACTOR, _distinct, _same_slot, share_key
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES, term_from_dict
from test_diagnosis_pairs import fit_half

UNITS = {"rate": "deg/s", "time": "s"}
T = TERM_TYPES
FS = 100.0


def _attr(effect: str, **params: float) -> Attribution:
    """A fitted effect with the given parameters (only what the set's bookkeeping reads)."""
    z = np.zeros(3)
    return Attribution(effect, {}, dict(params), {}, 1.0, 0.0, 1.0, True, 0.5, 0.0, {}, z)


def _markov_candidates(model: NoiseModel | None = None) -> dict[str, object]:
    cands, _ = candidate_library({}, duration=100.0, model=model)
    return {c.effect: c for c in cands}


def test_a_second_markov_is_its_own_slot_once() -> None:
    by = _markov_candidates(NoiseModel((T["white"](N=0.05), T["markov"](sigma=0.1, tau_c=0.5))))
    gm, white, rescale = by["markov"], by["white"], by["rescale:markov"]
    assert not _same_slot(gm, [white])
    assert not _same_slot(gm, [gm])  # a second added process
    assert not _same_slot(gm, [rescale])  # next to the model's process, rescaled
    assert _same_slot(gm, [gm, gm])  # never a third
    assert _same_slot(rescale, [gm])  # the model's process is one slot
    assert _same_slot(white, [by["rescale:white"]])  # other kinds unchanged


def test_a_second_markov_needs_a_distinct_correlation_time() -> None:
    model = NoiseModel((T["white"](N=0.05), T["markov"](sigma=0.1, tau_c=0.5)), UNITS)
    by = _markov_candidates(model)
    gm, rescale = by["markov"], by["rescale:markov"]
    first = _attr("markov", sigma=0.1, tau_c=0.02)
    for tau_c, ok in ((0.02 * DISTINCT_FACTOR * 1.01, True), (0.02 * DISTINCT_FACTOR * 0.99, False),
                      (0.02 / DISTINCT_FACTOR / 1.01, True), (0.03, False)):  # fmt: skip
        assert _distinct(_attr("markov", sigma=0.1, tau_c=tau_c), gm, [first], [gm]) is ok
    # against a rescale, the model term's correlation time (0.5 s) counts
    scaled = _attr("rescale:markov", scale=2.0, sigma=0.2)
    assert not _distinct(_attr("markov", sigma=0.1, tau_c=1.0), gm, [scaled], [rescale])
    assert _distinct(_attr("markov", sigma=0.1, tau_c=5.0), gm, [scaled], [rescale])
    # unrelated kinds never block it
    assert _distinct(_attr("markov", sigma=0.1, tau_c=0.02), gm, [_attr("white", N=0.1)],
                     [by["white"]])  # fmt: skip


def test_share_keys_of_a_repeated_effect() -> None:
    share = {"markov": 0.5}
    assert share_key("markov", share) == "markov_2"
    share["markov_2"] = 0.2
    assert share_key("markov", share) == "markov_3"
    assert share_key("white", share) == "white"


@pytest.fixture(scope="module")
def two_markov() -> tuple[NoiseModel, tuple[object, object], object]:
    """White-noise model; real = model + a fast and a slow Gauss-Markov process."""
    n = 2**16
    model = NoiseModel((T["white"](N=0.05),), UNITS)
    fast = T["markov"](sigma=0.25, tau_c=0.02)
    slow = T["markov"](sigma=0.05, tau_c=5.0)
    x = np.asarray(model.plus(fast, slow).simulate(n, fs=FS, seed=11), dtype=np.float64).ravel()
    d = diagnose(fit_half(x), model, fs=FS, units="deg/s", n_mc=60, seed=12)
    return model, (fast, slow), d


def test_two_gauss_markov_processes_are_both_named(two_markov) -> None:  # type: ignore[no-untyped-def]
    _, truth, d = two_markov
    gms = [a for a in d.explanation.effects if a.effect == "markov"]
    assert len(gms) == 2, [(a.effect, a.params) for a in d.explanation.effects]
    gms.sort(key=lambda a: a.params["tau_c"])
    for a, true in zip(gms, truth, strict=True):
        # within three of the fit's own standard errors (log scale: sigma / value)
        rel = a.params_sigma["tau_c"] / a.params["tau_c"]
        assert abs(np.log(a.params["tau_c"] / true.tau_c)) <= 3 * max(rel, 1e-3), (a.params, rel)
    share = d.explanation.share
    assert {"markov", "markov_2"} <= set(share)
    assert sum(share.values()) == pytest.approx(1.0, abs=1e-9)


def test_the_two_process_model_pastes_and_simulates(two_markov) -> None:  # type: ignore[no-untyped-def]
    model, _, d = two_markov
    terms = d.explanation.terms
    assert [t["type"] for t in terms].count("markov") == 2
    combined = NoiseModel.from_dict({**model.to_dict(), "terms": terms})
    assert len(combined.terms_of_type("markov")) == 2
    x = np.asarray(combined.simulate(4096, fs=FS, seed=5), dtype=np.float64).ravel()
    assert x.shape == (4096,)
    assert np.all(np.isfinite(x))
    # its Allan variance is the model's plus both processes' (they add)
    tau = np.array([0.01, 0.1, 1.0, 10.0])
    added = sum(term_from_dict(t).avar(tau, 1 / FS) for t in terms if t["type"] == "markov")
    np.testing.assert_allclose(combined.avar(tau, 1 / FS), model.avar(tau, 1 / FS) + added)


def test_a_correlation_time_at_its_upper_bound_is_degenerate() -> None:
    model = NoiseModel((T["white"](N=0.05),), UNITS)
    x = np.asarray(model.simulate(2**14, fs=FS, seed=1), dtype=np.float64).ravel()
    tm = tau_model_for(x, SimSource(fs=FS, model=model), n_mc=20, seed=2)
    gm = _markov_candidates()["markov"]
    lo, hi = _bounds(gm, tm)
    inside = np.array([np.log(0.1), np.log(2.0)])
    assert not _degenerate(gm, inside, lo, tm.dt, hi)
    at_bound = np.array([np.log(0.1), hi[1] - 1e-3])
    assert _degenerate(gm, at_bound, lo, tm.dt, hi)
    assert not _degenerate(gm, at_bound, lo, tm.dt)  # without the bound: the old rule


def test_a_ramp_is_not_read_as_a_process_at_the_bound(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """A clear ramp on white + Gauss-Markov noise: Gauss-Markov and telegraph fits run to the
    longest correlation time the fit allows (four times the record: a drift). They are not
    kept; without the upper-bound rule they are (the test's control)."""
    import allanite.diagnosis.attribution as attribution

    n = 2**15
    model = NoiseModel((T["white"](N=0.05), T["markov"](sigma=0.02, tau_c=1.0)), UNITS)
    x = np.asarray(model.plus(T["ramp"](R=3e-3)).simulate(n, fs=FS, seed=31)).ravel()
    tm = tau_model_for(x, SimSource(fs=FS, model=model), n_mc=40, seed=22)
    cands, _ = candidate_library({"kurt_lf": True}, duration=n / FS, model=model)
    cands = [c for c in cands if c.effect in ("ramp", "rrw", "markov", "telegraph")]
    test = {"alpha": 0.05, "evidence_p": {"kurt_lf": 1.0}, "significant": {}}
    limit = np.log(4 * tm.duration) - 0.01

    def at_bound(ranked: list[Attribution]) -> list[str]:
        return [a.effect for a in ranked if np.log(a.params.get("tau_c", 1.0)) >= limit]

    ranked = rank(cands, tm, **test)
    assert ranked
    assert ranked[0].effect == "ramp"
    assert at_bound(ranked) == []
    original = attribution._degenerate
    monkeypatch.setattr(
        attribution,
        "_degenerate",
        lambda c, logp, lo, dt, hi=None, extra=None: original(c, logp, lo, dt),
    )
    # a telegraph that explains no platykurtic block means is not kept at all (it is a
    # Gauss-Markov process, attribution.TWO_LEVEL); without that rule too it runs to the bound
    assert set(at_bound(rank(cands, tm, **test))) == {"markov"}
    monkeypatch.setattr(attribution, "TWO_LEVEL", ())
    assert set(at_bound(rank(cands, tm, **test))) == {"markov", "telegraph"}


def _adis_base(axis: int, terms: str = "auto") -> tuple[NoiseModel, Callable[[int], np.ndarray]]:
    """Run 1's fitted model of an ADIS16405 gyro axis and a loader of its runs (deg/s), as the
    validation's real-base cases build them (``benchmarks/diagnosis_adis16405.py``; the
    tests request ``shared_data``, which skips or fails when the data are absent)."""
    adis = benchmark_module.load("diagnosis_adis16405")
    model, _ = adis.fit_model(adis.load(1, axis), terms)
    return NoiseModel(model.terms, UNITS), lambda run: adis.load(run, axis)


@pytest.mark.slow
def test_real_base_gauss_markov_next_to_the_runs_own_wander(shared_data, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """ADIS16405 x gyro: run 1's power-law model (N, B: what the default fit chose before it
    modelled the sensor's averaging filter) as the simulation, run 3 with a 2-s Gauss-Markov
    process injected as the record (the validation's real-base case). Against that model the
    run shows a short-correlation wander (0.013-0.019 s: the unmodelled filter), so one
    Gauss-Markov process fits a compromise and loses to flicker; fitted as a pair, both
    processes are named. Without the pair step the backfitting sweep still names it; without
    both the injected process is not named. (Against the default fit's model, which holds
    the filter, the injected process is named without either step.)"""
    import allanite.diagnosis.joint as joint

    model, load = _adis_base(axis=0, terms="N,B")
    gm = T["markov"](sigma=0.0721, tau_c=2.0)  # Allan variance peak 8x the model's
    n = 2**16
    injected = NoiseModel((gm,), UNITS).simulate(n, fs=FS, seed=1092, allow_aliasing=True)
    x = load(3)[:n] + np.asarray(injected, dtype=np.float64).ravel()
    kw = {"fs": FS, "units": "deg/s", "holdout": None, "n_mc": 60, "seed": 1086}

    def processes(d) -> list[Attribution]:  # type: ignore[no-untyped-def]
        return sorted(
            (a for a in d.explanation.effects if a.effect == "markov"),
            key=lambda a: a.params["tau_c"],
        )

    fast, slow = processes(diagnose(fit_half(x), model, **kw))
    rel = slow.params_sigma["tau_c"] / slow.params["tau_c"]
    assert abs(np.log(slow.params["tau_c"] / gm.tau_c)) <= 3 * rel, (slow.params, rel)
    assert fast.params["tau_c"] < gm.tau_c / DISTINCT_FACTOR**2  # the run's own wander
    monkeypatch.setattr(joint, "_two_processes", lambda *args, **kwargs: None)
    # without the pair step the backfitting sweep (the run's own wander refitted with the
    # injected process on top) is a second route to both processes
    backfit = processes(diagnose(fit_half(x), model, **kw))
    assert any(abs(np.log(a.params["tau_c"] / gm.tau_c)) <= np.log(3.0) for a in backfit)
    monkeypatch.setattr(joint, "_moved", lambda *args, **kwargs: False)  # no refit adopted
    before = processes(diagnose(fit_half(x), model, **kw))
    assert all(abs(np.log(a.params["tau_c"] / gm.tau_c)) > np.log(3.0) for a in before)


# --- two resonances (a repeatable kind whose frequency the frequency view fixes) -------------


def _resonance_candidate(others: tuple[dict[str, float], ...] = ()) -> Candidate:
    band = [BandShape("resonance", (9.0, 11.0), {"N": 0.1, "frequency": 10.0, "damping": 0.05})]
    band += [BandShape("resonance", (0.0, 1.0), p) for p in others]
    cands, _ = candidate_library({}, duration=100.0, band=band)
    return next(c for c in cands if c.effect == "resonance")


def test_two_resonances_are_distinct_when_their_bands_do_not_overlap() -> None:
    c = _resonance_candidate()
    p = {"N": 0.1, "frequency": 10.0, "damping": 0.05}  # half-power band 9.5 .. 10.5 Hz
    assert c.distinct(p, {"N": 0.1, "frequency": 11.2, "damping": 0.05})  # 1.2 Hz > 0.5 + 0.56
    assert not c.distinct(p, {"N": 0.1, "frequency": 10.9, "damping": 0.05})  # 0.9 < 0.5 + 0.545
    assert not c.distinct(p, {"N": 0.1, "frequency": 20.0, "damping": 0.7})  # a broad one over it
    assert c.repeat_key == "frequency"
    with pytest.raises(ValueError, match="not a repeatable kind"):
        _markov_candidates()["white"].distinct({}, {})


def test_a_second_band_is_a_further_resonance_of_the_candidate() -> None:
    second = {"N": 0.2, "frequency": 30.0, "damping": 0.1}
    c = _resonance_candidate((second,))
    assert c.free == ("N",)
    assert c.fixed == {"frequency": 10.0, "damping": 0.05}
    (r,) = c.repeats()
    assert r.fixed == {"frequency": 30.0, "damping": 0.1}
    assert r.start == {"N": 0.2}
    assert r.others == ()
    assert not _same_slot(r, [c])  # next to the first, once
    assert _same_slot(r, [c, c])
    assert _resonance_candidate().repeats() == []


@pytest.fixture(scope="module")
def two_resonances() -> tuple[NoiseModel, tuple[object, object], object, object]:
    """White-noise model; real = model + resonances at 12 Hz (Q 10) and 31 Hz (Q 6)."""
    n = 2**15
    model = NoiseModel((T["white"](N=0.05),), UNITS)
    low = T["resonance"](N=0.4, frequency=12.0, damping=0.05)
    high = T["resonance"](N=0.3, frequency=31.0, damping=0.08)
    x = np.asarray(model.plus(low, high).simulate(n, fs=FS, seed=21), dtype=np.float64).ravel()
    d = diagnose(fit_half(x), model, fs=FS, units="deg/s", n_mc=40, seed=22)
    return model, (low, high), d, x


def test_two_resonances_are_both_found_and_named(two_resonances) -> None:  # type: ignore[no-untyped-def]
    _, truth, d, x = two_resonances
    bands = sorted(band_shapes(x[: x.size // 2], FS, d.frequency), key=lambda b: b.band_hz[0])
    assert [b.kind for b in bands] == ["resonance", "resonance"]
    res = sorted(
        (a for a in d.explanation.effects if a.effect == "resonance"),
        key=lambda a: a.params["frequency"],
    )
    assert len(res) == 2, [(a.effect, a.params) for a in d.explanation.effects]
    for a, true in zip(res, truth, strict=True):
        # the frequency within the true resonance's own half-power half-width
        assert abs(a.params["frequency"] - true.frequency) <= true.damping * true.frequency
    assert {"resonance", "resonance_2"} <= set(d.explanation.share)


def test_the_two_resonance_model_pastes_and_simulates(two_resonances) -> None:  # type: ignore[no-untyped-def]
    model, _, d, _ = two_resonances
    terms = d.explanation.terms
    assert [t["type"] for t in terms].count("resonance") == 2
    combined = NoiseModel.from_dict({**model.to_dict(), "terms": terms})
    x = np.asarray(combined.simulate(4096, fs=FS, seed=5), dtype=np.float64).ravel()
    assert np.all(np.isfinite(x))
    # both resonances are in the model: its Allan variance is the rest's plus theirs
    tau = np.array([0.01, 0.05, 0.1, 1.0])
    rest = NoiseModel.from_dict(
        {**model.to_dict(), "terms": [t for t in terms if t["type"] != "resonance"]}
    )
    added = sum(term_from_dict(t).avar(tau, 1 / FS) for t in terms if t["type"] == "resonance")
    np.testing.assert_allclose(combined.avar(tau, 1 / FS), rest.avar(tau, 1 / FS) + added)


def test_without_a_second_band_one_resonance_is_named(two_resonances, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """The control: with one band-pass excess per record (the previous rule) the set holds
    one resonance only."""
    import allanite.diagnosis.engine as engine

    _, _, _, x = two_resonances
    model = two_resonances[0]
    monkeypatch.setattr(engine, "band_shapes", lambda *a: band_shapes(*a, n_max=1))
    d = diagnose(fit_half(x), model, fs=FS, units="deg/s", n_mc=40, seed=22)
    assert [a.effect for a in d.explanation.effects].count("resonance") <= 1


@pytest.mark.slow
def test_real_base_resonance_next_to_the_gyros_own(shared_data, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """ADIS16405 z gyro: run 1's fitted model (white + rate random walk) as the simulation, run
    2 with a 35-Hz resonance (Q 5) injected as the record (the validation's real-base case).
    The gyro has a 20-Hz resonance of its own: both are named, each within the injected or the
    control's half-power half-width. With one band per record (the previous rule) the
    injected resonance is not named (the set was quantization + Gauss-Markov)."""
    import allanite.diagnosis.engine as engine

    model, load = _adis_base(axis=2)
    res = T["resonance"](N=0.197, frequency=35.0, damping=0.1)  # Allan variance peak 8x
    n = 2**16
    injected = NoiseModel((res,), UNITS).simulate(n, fs=FS, seed=1024, allow_aliasing=True)
    x = load(2)[:n] + np.asarray(injected, dtype=np.float64).ravel()
    kw = {"fs": FS, "units": "deg/s", "holdout": None, "n_mc": 60, "seed": 1018}

    def resonances(d) -> list[tuple[float, float]]:  # type: ignore[no-untyped-def]
        """(frequency, damping) of the named resonances, lowest first."""
        return sorted(
            (a.params["frequency"], a.params["damping"])
            for a in d.explanation.effects
            if a.effect == "resonance"
        )

    def frequencies(d) -> list[float]:  # type: ignore[no-untyped-def]
        return [f for f, _ in resonances(d)]

    control = resonances(diagnose(fit_half(load(2)[:n]), model, **kw))
    assert len(control) == 1  # the gyro's own
    (f_own, zeta_own) = control[0]
    own, injected_f = frequencies(diagnose(fit_half(x), model, **kw))
    assert abs(injected_f - res.frequency) <= res.damping * res.frequency
    assert abs(own - f_own) <= zeta_own * f_own
    monkeypatch.setattr(engine, "band_shapes", lambda *a: band_shapes(*a, n_max=1))
    before = frequencies(diagnose(fit_half(x), model, **kw))
    assert all(abs(f - res.frequency) > res.damping * res.frequency for f in before)


# --- a narrow resonance is not a line ---------------------------------------------------------


def _narrow_pair(seed: int, *extra: object) -> np.ndarray:
    """White noise + a narrow resonance at 12 Hz (Q ~ 17) + a second one at 31 Hz (Q ~ 6)."""
    model = NoiseModel((T["white"](N=0.05),), UNITS)
    low = T["resonance"](N=0.4, frequency=12.0, damping=0.03)
    high = T["resonance"](N=0.3, frequency=31.0, damping=0.08)
    return np.asarray(model.plus(low, high, *extra).simulate(2**15, fs=FS, seed=seed)).ravel()


def test_a_narrow_resonance_is_not_reported_as_a_line() -> None:
    """Seed 21: the 12-Hz resonance (half-power band 11.6-12.4 Hz) is narrower than the line
    contrast's running median on the fitted half (17 bins of 0.098 Hz): its own peak has
    contrast 0.77 against a threshold of 0.71, and a 'line' at 11.85 Hz used to be reported
    and added to the set as a sine. With the resonance expected, it is not a line."""
    model = NoiseModel((T["white"](N=0.05),), UNITS)
    d = diagnose(fit_half(_narrow_pair(21)), model, fs=FS, units="deg/s", n_mc=40, seed=22)
    assert d.frequency.lines == []
    assert d.explanation is not None
    names = [a.effect for a in d.explanation.effects]
    assert names.count("resonance") == 2
    assert "sine" not in names
    assert "spectral line" not in d.headline


def test_a_sine_inside_a_resonance_band_is_still_a_line() -> None:
    """The control: a sinusoid at 12.2 Hz (amplitude 0.5) inside the narrow resonance's band
    keeps its line (contrast 1.99; its power sits in one or two bins, so it still stands out
    with the resonance expected). At amplitude 0.3 its contrast over the resonance's own is
    at the threshold (1.24 before, within the resonance's peak contrast of it after)."""
    model = NoiseModel((T["white"](N=0.05),), UNITS)
    sine = T["sine"](amplitude=0.5, frequency=12.2)
    d = diagnose(fit_half(_narrow_pair(21, sine)), model, fs=FS, units="deg/s", n_mc=40, seed=22)
    assert any(abs(ln.frequency_hz - 12.2) < 0.05 for ln in d.frequency.lines)
    assert d.frequency.line_p_value < 0.05


def test_lines_beyond_nothing_keeps_the_view() -> None:
    model = NoiseModel((T["white"](N=0.05),), UNITS)
    x = _narrow_pair(23, T["sine"](amplitude=0.1, frequency=20.0))
    d = diagnose(x, model, fs=FS, units="deg/s", n_mc=20, seed=1, effects=["sine"])
    fv = d.frequency
    same = fv.lines_beyond(np.zeros_like(fv.f))
    assert same.lines == fv.lines
    assert same.line_p_value == pytest.approx(fv.line_p_value)
