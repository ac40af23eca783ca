"""The sensor's own output filter (issue 27): one Term, its exact law, simulation and fit.

Records are built by an independent generator (numpy white noise through
``scipy.signal.lfilter``), never by allanite.simulation.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import signal, stats

import allanite
from allanite.fit.spec import resolve_terms
from allanite.terms import GaussMarkov, LowPassWhite, term_from_dict
from allanite.variance import oracle

FS = 100.0
DT = 1.0 / FS


def _filtered_white(seed: int, n: int, N: float, b: np.ndarray, a: np.ndarray) -> np.ndarray:
    rng = np.random.default_rng(seed)
    burn = 20_000
    w = N * math.sqrt(FS) * rng.standard_normal(n + burn)
    return np.asarray(signal.lfilter(b, a, w)[burn:])


def _random_walk(seed: int, n: int, K: float) -> np.ndarray:
    rng = np.random.default_rng(seed + 1000)
    return np.cumsum(rng.standard_normal(n)) * K * math.sqrt(DT)


def test_one_pole_law_is_the_sampled_ar1_and_tends_to_the_rc_law() -> None:
    bw = 2.0
    phi = math.exp(-2.0 * math.pi * bw * DT)
    # y = phi y + (1 - phi) x with Var(x) = N^2 / dt: an AR(1) with innovation (1-phi)^2/dt
    ar1 = GaussMarkov.from_ar1(phi, (1.0 - phi) ** 2 / DT, DT)
    m = np.array([1, 2, 3, 7, 30, 100, 500, 5000], dtype=float)
    term = LowPassWhite(1.0, bw, "one_pole")
    np.testing.assert_allclose(term.avar(m * DT, DT), ar1.avar(m * DT, DT), rtol=1e-8)
    rc = LowPassWhite(1.0, 0.05)  # cutoff far below the sample rate: digital = analog
    assert abs(LowPassWhite(1.0, 0.05, "one_pole").avar(20.0, DT) / rc.avar(20.0, DT) - 1) < 1e-3


@pytest.mark.parametrize(
    ("kind", "order", "design"),
    [
        ("butterworth", 4.0, lambda: signal.butter(4, 5.0, fs=FS)),
        ("moving_average", None, lambda: (np.ones(10) / 10, np.ones(1))),
        ("bartlett", None, lambda: (np.convolve(np.ones(6), np.ones(6)) / 36, np.ones(1))),
    ],
)
def test_exact_law_matches_the_oracle_on_an_lfilter_record(kind, order, design) -> None:
    b, a = design()
    term = LowPassWhite(0.01, 5.0, kind, order)
    if kind != "butterworth":  # the box length that the bandwidth names
        length = 10 if kind == "moving_average" else 6
        c = {"moving_average": 0.4429464706890664, "bartlett": 0.3189166986852232}[kind]
        term = LowPassWhite(0.01, c / (length * DT), kind)
        assert term.length(DT) == pytest.approx(length)
    n = 400_000
    x = _filtered_white(3, n, 0.01, b, a)
    m = np.array([1, 2, 4, 8, 16, 64, 256])
    measured = oracle.variance(x, m, "overlapping")
    predicted = term.avar(m * DT, DT)
    # a 1e-3 two-sided check per tau with a conservative EDF (n / (2m) independent pairs)
    edf = n / (2.0 * m)
    lo = stats.chi2.ppf(0.0005, edf) / edf
    hi = stats.chi2.ppf(0.9995, edf) / edf
    ratio = measured / predicted
    assert np.all((ratio > lo) & (ratio < hi)), ratio


def test_closed_form_beyond_the_support_is_n2_over_tau_less_the_r1_part() -> None:
    term = LowPassWhite(1.0, 0.4429464706890664 / (10 * DT), "moving_average")
    # a 10-tap box: R0 = 1/dt, R1 = sum |k| r(k) = (1/dt) * 2 * sum_k k (10-k)/100 = 3.3/dt
    m = np.array([20.0, 200.0])
    expected = (1.0 / m - 1.5 * 3.3 / m**2) / DT
    np.testing.assert_allclose(term.avar(m * DT, DT), expected, rtol=1e-8)  # L = 10 to 1e-9


def test_json_round_trip_and_clear_errors() -> None:
    term = LowPassWhite(0.01, 5.0, "butterworth", 4.0)
    data = term.to_dict()
    assert data == {
        "type": "lowpass_white", "N": 0.01, "bandwidth": 5.0, "order": 4.0, "filter": "butterworth"
    }  # fmt: skip
    assert term_from_dict(data) == term
    assert LowPassWhite(0.01, 5.0).to_dict() == {
        "type": "lowpass_white",
        "N": 0.01,
        "bandwidth": 5.0,
    }
    with pytest.raises(ValueError, match="must be one of rc, one_pole"):
        term_from_dict({**data, "filter": "chebyshev"})
    with pytest.raises(ValueError, match="order is the order of a butterworth"):
        LowPassWhite(0.01, 5.0, "moving_average", 3.0)


def test_stream_is_the_filtered_white_whatever_the_chunks() -> None:
    term = LowPassWhite(0.01, 5.0, "butterworth", 4.0)
    one = term.stream(FS, 2, 7).next(50_000)
    stream = term.stream(FS, 2, 7)
    parts = np.concatenate([stream.next(k) for k in (1, 999, 17_000, 32_000)])
    np.testing.assert_array_equal(one, parts)
    psd_level = term.psd_sampled(np.array([0.01]), DT)[0]
    assert psd_level == pytest.approx(2.0 * 0.01**2, rel=1e-6)  # N is the unfiltered density
    m = np.array([1, 8, 64])
    measured = oracle.variance(one[:, 0], m, "overlapping")
    edf = one.shape[0] / (2.0 * m)
    ratio = measured / term.avar(m * DT, DT)
    assert np.all(np.abs(np.log(ratio)) < 3.3 * np.sqrt(2.0 / edf)), ratio


def test_terms_names_lists_and_auto_plus() -> None:
    assert [s.cls.type for s in resolve_terms("N,B,K").specs] == ["white", "flicker", "rrw"]
    assert [s.cls.type for s in resolve_terms("white,flicker,rrw").specs] == [
        "white", "flicker", "rrw"
    ]  # fmt: skip
    plus = resolve_terms("auto+markov")
    assert plus.auto
    assert "markov" in [s.cls.type for s in plus.specs]
    forced = resolve_terms("auto+filter")
    assert forced.force_filters
    assert len(forced.filters) >= 3
    spec = resolve_terms("butterworth4,K").specs[0]
    assert spec.template == LowPassWhite(1.0, 1.0, "butterworth", 4.0)
    with pytest.raises(ValueError, match=r"unknown term 'chebyshev'; fit one of: .*lowpass"):
        resolve_terms("chebyshev")
    with pytest.raises(ValueError, match="list it instead of 'N'"):
        resolve_terms("N,lowpass")


@pytest.mark.slow
def test_auto_with_a_butterworth_recovers_the_unfiltered_sensor() -> None:
    n = 100_000
    N, K = 0.01, 1e-4
    b, a = signal.butter(4, 5.0, fs=FS)
    x = _filtered_white(1, n, N, b, a) + _random_walk(1, n, K)
    fit = allanite.fit(x, fs=FS, terms="auto+butterworth4")
    (term,) = [t for t in fit.model.terms if isinstance(t, LowPassWhite)]
    assert not fit.rejected
    assert term.filter == "butterworth"
    assert term.order == 4.0
    lo, hi = fit.coefficients["bandwidth"].ci(0.999)
    assert lo < 5.0 < hi
    lo, hi = fit.coefficients["N"].ci(0.999)
    assert lo < N < hi


@pytest.mark.slow
def test_named_moving_average_fit_recovers_the_length() -> None:
    n = 100_000
    N = 0.01
    x = _filtered_white(2, n, N, np.ones(10) / 10, np.ones(1)) + _random_walk(2, n, 1e-4)
    fit = allanite.fit(x, fs=FS, terms="moving_average,K")
    (term,) = [t for t in fit.model.terms if isinstance(t, LowPassWhite)]
    lo, hi = fit.coefficients["bandwidth"].ci(0.999)
    truth = 0.4429464706890664 / (10 * DT)
    assert lo < truth < hi
    assert term.length(DT) == pytest.approx(10, rel=0.1)
    lo, hi = fit.coefficients["N"].ci(0.999)
    assert lo < N < hi


def test_tau_range_fits_only_the_taus_inside() -> None:
    rng = np.random.default_rng(5)
    x = 0.01 * math.sqrt(FS) * rng.standard_normal(100_000)
    full = allanite.fit(x, fs=FS, terms="N")
    part = allanite.fit(x, fs=FS, terms="N", tau_range=(0.5, 50.0))
    assert part.tau.min() >= 0.5
    assert part.tau.max() <= 50.0
    assert part.tau.size < full.tau.size
    with pytest.raises(ValueError, match="no tau of the curve lies in tau_range"):
        allanite.fit(x, fs=FS, terms="N", tau_range=(1e5, 1e6))
    with pytest.raises(ValueError, match="tau_range needs 0 <= lo < hi"):
        allanite.fit(x, fs=FS, terms="N", tau_range=(5.0, 1.0))


def test_cli_terms_and_tau_range(tmp_path, capsys) -> None:
    from allanite.cli import main

    n = 60_000
    x = _filtered_white(4, n, 0.01, np.ones(10) / 10, np.ones(1))
    data = tmp_path / "rate.npy"
    np.save(data, x)
    args = ["fit", str(data), "--fs", "100", "--units", "deg/s", "--json"]
    assert main([*args, "--terms", "moving_average", "--tau-range", ":200"]) == 0
    out = json.loads(capsys.readouterr().out)
    (term,) = out["channels"][0]["model"]["terms"]
    assert term["type"] == "lowpass_white"
    assert term["filter"] == "moving_average"
    assert main([*args, "--terms", "N", "--tau-range", "1:50"]) == 0
    (term,) = json.loads(capsys.readouterr().out)["channels"][0]["model"]["terms"]
    assert term["type"] == "white"
    assert main([*args, "--terms", "chebyshev"]) == 2
    assert "unknown term 'chebyshev'; fit one of:" in capsys.readouterr().err
    assert main([*args, "--tau-range", "5"]) == 2
    assert "--tau-range '5': write LO:HI" in capsys.readouterr().err


def _one_pole(seed: int, n: int, N: float, fc: float) -> np.ndarray:
    phi = math.exp(-2.0 * math.pi * fc * DT)
    return _filtered_white(seed, n, N, np.array([1.0 - phi]), np.array([1.0, -phi]))


def test_default_fit_selects_the_sensor_filter_and_names_it(tmp_path, capsys) -> None:
    """Plain ``auto``: a one-pole record's roll-off asks for the filter (before: N alone,
    chi2 1e6, N 3.7x low); N and the bandwidth of the generator are recovered."""
    from allanite.cli import main

    n, N, fc, K = 100_000, 0.01, 2.0, 1e-4
    x = _one_pole(11, n, N, fc) + _random_walk(11, n, K)
    fit = allanite.fit(x, fs=FS, units="deg/s")
    (term,) = [t for t in fit.model.terms if isinstance(t, LowPassWhite)]
    assert not fit.rejected
    assert term.filter == "one_pole"
    for name, truth in (("N", N), ("bandwidth", fc)):
        lo, hi = fit.coefficients[name].ci(0.999)
        assert lo < truth < hi, (name, lo, hi)
    assert "first-order (digital) low-pass, -3 dB at 2" in fit.goodness_line()
    data = tmp_path / "rate.npy"
    np.save(data, x)
    assert main(["fit", str(data), "--fs", "100", "--units", "deg/s"]) == 0
    assert "sensor output filter: first-order (digital) low-pass" in capsys.readouterr().out


def test_default_fit_does_not_try_filters_on_an_unfiltered_record(monkeypatch) -> None:
    """The gate: white + random walk (accepted) and white + a drift the power laws reject
    both leave the filters untried (the searches cost seconds to minutes each)."""
    import importlib

    filters = importlib.import_module("allanite.fit.filters")
    tried: list[object] = []
    real = filters.select_terms

    def spy(specs, *args, **kwargs):
        tried.extend(s for s in specs if s.cls is LowPassWhite)
        return real(specs, *args, **kwargs)

    monkeypatch.setattr(filters, "select_terms", spy)
    n = 100_000
    rng = np.random.default_rng(12)
    white = 0.01 * math.sqrt(FS) * rng.standard_normal(n)
    fit = allanite.fit(white + _random_walk(12, n, 1e-4), fs=FS)
    assert not fit.rejected
    t = np.arange(n) * DT
    drift = allanite.fit(white + 0.01 * np.sin(2 * math.pi * t / 50.0), fs=FS)
    assert drift.rejected
    assert not [t for t in drift.model.terms if isinstance(t, LowPassWhite)]
    assert tried == []


def test_slope_regions_and_readouts_skip_the_filter_roll_off() -> None:
    """The filter's hump (+0.3 then 0 slopes at the short taus) named no rate random walk
    and no bias instability (before: K read at 0.03 s, 40x the generator's); the control,
    white + flicker-like + random walk with no filter, keeps its rows."""
    from allanite.fit.classic import classic_readout
    from allanite.slopes import FILTER_ROLLOFF, rolloff_end, slope_table

    n = 200_000
    x = _one_pole(13, n, 0.01, 2.0) + _random_walk(13, n, 1e-5)
    res = allanite.avar(x, fs=FS)
    end = rolloff_end(res.tau, res.dev)
    assert end is not None
    assert 0.2 < end < 1.0
    rows = slope_table(res.tau, res.dev, res.edf)
    before = [r for r in rows if r.tau_max < end]
    assert before
    assert all(r.term == FILTER_ROLLOFF and r.symbol == "" for r in before)
    assert not [r for r in rows if r.symbol in ("B", "K")]
    readout = classic_readout(res.tau, res.dev)
    assert readout.values["K"] is None
    assert readout.values["B"] is None
    assert readout.values["N"] == pytest.approx(0.01, rel=0.15)
    rng = np.random.default_rng(14)
    plain = allanite.avar(
        0.01 * math.sqrt(FS) * rng.standard_normal(n) + _random_walk(14, n, 1e-3), fs=FS
    )
    assert rolloff_end(plain.tau, plain.dev) is None
    symbols = [r.symbol for r in slope_table(plain.tau, plain.dev, plain.edf)]
    assert symbols[0] == "N"
    assert symbols[-1] == "K"
    assert "" not in symbols
