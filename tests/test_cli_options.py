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


@pytest.mark.parametrize("command", ["analyze", "fit"])
def test_in_memory_allan_variance_shows_progress_on_a_terminal(
    tmp_path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, command: str
) -> None:
    """Regression: on a 6 h, 2 kHz, 3-axis record ``allanite analyze`` and ``fit`` spent ~20 s
    in the Allan variance without a bar: only --memory-limit or --fast passed the callback."""
    pytest.importorskip("tqdm")
    import sys

    from allanite.cli import main

    path = tmp_path / "rec.npy"
    np.save(path, np.random.default_rng(2).standard_normal((4000, 2)))
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert main([command, str(path), "--fs", "100", "--units", "deg/s"]) == 0
    err = capsys.readouterr().err
    assert "variance" in err  # the stage bar of the tau passes
    assert "phase" in err


def test_a_record_larger_than_memory_is_analysed_out_of_core_by_default(
    tmp_path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Regression: without --memory-limit the phase array was always built in memory (8 bytes
    per sample and channel next to the samples): a record near the machine's memory failed
    instead of taking the out-of-core path the library has."""
    import allanite.cli.record_options as options
    from allanite.cli import main

    path = tmp_path / "rec.npy"
    np.save(path, np.random.default_rng(3).standard_normal((4000, 2)))
    argv = ["analyze", str(path), "--fs", "100", "--units", "deg/s", "--table"]
    assert main([*argv, "-o", str(tmp_path / "in.csv")]) == 0
    assert "out of core" not in capsys.readouterr().err
    budgets = []
    real_avar = options.avar

    def spy(*args, **kwargs):
        budgets.append(kwargs.get("memory_limit"))
        return real_avar(*args, **kwargs)

    monkeypatch.setattr(options, "avar", spy)
    monkeypatch.setattr(options, "available_memory", lambda: 100_000)  # phase: 64 kB
    assert main([*argv, "-o", str(tmp_path / "out.csv")]) == 0
    err = capsys.readouterr().err
    assert "note: the record's phase array (6.4e-05 GB) would take more than half of the " \
        "available memory: working out of core with --memory-limit 0.0671GB" in err  # fmt: skip
    assert budgets == [64 << 20]
    assert (tmp_path / "out.csv").read_text() == (tmp_path / "in.csv").read_text()
    # a kind that needs the phase in memory, or --fast, keeps the in-memory path
    budgets.clear()
    assert main([*argv, "--kind", "modified"]) == 0
    assert main([*argv, "--fast"]) == 0
    assert budgets == [None, None]
    assert "out of core" not in capsys.readouterr().err


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


def test_every_subcommand_help_has_examples_each_on_its_own_lines() -> None:
    """`allanite COMMAND --help` ends with examples; a continuation backslash that Python ate
    ("az       --units") would run two example lines into one."""
    import re

    from allanite.cli import SUBCOMMANDS, build_parser

    parser = build_parser()
    subparsers = next(a for a in parser._actions if a.dest == "command").choices
    for name in SUBCOMMANDS:
        text = subparsers[name].format_help()
        assert "examples:" in text, f"allanite {name} --help has no examples"
        examples = text.split("examples:", 1)[1]
        for line in examples.splitlines():
            assert not re.search(r"\S {3,}--\w", line.split("#")[0]), (name, line)
            if line.strip().startswith("allanite "):
                assert line.strip().split()[1] in (name, "fit", "analyze"), (name, line)


def test_reader_flags_are_the_read_options_and_survive_record_command() -> None:
    """read_record's options object is the CLI's: every ReadOptions field has a flag, and the
    command record_command writes for the next step reads the record the same way."""
    import dataclasses
    import shlex

    from allanite.cli import build_parser
    from allanite.cli.record_options import read_options, record_command
    from allanite.io import ReadOptions

    argv = [
        "analyze", "imu.bag", "--fs", "200", "--input", "angle", "--units", "deg",
        "--channels", "gx,gy", "--time-column", "t", "--time-scale", "1e-9", "--gaps", "split",
        "--scale", "0.05", "--format", "raw", "--delimiter", ";", "--header", "no",
        "--key", "imu", "--dtype", "int16", "--n-channels", "3", "--byte-order", "big",
        "--offset", "16", "--topic", "/imu1", "--fs-source", "time", "--temperature", "temp",
    ]  # fmt: skip
    parser = build_parser()
    options = read_options(parser.parse_args(argv))
    defaults = ReadOptions()
    unchanged = [
        f.name
        for f in dataclasses.fields(ReadOptions)
        if getattr(options, f.name) == getattr(defaults, f.name)
    ]
    assert not unchanged, f"ReadOptions fields no CLI flag sets: {unchanged}"
    again = shlex.split(record_command("fit", "imu.bag", parser.parse_args(argv)))
    assert read_options(parser.parse_args(again[1:])) == options
