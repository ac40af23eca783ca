"""Hostile inputs: configs and records refused cleanly, in bounded time (issue 31).

Each case is generated here (no large files in the repository) and must end in a
ValueError/InputError with a short message well inside a time bound that the old code
exceeded by minutes (measured old times in the comments; the bound is generous for a
loaded CI machine).
"""

from __future__ import annotations

import time
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from allanite.cli import main
from allanite.errors import InputError
from allanite.formats import kalibr, matlab, px4_plugin
from allanite.formats.base import number
from allanite.io import read_record
from allanite.model import NoiseModel
from allanite.terms import White

#: seconds; the old code took minutes on each case below
BOUND = 5.0
#: longest message accepted (a message must not echo unbounded input)
MESSAGE = 2000


def _refused(read: Callable[[str], object], text: str, match: str | None = None) -> str:
    start = time.monotonic()
    with pytest.raises(ValueError, match=match) as info:
        read(text)
    assert time.monotonic() - start < BOUND
    message = str(info.value)
    assert len(message) < MESSAGE
    return message


def test_px4_unclosed_element_with_spaces_is_linear() -> None:
    # old: 22 s for 2,000 spaces, about cubic (255 s for 10,000); 100,000 here
    text = (
        "<plugin name='imu' filename='libgazebo_imu_plugin.so'><gyroscopeNoiseDensity>"
        + " " * 100_000
        + "<gyroscopeRandomWalk>x</gyroscopeRandomWalk></plugin>"
    )
    _refused(px4_plugin.read, text, "gyroscopeRandomWalk")


def test_px4_value_with_spacing_still_read_and_rewritten() -> None:
    text = (
        "<plugin filename='libgazebo_imu_plugin.so'>\n"
        "  <gyroscopeNoiseDensity>  0.0003  </gyroscopeNoiseDensity>\n</plugin>\n"
    )
    config = px4_plugin.read(text)
    written = px4_plugin.write(config, template=text, rate=250.0).text
    assert "<gyroscopeNoiseDensity>  0.0003  </gyroscopeNoiseDensity>" in written


@pytest.mark.parametrize(
    "text",
    [
        "a" * 100_000,  # old: 59 s at 20,000 (quadratic)
        "a." * 50_000,
        "gyroparams('NoiseDensity', [" + "1" * 100_000 + "x])",
        "gyroparams(" * 9_000,
        "x = 1\n" + "\n" * 100_000,
    ],
    ids=["word", "dotted", "digits", "nested-calls", "blank-lines"],
)
def test_matlab_pathological_lines_are_bounded(text: str) -> None:
    _refused(matlab.read, text)


def test_yaml_alias_bomb_is_refused() -> None:
    # nine anchors of ten aliases: 10^9 leaves once expanded (old: > 60 s, 3 GB)
    lines = ["a: &a [x, x, x, x, x, x, x, x, x, x]"]
    for i in range(8):
        name, prev = chr(98 + i), chr(97 + i)
        lines.append(f"{name}: &{name} [" + ", ".join([f"*{prev}"] * 10) + "]")
    text = "\n".join(lines) + "\ngyroscope_noise_density: *i\n"
    _refused(kalibr.read, text, "alias")


def test_scalar_yaml_alias_is_still_read() -> None:
    text = (
        "rate: &r 200\nupdate_rate: *r\ngyroscope_noise_density: 1.0e-4\n"
        "gyroscope_random_walk: 1.0e-6\naccelerometer_noise_density: 1.0e-3\n"
        "accelerometer_random_walk: 1.0e-5\n"
    )
    assert kalibr.read(text).rate == 200


def test_number_message_is_bounded() -> None:
    nested: list[object] = ["x"] * 10
    for _ in range(6):
        nested = [nested] * 10
    with pytest.raises(ValueError, match="expected a number") as info:
        number(nested, "gyroscope_noise_density")
    assert len(str(info.value)) < 200
    with pytest.raises(ValueError, match="expected a number") as info:
        number("9" * 10_000 + "x", "gyroscope_noise_density")
    assert len(str(info.value)) < 200


def _npz_with_text_member(path: Path) -> None:
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("notes.txt", "not an array")


def test_npz_member_not_npy_is_an_input_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.npz"
    _npz_with_text_member(bad)
    start = time.monotonic()
    with pytest.raises(InputError, match=r"bad\.npz: cannot read it as npz"):
        read_record(bad, fs=100.0)
    assert time.monotonic() - start < BOUND


def test_batch_writes_the_table_with_an_error_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(6)
    goods = []
    for i in range(2):
        goods.append(tmp_path / f"good{i}.npy")
        np.save(goods[-1], rng.normal(0.0, 0.01, 3000))
    bad = tmp_path / "bad.npz"
    _npz_with_text_member(bad)
    out = tmp_path / "out.csv"
    rc = main(["batch", *map(str, goods), str(bad), "--fs", "100", "-o", str(out)])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert rc in (0, 1)
    text = out.read_text()
    rows = {Path(line.split(",")[0]).name: line for line in text.splitlines()[1:]}
    assert ",error," in rows["bad.npz"]
    assert "cannot read it as npz" in rows["bad.npz"]
    assert len(rows) == 3


@pytest.mark.parametrize("fs", ["1e-320", "1e-300", "1e300"])
@pytest.mark.parametrize("command", ["analyze", "simulate"])
def test_extreme_fs_is_refused_with_the_range(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], fs: str, command: str
) -> None:
    rec = tmp_path / "rec.npy"
    np.save(rec, np.random.default_rng(7).normal(0.0, 0.01, 2000))
    out = tmp_path / "sim.npy"
    model = tmp_path / "model.json"
    model.write_text(NoiseModel((White(N=0.01),), "rad/s").to_json())
    argv = {
        "analyze": ["analyze", str(rec), "--fs", fs],
        "simulate": ["simulate", str(model), "--fs", fs, "-n", "1000", "-o", str(out)],
    }[command]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "outside the range allanite computes with" in err
    assert "Traceback" not in err
    assert not out.exists()
