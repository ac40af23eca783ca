"""ADIS16405 run1 gyro x: N of the fit against the PSD plateau (README, the sensor filter).

Usage: ``python benchmarks/adis_filter_fit.py [TERMS]`` (default ``auto``; the README quotes
``auto`` on main and ``moving_average,B,K``). Needs ../shared/data/imu/adis16405.
"""

import sys
import time

import numpy as np
from scipy import signal

import allanite

terms = sys.argv[1] if len(sys.argv) > 1 else "auto"
d = np.load("../shared/data/imu/adis16405/run1.npz")
x = d["gyro_counts"][:, 0] * 0.05  # deg/s
fs = 100.0
f, p = signal.welch(x - x.mean(), fs=fs, nperseg=1 << 14)
band = (f > 0.5) & (f < 3.0)
print("PSD plateau N (0.5-3 Hz):", np.sqrt(np.median(p[band]) / 2) * 60, "deg/sqrt(h)")
t = time.time()
r = allanite.fit(x, fs=fs, units="deg/s", **({} if terms == "auto" else {"terms": terms}))
print(terms, "time", round(time.time() - t), "s rejected", r.rejected, "p", r.p_value)
print(r.model)
for k, c in r.coefficients.items():
    print(k, c.value, c.unit, c.ci(0.95))
