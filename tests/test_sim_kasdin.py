"""Flicker by Kasdin's fractional filter: coefficients, exact law, plateau, streaming, CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import integrate, special, stats

import allanite
from allanite.cli import build_parser, main
from allanite.model import NoiseModel
from allanite.simulation import simulate, simulate_chunks
from allanite.simulation.flicker import FLICKER_METHODS, flicker_stream
from allanite.simulation.kasdin import (
    KASDIN_MAX_SAMPLES,
    KasdinStream,
    kasdin_coefficients,
)
from allanite.terms import Flicker, White
from allanite.terms.flicker import PLATEAU
from allanite.terms.flicker_laws import kasdin_avar

FS = 100.0
DT = 1.0 / FS


def test_coefficients_follow_the_recursion_and_the_gamma_closed_form():
    h = kasdin_coefficients(2000)
    expected = [1.0]
    for k in range(1, 2000):
        expected.append(expected[-1] * (k - 1 + 0.5) / k)
    np.testing.assert_allclose(h, expected, rtol=1e-13, atol=0)
    k = np.arange(2000)
    closed = np.exp(special.gammaln(k + 0.5) - special.gammaln(0.5) - special.gammaln(k + 1.0))
    np.testing.assert_allclose(h, closed, rtol=1e-11, atol=0)
    # other exponents: alpha = 2 is the random walk (all ones)
    np.testing.assert_array_equal(kasdin_coefficients(5, alpha=2.0), np.ones(5))


def test_stationary_law_equals_the_discrete_psd_integral():
    # sigma^2(m dt) = B^2 int_0^1/2 2 sin^4(pi m u) / (m^2 sin^3(pi u)) du  (Kasdin's PSD)
    B = 3.0
    m = np.array([1, 2, 3, 7, 20])
    got = kasdin_avar(m * DT, DT, B)
    for mm, value in zip(m, got, strict=True):
        integral, _ = integrate.quad(
            lambda u, mm=mm: 2 * np.sin(np.pi * mm * u) ** 4 / (mm**2 * np.sin(np.pi * u) ** 3),
            0.0,
            0.5,
            limit=400,
            epsabs=0.0,
            epsrel=1e-12,
        )
        assert value == pytest.approx(B**2 * integral, rel=1e-10)
    # closed form at tau = dt: 2 B^2 / pi
    assert float(kasdin_avar(DT, DT, B)) == pytest.approx(2 * B**2 / math.pi, rel=1e-12)


def test_short_tau_departure_and_plateau_of_the_exact_law():
    m = np.array([1, 2, 4, 10, 100, 1000, 10_000, 100_000])
    ratio = kasdin_avar(m * DT, DT, 1.0) / Flicker(B=1.0).avar(m * DT, DT)
    # the table of the module docstring
    np.testing.assert_allclose(ratio[:5], [1.704, 1.182, 1.0569, 1.0116, 1.0002], atol=6e-4)
    # the plateau 2 ln2 / pi B^2 from 100 dt on
    np.testing.assert_allclose(kasdin_avar(m[4:] * DT, DT, 1.0) / PLATEAU, 1.0, atol=2e-4)


def test_truncated_record_law_departs_by_about_0_06_tau_over_t():
    for n in (1000, 1 << 20):
        m = np.array([1, n // 100, n // 10])
        stationary = kasdin_avar(m * DT, DT, 1.0)
        departure = 1.0 - kasdin_avar(m * DT, DT, 1.0, n_samples=n) / stationary
        # zero history lowers the law, by 0.035-0.06 tau / T (0.59% at T/10, any length)
        slope = departure / (m / n)
        assert np.all((slope > 0.035) & (slope < 0.06)), slope
        assert departure[-1] == pytest.approx(5.9e-3, abs=1e-4)


def test_truncated_law_matches_the_brute_force_expectation():
    # E[overlapping AVAR] from the covariance of the truncated filter x = L w, built densely
    n, B = 64, 1.5
    h = kasdin_coefficients(n)
    L = np.array([[h[i - j] if i >= j else 0.0 for j in range(n)] for i in range(n)])
    cov = B**2 * L @ L.T
    for m in (1, 3, 8, 21):
        windows = n - 2 * m + 1
        total = 0.0
        for start in range(windows):
            c = np.zeros(n)
            c[start : start + m] = -1.0 / m
            c[start + m : start + 2 * m] = 1.0 / m
            total += 0.5 * c @ cov @ c
        assert float(kasdin_avar(m * DT, DT, B, n_samples=n)) == pytest.approx(
            total / windows, rel=1e-12
        )


def test_chi_square_coverage_over_50_seeds():
    n, channels, B = 1 << 14, 50, 1e-3
    x = simulate([Flicker(B=B)], n, fs=FS, n_channels=channels, seed=404, flicker_method="kasdin")
    result = allanite.avar(x, fs=FS, taus="octave")
    keep = result.tau <= n * DT / 10.0
    theory = kasdin_avar(result.tau[keep], DT, B, n_samples=n)[:, None]
    lo, hi = result.var_ci(0.95)
    inside = (lo[keep] <= theory) & (theory <= hi[keep])
    assert 0.90 <= inside.mean() <= 0.99, f"coverage {inside.mean():.3f}"
    # the test has power: the term's band-limited law (70% lower at dt) is rejected
    term_law = Flicker(B=B).avar(result.tau[keep], DT)[:, None]
    assert ((lo[keep] <= term_law) & (term_law <= hi[keep])).mean() < 0.85


@pytest.mark.slow
def test_long_kasdin_record_holds_the_plateau_over_three_decades():
    n, channels, B = 1 << 21, 4, 1e-3
    stream = flicker_stream(Flicker(B=B), FS, channels, seed=77, n_samples=n, method="kasdin")
    x = np.concatenate([stream.next(1 << 19) for _ in range(4)])
    m = np.unique(np.round(np.logspace(np.log10(100), np.log10(100_000), 13))).astype(np.int64)
    result = allanite.avar(x, fs=FS, m=m, alpha=-1)
    # pooled estimate of the channels and its 99% chi-square band
    edf = result.edf.sum(axis=1)
    pooled = (result.var * result.edf).sum(axis=1) / edf
    lo = pooled * edf / stats.chi2.ppf(0.995, edf)
    hi = pooled * edf / stats.chi2.ppf(0.005, edf)
    plateau = PLATEAU * B**2
    # the 0.664 B plateau itself lies in the band at every tau, 1 s to 1000 s
    assert np.all((lo <= plateau) & (plateau <= hi)), np.sqrt(pooled / PLATEAU) / B
    # and so does the record's exact law
    exact = kasdin_avar(result.tau, DT, B, n_samples=n)
    assert np.all((lo <= exact) & (exact <= hi))


def test_stream_is_chunk_independent():
    n = 3 * 70_001
    whole = KasdinStream(2e-3, n, FS, 3, seed=5).next(n)
    stream = KasdinStream(2e-3, n, FS, 3, seed=5)
    pieces = [stream.next(size) for size in (1, 65_535, 70_000, n - 135_536)]
    assert np.array_equal(np.concatenate(pieces), whole)


@pytest.mark.parametrize("chunk", [4096, 65_535, 100_000])
def test_chunked_model_equals_one_shot_bit_for_bit(chunk):
    model = [White(N=1e-3), Flicker(B=2e-3)]
    n = 3 * 70_001
    whole = simulate(model, n, fs=FS, n_channels=3, seed=21, flicker_method="kasdin")
    pieces = simulate_chunks(
        model, n, fs=FS, n_channels=3, seed=21, chunk=chunk, flicker_method="kasdin", output="rate"
    )
    assert np.array_equal(np.concatenate(list(pieces)), whole)
    # the method is really used: the spectral samples of the same seed differ
    assert not np.array_equal(whole, simulate(model, n, fs=FS, n_channels=3, seed=21))


def test_model_simulate_passes_the_method():
    model = NoiseModel((Flicker(B=1.0),))
    via_model = model.simulate(5000, fs=FS, seed=8, flicker_method="kasdin")
    direct = flicker_stream(
        Flicker(B=1.0),
        FS,
        1,
        np.random.SeedSequence(8).spawn(1)[0],
        n_samples=5000,
        method="kasdin",
    ).next(5000)[:, 0]
    assert np.array_equal(via_model, direct)


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (
            lambda: flicker_stream(Flicker(B=1.0), FS, 1, 1, method="kasdin"),
            ValueError,
            "needs the record length",
        ),
        (
            lambda: flicker_stream(
                Flicker(B=1.0), FS, 1, 1, n_samples=KASDIN_MAX_SAMPLES + 1, method="kasdin"
            ),
            ValueError,
            "limited to",
        ),
        (
            lambda: flicker_stream(
                Flicker(B=1.0), FS, 16, 1, n_samples=KASDIN_MAX_SAMPLES, method="kasdin"
            ),
            ValueError,
            "samples x channels",
        ),
        (
            lambda: flicker_stream(
                Flicker(B=1.0, f0=10.0), FS, 1, 1, n_samples=100, method="kasdin"
            ),
            ValueError,
            "no cutoff",
        ),
        (
            lambda: simulate([Flicker(B=1.0)], 100, fs=FS, flicker_method="fft"),
            ValueError,
            "unknown flicker_method",
        ),
        (lambda: kasdin_avar([0.015], DT, 1.0), ValueError, "whole multiples"),
        (lambda: kasdin_avar([0.0], DT, 1.0), ValueError, "positive"),
        (lambda: kasdin_avar([DT], DT, -1.0), ValueError, "non-negative"),
        (lambda: kasdin_avar([DT], DT, "1"), TypeError, "B must be a number"),
        (lambda: kasdin_avar([0.5], DT, 1.0, n_samples=99), ValueError, "tau <= n_samples"),
        (lambda: kasdin_coefficients(0), ValueError, "at least one"),
        (lambda: kasdin_coefficients(4, alpha=2.5), ValueError, "alpha"),
    ],
)
def test_bad_input_is_refused(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_cli_flicker_method(tmp_path):
    model = NoiseModel((Flicker(B=1e-3), White(N=1e-4)))
    path = tmp_path / "model.json"
    path.write_text(json.dumps(model.to_dict()))
    out = tmp_path / "kasdin.npy"
    argv = ["simulate", str(path), "--fs", "100", "-n", "3000", "--seed", "3", "-o", str(out)]
    assert main([*argv, "--flicker-method", "kasdin"]) == 0
    expected = model.simulate(3000, fs=FS, seed=3, flicker_method="kasdin")
    assert np.array_equal(np.load(out), expected)
    assert main(argv) == 0  # default auto: spectral synthesis for this length
    assert np.array_equal(np.load(out), model.simulate(3000, fs=FS, seed=3))


def test_cli_refuses_kasdin_with_a_cutoff_and_unknown_methods(tmp_path, capsys):
    path = tmp_path / "model.json"
    path.write_text(json.dumps(NoiseModel((Flicker(B=1e-3, f0=10.0),)).to_dict()))
    out = tmp_path / "x.npy"
    argv = ["simulate", str(path), "--fs", "100", "-n", "300", "-o", str(out)]
    assert main([*argv, "--flicker-method", "kasdin"]) == 2
    assert "no cutoff" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(SystemExit):
        main([*argv, "--flicker-method", "fft"])
    for method in FLICKER_METHODS:  # every library method is offered
        assert (
            build_parser().parse_args([*argv, "--flicker-method", method]).flicker_method == method
        )
