"""The original synthesis procedure end to end on real data (ADIS16405 run 1, gyro X).

Fit a model to the real record (the benchmark's clearly labelled simple stand-in fit until
allanite.fit lands), simulate a record of the same length, and require the simulated Allan
variance to stay inside the real curve's 99% chi-square band wherever the fit itself is good
(the model inside the real 68% band). benchmarks/sim_to_real_adis.py draws the figure.
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
    real, sim, model, good, inside = procedure.compare(x)
    assert len(model) >= 2
    # the comparison must cover most of the curve to mean something
    assert good.sum() >= 0.5 * good.size, f"fit good at only {good.sum()} of {good.size} taus"
    bad = real.tau[good & ~inside]
    assert bad.size == 0, f"simulated AVAR outside the real 99% band at tau = {bad}"
    # and the simulated record is not the real one in disguise
    assert not np.allclose(sim.var, real.var, rtol=1e-3)
