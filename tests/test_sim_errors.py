"""Bad input to the simulator and its CLI: clear errors, no partial files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from allanite.cli import main
from allanite.examples import example_model, example_record
from allanite.model import NoiseModel
from allanite.simulation import parse_duration, simulate
from allanite.terms import GaussMarkov, Sine, Telegraph, White


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: White(N=-1.0), "non-negative"),
        (lambda: GaussMarkov(sigma=1.0, tau_c=0.0), "positive"),
        (lambda: GaussMarkov(sigma=1.0, tau_c=-2.0), "non-negative"),
        (lambda: Telegraph(amplitude=1.0, tau_c=0.0), "positive"),
    ],
)
def test_bad_coefficients(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_tone_above_nyquist_needs_the_aliasing_flag():
    model = [Sine(amplitude=1.0, frequency=80.0)]
    with pytest.raises(ValueError, match="above the Nyquist frequency"):
        simulate(model, 100, fs=100.0, seed=1)
    aliased = simulate(model, 100, fs=100.0, seed=1, allow_aliasing=True)
    # an 80 Hz tone sampled at 100 Hz shows up at its alias, 20 Hz
    spectrum = np.abs(np.fft.rfft(aliased))
    assert np.fft.rfftfreq(100, 0.01)[np.argmax(spectrum)] == pytest.approx(20.0)


def test_events_far_faster_than_the_sampling_are_refused():
    from allanite.terms import BiasSteps

    with pytest.raises(ValueError, match="events per sample"):
        simulate([Telegraph(amplitude=1.0, tau_c=1e-6)], 100, fs=100.0, seed=1)
    with pytest.raises(ValueError, match="events per sample"):
        simulate([BiasSteps(size=1.0, interval=1e-5)], 100, fs=100.0, seed=1)


def test_flicker_cutoff_above_nyquist_is_refused():
    from allanite.terms import Flicker

    with pytest.raises(ValueError, match="Nyquist"):
        simulate([Flicker(B=1.0, f0=80.0)], 100, fs=100.0, seed=1)
    with pytest.raises(ValueError, match="aliased part is not simulated"):
        simulate([Flicker(B=1.0, f0=80.0)], 100, fs=100.0, seed=1, allow_aliasing=True)
    assert simulate([Flicker(B=1.0, f0=20.0)], 100, fs=100.0, seed=1).shape == (100,)


def test_progress_reports_every_sample(tmp_path):
    from allanite.model import NoiseModel
    from allanite.simulation.writers import write_record
    from allanite.terms import White

    calls = []
    model = NoiseModel((White(N=1.0),), {"rate": "deg/s", "time": "s"})
    write_record(
        tmp_path / "x.npy", model, 1000, fs=100.0, seed=1, progress=lambda *a: calls.append(a)
    )
    assert calls
    assert calls[-1] == ("simulate", 1000, 1000)
    assert [c[1] for c in calls] == sorted(c[1] for c in calls)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"fs": 0.0, "n": 10}, ValueError, "positive"),
        ({"fs": -5.0, "n": 10}, ValueError, "positive"),
        ({"fs": 10.0, "n": 0}, ValueError, "positive length"),
        ({"fs": 10.0, "duration": "0s"}, ValueError, "positive"),
        ({"fs": 10.0, "duration": 0.01}, ValueError, "positive length"),
        ({"fs": 10.0}, ValueError, "n .samples. or duration"),
        ({"fs": 10.0, "n": 10, "output": "volts"}, ValueError, "unknown output"),
        ({"fs": 10.0, "n": 10, "n_channels": 0}, ValueError, "n_channels"),
        ({"fs": 10.0, "n": 10, "seed": -1}, ValueError, "non-negative"),
        ({"fs": 10.0, "n": 10, "seed": "x"}, TypeError, "seed"),
        ({"fs": 10.0, "n": 2.5}, TypeError, "whole number"),
    ],
)
def test_bad_arguments(kwargs, error, match):
    with pytest.raises(error, match=match):
        simulate([White(N=1.0)], **kwargs)


def test_model_simulate_needs_fs():
    with pytest.raises(TypeError, match="sampling frequency"):
        example_model().simulate(100)


def test_empty_model():
    with pytest.raises(ValueError, match="no terms"):
        simulate(NoiseModel(()), 10, fs=10.0)


@pytest.mark.parametrize(
    ("text", "seconds"),
    [("90", 90), ("90s", 90), ("30min", 1800), ("1.5h", 5400), ("2d", 172800), (12.5, 12.5)],
)
def test_parse_duration(text, seconds):
    assert parse_duration(text) == seconds


@pytest.mark.parametrize("text", ["", "h", "5 weeks", "-1h", "1e400s"])
def test_parse_duration_rejects(text):
    with pytest.raises(ValueError, match="duration"):
        parse_duration(text)


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "model.json"
    example_model().save(path)
    return path


@pytest.mark.parametrize("suffix", [".npy", ".csv", ".bin"])
def test_cli_writes_the_same_samples_as_the_api(tmp_path, model_file, suffix):
    out = tmp_path / f"out{suffix}"
    code = main(
        [
            "simulate",
            str(model_file),
            "--fs",
            "100",
            "--duration",
            "1min",
            "-o",
            str(out),
            "--output",
            "angle",
            "--seed",
            "7",
            "--channels",
            "2",
        ]
    )
    assert code == 0
    expected = example_model().simulate(6000, fs=100.0, output="angle", n_channels=2, seed=7)
    if suffix == ".npy":
        got = np.load(out)
    elif suffix == ".csv":
        got = np.loadtxt(out, delimiter=",", skiprows=1)
        assert out.read_text().splitlines()[0] == "angle_0[deg],angle_1[deg]"
    else:
        got = np.fromfile(out, dtype="<f8").reshape(-1, 2)
    assert np.array_equal(got, expected)


def test_cli_bad_input_exits_2_without_a_file(tmp_path, model_file, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(
        json.dumps(
            {
                "units": {"rate": "deg/s", "time": "s"},
                "terms": [{"type": "sine", "amplitude": 1.0, "frequency": 80.0}],
            }
        )
    )
    out = tmp_path / "out.npy"
    assert main(["simulate", str(bad), "--fs", "100", "-n", "100", "-o", str(out)]) == 2
    assert "Nyquist" in capsys.readouterr().err
    assert main(["simulate", str(model_file), "--fs", "0", "-n", "100", "-o", str(out)]) == 2
    assert (
        main(
            ["simulate", str(model_file), "--fs", "10", "-n", "10", "-o", str(tmp_path / "out.xyz")]
        )
        == 2
    )
    assert (
        main(
            ["simulate", str(model_file), "--fs", "10", "--duration", "1 fortnight", "-o", str(out)]
        )
        == 2
    )
    assert list(tmp_path.iterdir()) == [model_file, bad] or sorted(tmp_path.iterdir()) == sorted(
        [model_file, bad]
    )


def test_example_record_is_fixed_and_follows_its_model():
    x, fs = example_record()
    assert x.shape == (180_000,)
    assert fs == 100.0
    y, _ = example_record()
    assert np.array_equal(x, y)
    import allanite

    result = allanite.avar(x, fs=fs, input="angle", taus="octave", alpha=2)
    # short tau is quantization-dominated: 3 Q^2 / tau^2 + N^2 / tau, within 1% at tau = dt
    theory = example_model().avar(result.tau[:1], 1.0 / fs)
    np.testing.assert_allclose(result.var[:1], theory, rtol=0.01)
