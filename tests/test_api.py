"""The public API's conventions: fs keyword-only, Records everywhere, real named deviations."""

from __future__ import annotations

import inspect
import warnings

import numpy as np
import pytest

import allanite
from allanite.io import Record, Segment
from allanite.variance import estimate

DEVIATIONS = ("adev", "oadev", "mdev", "hdev", "ohdev", "tdev", "totdev")


def _white(n: int = 4000, c: int = 1, seed: int = 1) -> np.ndarray:
    x = np.random.default_rng(seed).standard_normal((n, c))
    return x[:, 0] if c == 1 else x


@pytest.mark.parametrize("name", ["avar", "avar_large", *DEVIATIONS])
def test_fs_is_keyword_only_and_required_for_raw_samples(name):
    func = getattr(allanite, name)
    params = inspect.signature(func).parameters
    assert params["fs"].kind is inspect.Parameter.KEYWORD_ONLY
    assert not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()) or (
        name == "avar_large"  # its **open_options describe a raw binary file
    )
    x = _white()
    with pytest.raises(TypeError, match=r"fs .* is required for a raw array"):
        func(x)
    with pytest.raises(TypeError, match="positional"):
        func(x, 10.0)


@pytest.mark.parametrize("name", DEVIATIONS)
def test_named_deviations_are_documented_functions_of_their_kind(name):
    func = getattr(allanite, name)
    assert func.__module__ == "allanite.variance.estimate"
    assert func.__doc__
    assert "Parameters" in func.__doc__
    assert "Returns" in func.__doc__
    x = _white()
    got = func(x, fs=10.0, alpha=0)
    kind = inspect.signature(func).return_annotation  # resolved lazily: a string here
    assert kind == "AllanResult"
    expected = allanite.avar(x, fs=10.0, alpha=0, kind=got.kind)
    np.testing.assert_array_equal(got.var, expected.var)
    assert got.kind in estimate.__doc__ or got.kind in func.__doc__


@pytest.mark.parametrize("name", ["avar", "avar_large", *DEVIATIONS])
def test_every_variance_function_takes_a_record(name):
    func = getattr(allanite, name)
    x = _white(3000, c=2)
    record = Record(samples=x, fs=50.0, input="rate", units="deg/s", channels=("x", "y"))
    got = func(record)
    raw = func(x, fs=50.0, input="rate", units="deg/s")
    np.testing.assert_array_equal(got.var, raw.var)
    assert got.fs == 50.0
    assert got.units == "deg/s"
    assert got.meta["channels"] == ["x", "y"]
    if isinstance(got, allanite.AllanResult):  # one channel keeps its own name only
        assert got.channel(1).meta["channels"] == ["y"]


def test_a_record_brings_input_and_unit_and_its_longest_segment():
    angle = np.cumsum(_white(5000)) * 0.01
    record = Record(
        samples=angle,
        fs=100.0,
        input="angle",
        units="deg",
        segments=(Segment(0, 1000), Segment(1000, 5000, 10.5)),
    )
    got = allanite.avar(record, alpha=0)
    raw = allanite.avar(angle[1000:], fs=100.0, input="angle", units="deg", alpha=0)
    np.testing.assert_array_equal(got.var, raw.var)
    assert got.input == "angle"
    assert got.units == "deg/s"
    assert got.var.ndim == 1
    assert got.meta["segment"] == 1


def test_a_record_rejects_contradicting_fs_input_or_units():
    record = Record(samples=_white(), fs=100.0, input="rate", units="deg/s")
    assert allanite.avar(record, fs=100.0).fs == 100.0  # agreeing is fine
    with pytest.raises(ValueError, match="contradicts the record's own fs"):
        allanite.avar(record, fs=200.0)
    with pytest.raises(ValueError, match="contradicts the record's input"):
        allanite.avar(record, input="angle")
    with pytest.raises(ValueError, match="contradicts the record's unit"):
        allanite.avar(record, units="rad/s")


def test_a_record_without_fs_takes_the_given_one_or_says_how():
    record = Record(samples=_white(), fs=None, source="log.csv")
    assert allanite.avar(record, fs=20.0).fs == 20.0
    with pytest.raises(ValueError, match=r"log\.csv: the sampling frequency is unknown"):
        allanite.avar(record)


def test_no_warning_on_the_plain_path():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        allanite.oadev(_white(), fs=1.0)


def test_channels_as_a_count_is_n_channels_and_the_old_name_warns():
    from allanite.simulation import simulate
    from allanite.terms import White

    model = allanite.NoiseModel((White(N=0.1),), {"rate": "deg/s", "time": "s"})
    new = simulate(model, 200, fs=10.0, n_channels=2, seed=3)
    with pytest.warns(DeprecationWarning, match=r"channels= is renamed n_channels="):
        old = simulate(model, 200, fs=10.0, channels=2, seed=3)
    np.testing.assert_array_equal(new, old)
    with pytest.warns(DeprecationWarning, match="n_channels=2"):
        assert model.simulate(200, fs=10.0, channels=2, seed=3).shape == (200, 2)
    with pytest.raises(TypeError, match="give n_channels= only"):
        simulate(model, 200, fs=10.0, n_channels=2, channels=2)


