"""Shared CLI helpers: progress bar only on a terminal, strict JSON, rate units."""

from __future__ import annotations

import json

import numpy as np
import pytest

from allanite.cli.progress import progress, progress_bars
from allanite.cli.record_options import dump_json, rate_unit
from allanite.io import Record


def test_progress_bar_on_a_terminal_only(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("tqdm")
    assert list(progress(range(3), desc="fitting")) == [0, 1, 2]
    assert capsys.readouterr().err == ""
    import sys

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert list(progress(range(3), desc="fitting", total=3)) == [0, 1, 2]
    err = capsys.readouterr().err
    assert "fitting" in err
    assert "0/3" in err  # the bar was drawn (and cleared: leave=False)


def test_progress_bars_callback_draws_one_bar_per_stage(
    capsys: pytest.CaptureFixture[str],
) -> None:
    pytest.importorskip("tqdm")
    with progress_bars(True) as bar:
        for i in range(1, 4):
            bar("phase", i * 10, 30)
        bar("variance", 5, 5)
    err = capsys.readouterr().err
    assert "phase" in err
    assert "0/30" in err  # the bar of the first stage, cleared when the next began
    assert "variance" in err
    with progress_bars(False) as bar:
        bar("phase", 1, 2)
    assert capsys.readouterr().err == ""


def test_dump_json_is_strict() -> None:
    text = dump_json({"a": [1.0, float("nan"), float("inf")], "b": {"c": float("-inf")}})
    assert json.loads(text) == {"a": [1.0, None, None], "b": {"c": None}}


@pytest.mark.parametrize(
    ("input", "units", "expected"),
    [
        ("rate", "deg/s", "deg/s"),
        ("angle", "deg", "deg/s"),
        ("increment", "rad", "rad/s"),
        ("rate", None, None),
    ],
)
def test_rate_unit(input: str, units: str | None, expected: str | None) -> None:
    record = Record(samples=np.zeros((4, 1)), fs=1.0, input=input, units=units)
    assert rate_unit(record) == expected


def test_cli_errors_name_the_option_not_the_keyword(tmp_path, capsys) -> None:
    """A newcomer running `allanite fit run1.npz` is told `--key NAME`, then `--fs HZ`: the
    library's "key= (CLI: --key NAME)" is said once, in the command line's spelling."""
    from allanite.cli import cli_spelling, main

    path = tmp_path / "two.npz"
    x = np.random.default_rng(1).standard_normal(1000)
    np.savez(path, gyro=x, accel=x)
    assert main(["fit", str(path)]) == 2
    err = capsys.readouterr().err
    assert "choose one with --key NAME" in err
    assert "key=" not in err
    assert "CLI:" not in err
    assert main(["fit", str(path), "--key", "gyro"]) == 2
    err = capsys.readouterr().err
    assert "the sampling frequency is unknown; give it with --fs HZ" in err
    assert "fs=" not in err
    assert cli_spelling("give rate= (CLI: --rate HZ; diagnose: --sim-rate HZ)") == (
        "give --rate HZ (diagnose: --sim-rate HZ)"
    )
    assert cli_spelling("no keyword here (--time-column)") == "no keyword here (--time-column)"
