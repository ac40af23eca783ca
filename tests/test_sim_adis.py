"""The original synthesis procedure end to end on real data (ADIS16405 run 1, gyro X).

Fit a model to the real record with allanite.fit, simulate a record of the same length, and
require the simulated Allan variance to stay inside the real curve's 99% chi-square band
wherever the fit itself is good (the taus it does not flag as missed).
benchmarks/sim_to_real_adis.py draws the figure.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "sim_to_real_adis.py"


def _procedure():
    spec = importlib.util.spec_from_file_location("sim_to_real_adis", BENCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_simulated_twin_stays_in_the_real_band(shared_data):
    procedure = _procedure()
    x = procedure.load_gyro_x(shared_data / "imu" / "adis16405" / "run1.npz")
    assert x.shape == (1_000_000,)
    real, sim, fitted, good, inside = procedure.compare(x)
    assert len(fitted.model) >= 2
    # the comparison must cover a wide range to mean something: at least two decades of tau
    assert good.any()
    span = real.tau[good].max() / real.tau[good].min()
    assert span >= 100, f"fit good only over tau = {real.tau[good]}"
    bad = real.tau[good & ~inside]
    assert bad.size == 0, f"simulated AVAR outside the real 99% band at tau = {bad}"
    # and the simulated record is not the real one in disguise
    assert not np.allclose(sim.var, real.var, rtol=1e-3)
