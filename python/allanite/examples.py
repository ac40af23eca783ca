"""Example model and record: the rate gyro of the original work.

Coefficients (deg/s units): quantization Q = 2.45e-3 deg, angle random walk
N = 6.153e-3 deg/sqrt(s), bias instability B = 6.619e-5 deg/s, rate random walk
K = 8.1e-4 deg/s/sqrt(s), rate ramp R = 1.039e-8 deg/s^2. :func:`example_record` simulates
30 minutes of angle at 100 Hz from them with a fixed seed, so examples, docs and tests see
the same numbers everywhere.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from allanite.io.record import Record
from allanite.model import NoiseModel
from allanite.terms import Flicker, Quantization, RateRamp, RateRandomWalk, White

__all__ = ["EXAMPLE_FS", "EXAMPLE_SEED", "example_as_record", "example_model", "example_record"]

EXAMPLE_FS = 100.0
EXAMPLE_DURATION_S = 1800.0
EXAMPLE_SEED = 20_240_521


def example_model() -> NoiseModel:
    """Return the original work's rate-gyro model (deg/s): Q, N, B, K, R."""
    return NoiseModel(
        (
            Quantization(Q=2.45e-3),
            White(N=6.153e-3),
            Flicker(B=6.619e-5),
            RateRandomWalk(K=8.1e-4),
            RateRamp(R=1.039e-8),
        ),
        {"rate": "deg/s", "time": "s"},
    )


def example_record(**overrides: Any) -> tuple[NDArray[np.float64], float]:
    """Simulate the example: 30 min of angle (deg) at 100 Hz, fixed seed.

    Parameters
    ----------
    **overrides
        Optional ``output``, ``duration``, ``n_channels`` or ``seed`` passed on to
        :meth:`NoiseModel.simulate`.

    Returns
    -------
    tuple
        ``(samples, fs)``; with the defaults 180,000 angle samples in degrees and 100.0 Hz.
    """
    options: dict[str, Any] = {
        "duration": EXAMPLE_DURATION_S,
        "output": "angle",
        "seed": EXAMPLE_SEED,
    }
    options.update(overrides)
    return example_model().simulate(fs=EXAMPLE_FS, **options), EXAMPLE_FS


def example_as_record() -> Record:
    """The example as a :class:`~allanite.io.Record`: angle in deg at 100 Hz.

    The CLI's ``--example`` and the GUI's example button load this record.
    """
    samples, fs = example_record()
    return Record(
        samples=samples,
        fs=float(fs),
        input="angle",
        units="deg",
        channels=("example",) if samples.ndim == 1 else (),
        source="example record (simulated, 30 min at 100 Hz)",
    )