def test_one_confidence_default_everywhere():
    from allanite.batch import batch
    from allanite.confidence import DEFAULT_LEVEL
    from allanite.fit.result import FitResult
    from allanite.plot.allan import plot_allan
    from allanite.report.build import build_report
    from allanite.report.coefficients import coefficient_table

    def default(func):
        return inspect.signature(func).parameters["level"].default

    for func in (
        allanite.AllanResult.ci,
        allanite.AllanResult.var_ci,
        FitResult.table,
        FitResult.to_dict,
        batch,
        plot_allan,
        build_report,
        coefficient_table,
    ):
        assert default(func) == DEFAULT_LEVEL, func.__qualname__
    x = _white()
    result = allanite.avar(x, fs=1.0, alpha=0)
    np.testing.assert_array_equal(result.ci()[0], result.ci(DEFAULT_LEVEL)[0])
    assert "95 % interval" in result._repr_html_()


def test_the_version_is_defined_once():
    import importlib.metadata

    assert importlib.metadata.version("allanite") == allanite.__version__


def test_read_record_takes_one_options_object_or_its_fields(tmp_path):
    from allanite.io import ReadOptions, read_record

    path = tmp_path / "gyro.csv"
    np.savetxt(path, _white(500, c=2), delimiter=",", header="gx,gy", comments="")
    options = ReadOptions(fs=50.0, units="deg/s", columns=["gy"])
    by_object = read_record(path, options)
    by_keywords = read_record(path, fs=50.0, units="deg/s", columns=["gy"])
    np.testing.assert_array_equal(by_object.samples, by_keywords.samples)
    assert by_object.channels == ("gy",)
    assert read_record(path, options, fs=25.0).fs == 25.0  # keywords override the object
    with pytest.raises(TypeError, match="unknown reader option"):
        read_record(path, sampling_rate=50.0)


def test_batch_takes_fs_by_keyword_too():
    params = inspect.signature(allanite.batch).parameters
    assert params["fs"].kind is inspect.Parameter.KEYWORD_ONLY
    with pytest.raises(TypeError, match="positional"):
        allanite.batch([_white()], 10.0)


def test_fit_takes_a_record_with_its_own_fs_input_and_unit():
    from allanite.io import Record

    rng = np.random.default_rng(31)
    x = rng.standard_normal(100_000) * 0.1  # N = 0.01 deg/sqrt(s) at 100 Hz
    angle = Record(samples=np.cumsum(x)[:, None] / 100.0, fs=100.0, input="angle", units="deg")
    from_record = allanite.fit(angle)
    from_array = allanite.fit(np.cumsum(x) / 100.0, fs=100.0, input="angle", units="deg/s")
    assert from_record.model.units == from_array.model.units
    assert from_record["N"].value == from_array["N"].value
    with pytest.raises(ValueError, match="contradicts"):
        allanite.fit(angle, input="rate")
    two = Record(samples=np.column_stack([x, x]), fs=100.0, input="rate", units="deg/s")
    with pytest.raises(ValueError, match="one channel at a time"):
        allanite.fit(two)


@pytest.mark.parametrize("call", ["simulate", "simulate_chunks", "method"])
def test_simulate_takes_fs_by_keyword(call):
    from allanite.simulation import simulate, simulate_chunks
    from allanite.terms import White

    model = allanite.NoiseModel((White(N=0.1),), {"rate": "deg/s", "time": "s"})
    run = {
        "simulate": lambda *a, **k: simulate(model, *a, **k),
        "simulate_chunks": lambda *a, **k: np.concatenate(list(simulate_chunks(model, *a, **k)))[
            :, 0
        ],
        "method": model.simulate,
    }[call]
    assert run(500, fs=100.0, seed=1).shape == (500,)
    with pytest.raises(TypeError):
        run(500, 100.0, seed=1)


def test_an_allan_result_prints_in_one_line():
    res = allanite.avar(np.random.default_rng(2).standard_normal(5000), fs=10.0, units="deg/s")
    text = repr(res)
    assert "\n" not in text
    assert text.startswith("AllanResult(kind='overlapping', ")
    assert "fs=10 Hz" in text
    assert "units='deg/s'" in text
    assert len(text) < 200


def _record_call_extras() -> dict[str, tuple[tuple, dict]]:
    """How to call each public function of allanite.__all__ with a Record as its first argument
    (the other arguments it requires). A new public function must be added here."""
    model = allanite.NoiseModel((allanite.White(N=0.3),), {"rate": "deg/s", "time": "s"})
    extras: dict[str, tuple[tuple, dict]] = {
        name: ((), {}) for name in ("avar", "avar_large", "fit", "read_record", *DEVIATIONS)
    }
    extras["batch"] = ((), {})  # takes an iterable of records: called with [record]
    extras["diagnose"] = ((model,), {"n_mc": 20, "seed": 1})
    return extras


