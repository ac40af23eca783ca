"""The memory budget honours cgroup and ulimit -v limits; oversized simulations are refused
before allocating (issue 31, item 8)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from allanite import memory
from allanite.cli import main
from allanite.model import NoiseModel
from allanite.terms import White


def test_budget_is_bounded_by_the_address_space_limit() -> None:
    """Under ``ulimit -v`` the budget is at most the limit (MemAvailable alone ignored it)."""
    code = (
        "import resource; from allanite.memory import available_memory; "
        "limit = 3 << 30; resource.setrlimit(resource.RLIMIT_AS, (limit, limit)); "
        "print(available_memory() <= limit)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "True", out.stderr


def test_budget_is_bounded_by_the_cgroup_limit(tmp_path: Path) -> None:
    relative = Path("/proc/self/cgroup").read_text().strip() if Path("/proc").exists() else ""
    if "::" not in relative:
        pytest.skip("no cgroup v2 here")
    group = tmp_path / relative.split("::", 1)[1].lstrip("/")
    group.mkdir(parents=True, exist_ok=True)
    (group / "memory.max").write_text(f"{1 << 30}\n")
    (group / "memory.current").write_text(f"{256 << 20}\n")
    assert memory._cgroup(tmp_path) == (1 << 30) - (256 << 20)
    (group / "memory.max").write_text("max\n")
    assert memory._cgroup(tmp_path) is None


@pytest.mark.parametrize("case", ["channels", "terms"])
def test_oversized_simulation_is_refused_before_allocating(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    case: str,
) -> None:
    monkeypatch.setattr(memory, "available_memory", lambda: 2 << 30)  # a 2 GiB machine
    model = tmp_path / "model.json"
    terms = (White(N=0.01),) * (100_000 if case == "terms" else 1)
    model.write_text(NoiseModel(terms, "rad/s").to_json())
    out = tmp_path / "sim.npy"
    channels = "1000000" if case == "channels" else "1"
    argv = ["simulate", str(model), "--fs", "100", "-n", "10", "--n-channels", channels]
    assert main([*argv, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "GiB available" in err
    assert "Traceback" not in err
    assert not out.exists()


def test_ordinary_simulation_still_fits(tmp_path: Path) -> None:
    model = tmp_path / "model.json"
    model.write_text(NoiseModel((White(N=0.01),), "rad/s").to_json())
    out = tmp_path / "sim.npy"
    argv = ["simulate", str(model), "--fs", "100", "-n", "1000", "--n-channels", "3", "-o"]
    assert main([*argv, str(out)]) == 0
    assert np.load(out).shape == (1000, 3)
