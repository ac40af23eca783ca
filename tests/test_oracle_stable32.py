"""Stable32 results on the reference clock data of ../shared/data/stability.

Each Stable32 table lists ``AF Tau # Alpha MinSigma Sigma MaxSigma``. Checked here:

* the deviation to 1e-4 relative and the number of terms exactly, every table;
* the confidence limits to 1e-3 relative where the table has them, with the EDF computed from
  Stable32's own noise type (so that the EDF algorithm is tested on its own);
* the noise identification exactly wherever the lag-1 autocorrelation method applies (at least
  30 decimated points), apart from the documented differences below.

Phase data (seconds) is ``input="angle"`` with ``fs = 1 / tau0``; frequency data is
``input="rate"``.
"""

from __future__ import annotations

import functools
import gzip
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import allanite

KIND = {
    "Allan": "standard",
    "Overlapping Allan": "overlapping",
    "Modified Allan": "modified",
    "Time": "time",
    "Hadamard": "standard_hadamard",
    "Overlapping Hadamard": "hadamard",
    "Total": "total",
}


@dataclass(frozen=True)
class DataSet:
    folder: str
    data: str
    input: str
    tables: tuple[str, ...]


SETS = (
    DataSet(
        "phasedat",
        "PHASE.DAT",
        "angle",
        tuple(
            f"phase_dat_{s}{v}.txt"
            for s in ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")
            for v in ("", "_octave")
        ),
    ),
    DataSet(
        "ocxo",
        "ocxo_frequency.txt",
        "rate",
        tuple(
            f"{s}_octave.txt" for s in ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")
        )
        + tuple(
            f"stable32_{s}_alltau.txt"
            for s in ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")
        ),
    ),
    DataSet(
        "gps",
        "gps_1pps_phase_data.txt.gz",
        "angle",
        (
            "stable32_ADEV_decade.txt",
            *tuple(
                f"stable32_{s}_octave.txt"
                for s in ("OADEV", "MDEV", "TDEV", "HDEV", "OHDEV", "TOTDEV")
            ),
        ),
    ),
    DataSet(
        "Cs5071A",
        "5071A_phase.txt.gz",
        "angle",
        tuple(
            f"{s}_{v}.txt"
            for s in ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")
            for v in ("decade", "all")
        ),
    ),
    DataSet(
        "Keysight53230A_ti_noise_floor",
        "tic_phase.txt",
        "angle",
        tuple(f"tic_{s}.txt" for s in ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")),
    ),
    DataSet(
        "pink_frequency",
        "pink_frequency.txt",
        "rate",
        (
            *tuple(f"{s}.txt" for s in ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev")),
            "s32_oadev_octave.txt",
            "totdev_alpha0.txt",
        ),
    ),
)

CASES = [pytest.param(s, t, id=f"{s.folder}/{t}") for s in SETS for t in s.tables]

#: OCXO *_octave tables were made from f / 1e7 instead of (f - 1e7) / 1e7 (see the data
#: README: 7.6143e-11 vs 7.6106e-11 at 1 s); their deviations are checked through the
#: *_alltau tables of the same data, their confidence limits relative to their own sigma.
RENORMALISED = {
    ("ocxo", f"{s}_octave.txt")
    for s in ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")
}

#: Total-deviation runs made with a fixed noise type (Alpha 0 throughout although the same data
#: identifies otherwise in every other table).
FIXED_ALPHA = {
    ("Cs5071A", "totdev_decade.txt"),
    ("ocxo", "stable32_totdev_alltau.txt"),
    ("pink_frequency", "totdev_alpha0.txt"),
}

#: Known disagreements of the lag-1 identification, by averaging factor. Keysight all-tau ADEV:
#: Stable32 reports one power lower at these factors of the white-PM counter floor (lag-1 ACF
#: 0.34-0.44, where delta is just above the 0.25 differencing threshold), and at 30-31
#: decimated points (1824, 1868, 1913), the edge of the 30-point rule. Cs5071A m = 18784: 29.65
#: decimated points, the same edge (the overlapping tables agree there).
KNOWN_ALPHA_DIFFERENCES = {
    ("Keysight53230A_ti_noise_floor", "tic_adev.txt"): {
        *(126, 190, 360, 408, 789, 890, 1004, 1370),
        *(1824, 1868, 1913),
    },
    ("Cs5071A", "adev_all.txt"): {18784},
    ("Cs5071A", "hdev_all.txt"): {18784},
}

#: GPS TOTDEV at m = 65536 > N/4 (3.7 averages) with flicker PM: Stable32's EDF there is not
#: the SP1065 Table 5 formula it uses at every shorter tau (implied EDF 44 vs 42).
KNOWN_CI_DIFFERENCES = {("gps", "stable32_TOTDEV_octave.txt"): {65536}}


@dataclass(frozen=True)
class Table:
    kind: str
    level: float
    m: np.ndarray
    n: np.ndarray
    alpha: np.ndarray
    lo: np.ndarray
    dev: np.ndarray
    hi: np.ndarray
    tau0: float


def _parse(path: Path) -> Table:
    header = [
        line for line in path.read_text(errors="replace").splitlines() if line.startswith("#")
    ]
    sigma_type = next(line.split(":", 1)[1].strip() for line in header if "Sigma Type" in line)
    level = next(
        (float(line.split("=")[1]) for line in header if "Confidence Factor" in line), 0.683
    )
    rows = np.loadtxt(path, comments="#", ndmin=2)
    return Table(
        kind=KIND[sigma_type],
        level=level,
        m=rows[:, 0].astype(np.int64),
        n=rows[:, 2].astype(np.int64),
        alpha=rows[:, 3].astype(np.int64),
        lo=rows[:, 4],
        dev=rows[:, 5],
        hi=rows[:, 6],
        tau0=float(rows[0, 1] / rows[0, 0]),
    )


@functools.cache
def _record(root: str, folder: str, name: str) -> np.ndarray:
    path = Path(root) / "stability" / folder / name
    opener = gzip.open if name.endswith(".gz") else open
    with opener(path, "rt") as fh:
        values = np.loadtxt(fh, comments="#")
    if folder == "ocxo":  # Hz of a 10 MHz oscillator -> fractional frequency, as Stable32
        values = (values - 1e7) / 1e7
    return values


#: The Cs5071A all-tau tables (557k points, ~270 taus each) are checked at every third tau to
#: keep the suite within its time budget; the decade tables of the same data are complete.
THIN = {"Cs5071A": 3}


def _table(shared_data: Path, ds: DataSet, name: str) -> Table:
    table = _parse(shared_data / "stability" / ds.folder / name)
    step = THIN.get(ds.folder, 1) if name.endswith("_all.txt") else 1
    if step == 1:
        return table
    keep = np.arange(table.m.size) % step == 0
    fields = {f: getattr(table, f) for f in ("m", "n", "alpha", "lo", "dev", "hi")}
    return Table(
        table.kind, table.level, tau0=table.tau0, **{k: v[keep] for k, v in fields.items()}
    )


def _compute(shared_data: Path, ds: DataSet, table: Table, **kwargs: Any) -> allanite.AllanResult:
    x = _record(str(shared_data), ds.folder, ds.data)
    return allanite.avar(
        x, fs=1.0 / table.tau0, input=ds.input, kind=table.kind, m=table.m, **kwargs
    )


@functools.cache
def _identified(root: str, ds: DataSet, name: str) -> tuple[Table, allanite.AllanResult]:
    """The table and allanite's result with Stable32's per-tau noise identification (cached).

    ``alpha="stable32"``: the identification as Stable32 makes it, without the smoothing of
    isolated flips that :func:`allanite.avar` applies by default.
    """
    table = _table(Path(root), ds, name)
    return table, _compute(Path(root), ds, table, alpha="stable32")


def _decimated_points(ds: DataSet, n_record: int, m: np.ndarray) -> np.ndarray:
    if ds.input == "angle":
        return -(-n_record // m)  # len(x[::m])
    return n_record // m  # non-overlapping averages of m frequency values


@pytest.mark.parametrize(("ds", "name"), CASES)
def test_deviation_and_number_of_terms(shared_data: Path, ds: DataSet, name: str) -> None:
    table, res = _identified(str(shared_data), ds, name)
    np.testing.assert_array_equal(res.n_terms, table.n)
    if (ds.folder, name) in RENORMALISED:
        pytest.skip("deviations of the renormalised OCXO octave tables: see the *_alltau tables")
    np.testing.assert_allclose(res.dev, table.dev, rtol=1e-4)


@pytest.mark.parametrize(
    ("ds", "name"),
    [c for c in CASES if not any(k in c.id for k in ("_all.txt", "alltau", "phase_dat_adev.txt"))],
)
def test_confidence_limits(shared_data: Path, ds: DataSet, name: str) -> None:
    table = _table(shared_data, ds, name)
    if not np.any(table.lo):
        pytest.skip("this Stable32 table has no confidence limits")
    res = _compute(shared_data, ds, table, alpha=table.alpha)
    lo, hi = res.ci(table.level)
    keep = ~np.isin(table.m, list(KNOWN_CI_DIFFERENCES.get((ds.folder, name), ())))
    if (ds.folder, name) in RENORMALISED:  # compare the limits relative to each sigma
        np.testing.assert_allclose((lo / res.dev)[keep], (table.lo / table.dev)[keep], rtol=1e-3)
        np.testing.assert_allclose((hi / res.dev)[keep], (table.hi / table.dev)[keep], rtol=1e-3)
    else:
        np.testing.assert_allclose(lo[keep], table.lo[keep], rtol=1e-3)
        np.testing.assert_allclose(hi[keep], table.hi[keep], rtol=1e-3)


@pytest.mark.parametrize(("ds", "name"), CASES)
def test_noise_identification(shared_data: Path, ds: DataSet, name: str) -> None:
    if (ds.folder, name) in FIXED_ALPHA:
        pytest.skip("Stable32 ran this table with a fixed noise type")
    table, res = _identified(str(shared_data), ds, name)
    x = _record(str(shared_data), ds.folder, ds.data)
    acf = _decimated_points(ds, x.size, table.m) >= allanite.variance.edf.ACF_MIN_POINTS
    known = np.isin(table.m, list(KNOWN_ALPHA_DIFFERENCES.get((ds.folder, name), ())))
    check = acf & ~known
    assert check.sum() >= 1
    mismatch = table.m[check][res.alpha[check] != table.alpha[check]]
    assert mismatch.size == 0, f"alpha differs from Stable32 at m = {mismatch.tolist()}"
    # the documented differences are still what they were (one power lower in Stable32)
    if known.any():
        assert np.all(res.alpha[known] != table.alpha[known])