def test_every_public_function_accepts_a_record():
    """Introspection over allanite.__all__: each function takes a Record in place of samples,
    with its fs, input and unit (no fs given), and raw samples need fs (keyword-only)."""
    functions = {
        name: obj for name in allanite.__all__ if inspect.isfunction(obj := getattr(allanite, name))
    }
    extras = _record_call_extras()
    assert set(functions) == set(extras), "a public function without a Record call in this test"
    x = _white(8000, seed=9) * 0.3
    record = Record(samples=x[:, None], fs=50.0, input="rate", units="deg/s", channels=("gz",))
    for name, func in functions.items():
        params = list(inspect.signature(func).parameters.values())
        if "fs" in inspect.signature(func).parameters:
            assert inspect.signature(func).parameters["fs"].kind is inspect.Parameter.KEYWORD_ONLY
        doc = func.__doc__ or ""
        assert "Record" in doc, f"{name}'s docstring does not say it takes a Record"
        args, kwargs = extras[name]
        first = [record] if name == "batch" else record
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            out = func(first, *args, **kwargs)
        assert out is not None, name
        if isinstance(out, allanite.AllanResult):
            assert out.fs == 50.0, name
            assert out.units == "deg/s", name
        assert params[0].kind is not inspect.Parameter.KEYWORD_ONLY, name


def test_read_record_returns_a_record_unchanged_and_refuses_options_with_it():
    record = Record(samples=_white()[:, None], fs=10.0, input="rate", units="deg/s")
    assert allanite.read_record(record) is record
    with pytest.raises(TypeError, match=r"the Record is read already.*record\.select"):
        allanite.read_record(record, fs=20.0)


def test_no_confidence_level_default_but_the_one():
    """Every ``level``/``confidence`` parameter in the package defaults to DEFAULT_LEVEL
    (found by walking every module's functions and methods, not from a hand-kept list)."""
    import importlib
    import pkgutil

    from allanite.confidence import DEFAULT_LEVEL

    checked: set[str] = set()
    wrong = []
    for info in pkgutil.walk_packages(allanite.__path__, "allanite."):
        if info.name.startswith(("allanite.gui", "allanite.__main__")):
            continue  # needs a display / runs the CLI
        try:
            module = importlib.import_module(info.name)
        except ImportError:  # an optional extra that is not installed
            continue
        for owner in [module, *(c for _, c in inspect.getmembers(module, inspect.isclass))]:
            for _, func in inspect.getmembers(owner, inspect.isfunction):
                if getattr(func, "__module__", None) != module.__name__:
                    continue
                for param in inspect.signature(func).parameters.values():
                    if param.name in ("level", "confidence") and isinstance(param.default, float):
                        checked.add(f"{module.__name__}.{func.__qualname__}")
                        if param.default != DEFAULT_LEVEL:
                            wrong.append(f"{module.__name__}.{func.__qualname__}")
    assert {"allanite.fit.result.FitResult.table", "allanite.fit.result.Coefficient.ci"} <= checked
    assert not wrong, f"confidence defaults other than {DEFAULT_LEVEL}: {wrong}"


#: public functions whose fs stays positional, and why
POSITIONAL_FS = {
    "stream": "Term.stream(fs, n_channels, seed), the Term protocol the simulation calls",
    "flicker_stream": "a generator behind Term.stream, same protocol",
    "gauss_markov_stream": "a generator behind Term.stream, same protocol",
    "averaged_gauss_markov": "a generator behind Term.stream, same protocol",
    "random_walk_stream": "a generator behind Term.stream, same protocol",
    "check_fs": "the validator of an fs value itself",
    "resolve_source": "variance-internal: resolves (source, fs, input, units) for avar",
}


def test_fs_is_keyword_only_in_every_public_function_outside_diagnosis():
    """Walk every module's __all__ (functions and public methods): fs is keyword-only. The
    diagnosis package's internals are its owners' (listed in the report, not here)."""
    import importlib
    import pkgutil

    positional = []
    for info in pkgutil.walk_packages(allanite.__path__, "allanite."):
        if info.name.startswith(("allanite.gui", "allanite.cli", "allanite.__main__")):
            continue
        if info.name.startswith("allanite.diagnosis."):
            continue
        try:
            module = importlib.import_module(info.name)
        except ImportError:  # an optional extra that is not installed
            continue
        for name in getattr(module, "__all__", []):
            obj = getattr(module, name)
            members = [(name, obj)]
            if inspect.isclass(obj):
                members = [
                    (attr, value)
                    for attr, value in vars(obj).items()
                    if inspect.isfunction(value) and not attr.startswith("_")
                ]
            for attr, func in members:
                if not inspect.isfunction(func) or attr in POSITIONAL_FS:
                    continue
                param = inspect.signature(func).parameters.get("fs")
                if param is not None and param.kind is not inspect.Parameter.KEYWORD_ONLY:
                    positional.append(f"{info.name}.{attr}")
    assert not positional, f"fs given by position in {sorted(set(positional))}"
