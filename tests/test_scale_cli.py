"""CLI options of the large-record path: --memory-limit and --fast on allanite analyze."""

from __future__ import annotations

import json

import numpy as np

from allanite.cli import main


def test_analyze_memory_limit_and_fast(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    x = np.random.default_rng(4).standard_normal(40_000)
    path = tmp_path / "rec.npy"
    np.save(path, x)
    outputs = {}
    for name, extra in {
        "plain": [],
        "limited": ["--memory-limit", "150kB"],
        "fast": ["--fast"],
    }.items():
        assert main(["analyze", str(path), "--fs", "100", "--json", *extra]) == 0
        outputs[name] = json.loads(capsys.readouterr().out)
    assert list(tmp_path.iterdir()) == [path]  # the temporary phase file is gone
    plain, limited, fast = outputs["plain"], outputs["limited"], outputs["fast"]

    def column(data, key):
        return np.array(data["allan"][key])

    assert np.array_equal(column(plain, "var"), column(limited, "var"))
    tau = column(plain, "tau")
    short = tau < 0.32  # m < 2q = 32: exact in fast mode
    assert np.array_equal(column(plain, "var")[short], column(fast, "var")[short])
    assert not np.array_equal(column(plain, "var"), column(fast, "var"))
