"""Validated inputs of a diagnosis: the real record as rate samples and the simulated side.

The simulated side is either a noise model (anything with ``simulate`` and ``avar``, normally
:class:`allanite.model.NoiseModel`, or its JSON) or a simulated record. Both are turned into a
:class:`SimSource` that yields Monte Carlo replicates of the simulated sensor with the length of
the real record; every statistic of the diagnosis is calibrated against those replicates.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MIN_SAMPLES",
    "SimSource",
    "as_rate",
    "check_units",
    "load_model",
    "make_source",
]

#: shortest record the diagnosis accepts: 16 time windows of 32 samples and >= 6 octaves of tau
MIN_SAMPLES = 512


def as_rate(x: ArrayLike, fs: float, input: str, *, name: str = "real") -> NDArray[np.float64]:
    """Validate a record and return it as 1-D float64 rate samples.

    Increments ``d`` become ``d * fs``; angles ``a`` become ``diff(a) * fs`` (one sample fewer).

    Raises
    ------
    ValueError
        For NaN/inf samples, more than one channel, or a record shorter than
        :data:`MIN_SAMPLES`.
    TypeError
        For non-numeric samples.
    """
    arr = np.asarray(x)
    if arr.dtype == np.bool_ or not (
        np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)
    ):
        raise TypeError(f"the {name} record has dtype {arr.dtype}; give real numbers")
    if arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr[:, 0]
    if arr.ndim != 1:
        raise ValueError(
            f"the {name} record has shape {arr.shape}; the diagnosis works on one channel: pass "
            "x[:, k] for channel k"
        )
    out = np.asarray(arr, dtype=np.float64)
    bad = ~np.isfinite(out)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"the {name} record contains {int(bad.sum())} NaN/inf samples (first at index "
            f"{first}); remove or interpolate them before diagnosing"
        )
    if input == "rate":
        rate = out
    elif input == "increment":
        rate = out * fs
    elif input == "angle":
        rate = np.diff(out) * fs
    else:
        raise ValueError(f"unknown input {input!r}; use 'rate', 'increment' or 'angle'")
    if rate.size < MIN_SAMPLES:
        raise ValueError(
            f"the {name} record is too short for a diagnosis: {rate.size} rate samples, need at "
            f"least {MIN_SAMPLES} (16 time windows and 6 octaves of averaging time)"
        )
    return np.ascontiguousarray(rate)


def check_units(real_units: str | None, sim_units: str | None) -> str | None:
    """Return the common rate unit; raise ValueError when real and simulated units disagree."""
    if real_units is not None and sim_units is not None and not _same_unit(real_units, sim_units):
        raise ValueError(
            f"unit mismatch: the real record is in {real_units!r} but the simulated sensor "
            f"is in {sim_units!r}; convert one of them (e.g. with allanite.units) first"
        )
    return real_units if real_units is not None else sim_units


def _same_unit(a: str, b: str) -> bool:
    if a.replace(" ", "").lower() == b.replace(" ", "").lower():
        return True
    try:
        from allanite.units import convert

        return abs(convert(1.0, a, b) - 1.0) < 1e-12
    except (ImportError, ValueError, TypeError):
        return False


def load_model(sim: Any) -> Any:
    """Return a NoiseModel from a model object, its JSON text or dict, or a JSON file path."""
    if hasattr(sim, "simulate") and hasattr(sim, "avar"):
        return sim
    if isinstance(sim, (str, Path)) and not str(sim).strip().startswith("{"):
        path = Path(sim)
        if not path.is_file():
            raise ValueError(f"model file {path} not found; give a NoiseModel JSON file")
    try:
        from allanite.model import NoiseModel
    except ImportError as exc:  # pragma: no cover - only before the model module exists
        raise TypeError("a noise model needs allanite.model.NoiseModel, which is missing") from exc
    if isinstance(sim, Path):
        return NoiseModel.load(sim)
    if isinstance(sim, str):
        text = sim.strip()
        if not text.startswith("{"):
            return NoiseModel.load(text)
        return NoiseModel.from_json(text)
    if isinstance(sim, dict):
        return NoiseModel.from_json(json.dumps(sim))
    raise TypeError(
        f"sim must be a NoiseModel, its JSON (text, dict or path) or a simulated record array, "
        f"got {type(sim).__name__}"
    )


@dataclass
class SimSource:
    """The simulated sensor as a source of Monte Carlo replicates.

    Attributes
    ----------
    fs : float
        Sampling frequency in Hz.
    model : NoiseModel or None
        The model (``kind == "model"``).
    record : numpy.ndarray or None
        The simulated record truncated to the real length (``kind == "record"``).
    units : str or None
        Rate unit of the simulated side.
    """

    fs: float
    model: Any = None
    record: NDArray[np.float64] | None = None
    units: str | None = None
    _spectra: dict[int, NDArray[np.float64]] = field(default_factory=dict, repr=False)

    @property
    def kind(self) -> str:
        """``"model"`` or ``"record"``."""
        return "model" if self.model is not None else "record"

    def replicates(self, n: int, count: int, seed: int) -> Iterator[NDArray[np.float64]]:
        """``count`` independent simulated rate records of length ``n``.

        A model is simulated with its own generators (seeds ``seed, seed+1, ...``). A record is
        resampled as a Gaussian process with its smoothed, mirror-extended periodogram (random
        amplitudes and phases), an approximation that keeps the spectrum but not the
        non-Gaussian features of the record.
        """
        rng = np.random.default_rng(seed)
        if self.model is None:
            for _ in range(count):
                yield self._surrogate(n, rng)
            return
        # several replicates per call (as channels) while a batch stays below ~32 MB
        batch = int(max(1, min(count, 2**22 // n)))
        done = 0
        while done < count:
            k = min(batch, count - done)
            block = simulate_model(self.model, n, self.fs, seed + done, n_channels=k)
            for j in range(k):
                yield np.ascontiguousarray(block[:, j])
            done += k

    def _surrogate(self, n: int, rng: np.random.Generator) -> NDArray[np.float64]:
        assert self.record is not None
        if n not in self._spectra:
            base = self.record[:n]
            mean = float(base.mean())
            ext = np.concatenate([base - mean, (base - mean)[::-1]])
            power = np.abs(np.fft.rfft(ext)) ** 2
            self._spectra[n] = np.concatenate([[mean], _smooth_spectrum(power)])
        spec = self._spectra[n]
        mean, power = spec[0], spec[1:]
        m = 2 * n
        coef = np.sqrt(power / 2.0) * (
            rng.standard_normal(power.size) + 1j * rng.standard_normal(power.size)
        )
        coef[0] = 0.0
        coef[-1] = np.sqrt(power[-1]) * rng.standard_normal()
        return np.asarray(np.fft.irfft(coef, m)[:n] + mean, dtype=np.float64)


def _smooth_spectrum(power: NDArray[np.float64]) -> NDArray[np.float64]:
    """Periodogram smoothed over a window growing with frequency (5 % of the bin index, >= 3)."""
    csum = np.concatenate([[0.0], np.cumsum(power)])
    k = np.arange(power.size)
    half = np.maximum(1, (0.025 * k).astype(np.int64))
    lo = np.clip(k - half, 1, power.size)
    hi = np.clip(k + half + 1, 1, power.size)
    out = (csum[hi] - csum[lo]) / np.maximum(hi - lo, 1)
    out[0] = power[0]
    return np.asarray(out, dtype=np.float64)


def simulate_model(
    model: Any, n: int, fs: float, seed: int, *, n_channels: int = 1
) -> NDArray[np.float64]:
    """``n_channels`` independent rate records of ``n`` samples from a NoiseModel, ``(n, C)``.

    Tones above the Nyquist frequency are simulated aliased, as a real sampled sensor sees
    them.
    """
    out = model.simulate(n, fs=fs, n_channels=n_channels, seed=seed, allow_aliasing=True)
    out = np.asarray(out, dtype=np.float64)
    return out.reshape(n, -1)


def model_units(model: Any) -> str | None:
    """Rate unit of a model (``units["rate"]`` of a NoiseModel, or a plain string)."""
    units = getattr(model, "units", None)
    if isinstance(units, dict):
        return units.get("rate")
    return units if isinstance(units, str) else None


def make_source(
    sim: Any, fs: float, n_real: int, *, sim_units: str | None, sim_input: str = "rate"
) -> SimSource:
    """Build the :class:`SimSource` for ``sim`` (model, model JSON or record)."""
    if isinstance(sim, (np.ndarray, list, tuple)):
        rec = as_rate(sim, fs, sim_input, name="simulated")
        if rec.size < n_real:
            raise ValueError(
                f"the simulated record is shorter than the real one ({rec.size} < {n_real} rate "
                "samples); simulate at least as many samples as the real record has"
            )
        return SimSource(fs=fs, record=rec[:n_real], units=sim_units)
    model = load_model(sim)
    units = model_units(model)
    if sim_units is not None:
        units = check_units(sim_units, units)
    model_fs = getattr(model, "fs", None)
    if model_fs is not None and not np.isclose(float(model_fs), fs, rtol=1e-9):
        raise ValueError(
            f"sample-rate mismatch: the model was made for fs = {model_fs} Hz but the real record "
            f"has fs = {fs} Hz; diagnose at the model's rate or refit the model"
        )
    return SimSource(fs=fs, model=model, units=units)
