"""Calibration of the (segment-normalised) line detector on null records (issue 14).

60 records of the validation base model (2^14 samples at 100 Hz) diagnosed against their own
model (n_mc = 40): the line p-value must be about uniform, and no record a false alarm.
Run ``nice python benchmarks/line_detector_null.py``.
"""

import argparse
import time

import numpy as np

from allanite.diagnosis import diagnose
from validate_diagnosis import base_model

argparse.ArgumentParser(
    description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
).parse_args()  # --help describes the run instead of starting it

m = base_model(100.0)
ps, sig, closed = [], 0, 0
t = time.time()
for i in range(60):
    x = m.simulate(2**14, fs=100.0, seed=5000 + i)
    d = diagnose(x, m, fs=100.0, units="deg/s", n_mc=40, seed=i)
    ps.append(d.frequency.line_p_value)
    sig += d.significant
    closed += d.closed
ps = np.array(ps)
print(
    "n=60 line p<0.1:",
    np.mean(ps < 0.1),
    "p<0.25:",
    np.mean(ps < 0.25),
    "p<0.5:",
    np.mean(ps < 0.5),
    "false alarms:",
    sig,
    "closed:",
    closed,
    time.time() - t,
)
