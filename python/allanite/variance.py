"""Allan-family variances of a record: the public entry points and their result type.

The numeric work runs in :mod:`allanite._core` (compensated prefix sums, then one O(N) pass per
averaging factor, threaded over factors); this module validates the input, resolves the tau
grid, identifies the noise type and attaches equivalent degrees of freedom.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from allanite import _core
from allanite.edf import (
    equivalent_dof,
    identify_alpha,
    smooth_isolated_alpha,
    wants_identification,
)
from allanite.extras import require
from allanite.notebook import repr_html
from allanite.taus import KERNEL_KIND, TauSpec, averaging_factors
from allanite.units import record_rate_unit

__all__ = [
    "KINDS",
    "AllanResult",
    "adev",
    "avar",
    "hdev",
    "mdev",
    "oadev",
    "ohdev",
    "prepare_record",
    "tdev",
    "totdev",
]

InputKind = Literal["rate", "increment", "angle"]
Kind = Literal[
    "overlapping", "standard", "modified", "hadamard", "standard_hadamard", "total", "time"
]
KINDS: tuple[str, ...] = tuple(KERNEL_KIND)
INPUTS: tuple[str, ...] = ("rate", "increment", "angle")

_ACCEPTED = (np.float64, np.float32, np.int16, np.int32, np.int64)


@dataclass(frozen=True)
class AllanResult:
    """Allan-family variance of a record over a grid of averaging times.

    Attributes
    ----------
    tau : numpy.ndarray
        Averaging times in seconds, shape ``(T,)``.
    m : numpy.ndarray
        Averaging factors (``tau = m / fs``), shape ``(T,)``.
    var : numpy.ndarray
        The variance of this ``kind`` (e.g. the modified variance for ``kind="modified"``) in
        squared rate units, shape ``(T,)`` or ``(T, C)``.
    kind : str
        Estimator: overlapping, standard, modified, hadamard, standard_hadamard, total, time.
    n_terms : numpy.ndarray
        Number of difference terms averaged at each tau, shape ``(T,)``.
    edf : numpy.ndarray
        Equivalent degrees of freedom (Greenhall & Riley 2003), same shape as ``var``.
    alpha : numpy.ndarray
        Power-law noise exponent used for the EDF (identified from the data unless given).
    fs : float
        Sampling frequency in Hz.
    input : str
        What the samples were: rate, increment or angle.
    n_samples : int
        Record length.
    units : str or None
        Rate unit of the record (e.g. ``"deg/s"``), if known.
    """

    tau: NDArray[np.float64]
    m: NDArray[np.int64]
    var: NDArray[np.float64]
    kind: str
    n_terms: NDArray[np.int64]
    edf: NDArray[np.float64]
    alpha: NDArray[np.int64]
    fs: float
    input: str
    n_samples: int
    units: str | None = None
    meta: dict[str, Any] = field(default_factory=dict, compare=False)
    _repr_html_ = repr_html  # Jupyter: a compact table and the plot (allanite.notebook)

    @property
    def dev(self) -> NDArray[np.float64]:
        """Deviation, the square root of :attr:`var`."""
        return np.sqrt(self.var)

    @property
    def n_channels(self) -> int:
        """Number of channels (1 for a 1-D record)."""
        return 1 if self.var.ndim == 1 else int(self.var.shape[1])

    def var_ci(self, level: float = 0.683) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Chi-square confidence limits of the variance.

        ``var * edf / chi2.ppf((1 + level) / 2, edf)`` to ``var * edf / chi2.ppf((1 - level) / 2,
        edf)`` (SP1065 eq. 41).

        Parameters
        ----------
        level : float
            Two-sided confidence level in (0, 1), e.g. 0.683 or 0.95.

        Returns
        -------
        tuple of numpy.ndarray
            Lower and upper limits, shaped like :attr:`var`.
        """
        if not 0.0 < level < 1.0:
            raise ValueError(f"level must lie in (0, 1), got {level}")
        lo = self.var * self.edf / stats.chi2.ppf(0.5 + level / 2.0, self.edf)
        hi = self.var * self.edf / stats.chi2.ppf(0.5 - level / 2.0, self.edf)
        return lo, hi

    def ci(self, level: float = 0.683) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Confidence limits of the deviation (the square roots of :meth:`var_ci`)."""
        lo, hi = self.var_ci(level)
        return np.sqrt(lo), np.sqrt(hi)

    def with_excess_variance(self, excess: ArrayLike, gaussian: ArrayLike) -> AllanResult:
        r"""A copy whose EDF includes the non-Gaussian variance of the estimate.

        The Greenhall-Riley EDF :math:`\nu` describes Gaussian power-law noise. A heavy-tailed
        process (spikes, bias steps, telegraph noise) changes the variance of the estimate from
        the Gaussian :math:`G` (the variance for a Gaussian process of the same covariance) to
        :math:`G + \text{excess}`, its fourth cumulants giving the excess
        (:mod:`allanite.terms._estimator_kurtosis`). The EDF is scaled by that ratio:

        .. math:: \nu' = \nu\,\frac{G}{G + \text{excess}},

        i.e. the chi-square with :math:`\nu'` degrees of freedom matches the first two moments
        of the estimate (Satterthwaite) when :math:`\nu = 2\sigma^4/G`; the ratio, a property
        of the model, also holds where :math:`\nu` comes from an identified noise type.
        :meth:`var_ci` and :meth:`ci` then use :math:`\nu'`. Where the excess is zero the EDF
        is kept bit for bit. :meth:`with_model_edf` takes both from a model.

        Parameters
        ----------
        excess : array_like
            Excess variance of the estimate (rate^4), shape ``(T,)`` or like :attr:`var`
            (:meth:`allanite.model.NoiseModel.avar_excess_variance`). May be negative (a
            telegraph signal at :math:`\tau \gg T_c` is lighter-tailed than Gaussian).
        gaussian : array_like
            Gaussian variance of the estimate (rate^4), same shapes
            (:meth:`allanite.model.NoiseModel.avar_gaussian_variance`).

        Returns
        -------
        AllanResult
            The same result with the corrected :attr:`edf`.

        Raises
        ------
        ValueError
            For another kind than ``overlapping`` (the excess is derived for it), mismatched
            shapes, non-finite values, ``gaussian <= 0`` or ``gaussian + excess <= 0``.
        """
        if self.kind != "overlapping":
            raise ValueError(
                f"the excess variance is derived for the overlapping estimator, this result is "
                f"{self.kind!r}: compute it with kind='overlapping'"
            )
        shape = self.var.shape
        arrays = []
        for name, value in (("excess", excess), ("gaussian", gaussian)):
            a = np.asarray(value, dtype=np.float64)
            if a.shape == self.tau.shape and len(shape) == 2:
                a = a[:, None]
            if np.broadcast_shapes(a.shape, shape) != shape:
                raise ValueError(
                    f"{name} must have shape {self.tau.shape} (one per tau) or {shape}, got "
                    f"{a.shape}"
                )
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name} must be finite")
            arrays.append(a)
        extra, base = arrays
        if np.any(base <= 0) or np.any(base + extra <= 0):
            raise ValueError(
                "gaussian and gaussian + excess (variances of the estimate) must be positive; "
                "take both from the same model (AllanResult.with_model_edf)"
            )
        edf = np.where(extra == 0.0, self.edf, self.edf * base / (base + extra))
        meta = {**self.meta, "edf_excess": True}
        return dataclasses.replace(
            self, edf=np.broadcast_to(edf, shape).astype(np.float64), meta=meta
        )

    def with_model_edf(self, model: Any) -> AllanResult:
        """:meth:`with_excess_variance` with the excess and Gaussian variance of ``model``.

        Parameters
        ----------
        model : allanite.model.NoiseModel
            The model the record follows (e.g. the one it was simulated from, or a fit); a
            model without heavy-tailed terms leaves the EDF unchanged.

        Returns
        -------
        AllanResult
            The same result with the corrected :attr:`edf`.
        """
        dt = 1.0 / self.fs
        n_rate = self.n_samples - 1 if self.input == "angle" else self.n_samples
        excess = model.avar_excess_variance(self.tau, dt, n_rate)
        if not np.any(excess != 0.0):
            return dataclasses.replace(self, meta={**self.meta, "edf_excess": True})
        return self.with_excess_variance(excess, model.avar_gaussian_variance(self.tau, dt, n_rate))

    def channel(self, index: int) -> AllanResult:
        """Return one channel as a single-channel result."""
        if self.var.ndim == 1:
            if index != 0:
                raise IndexError(f"channel {index} out of range for a single-channel result")
            return self
        return dataclasses.replace(
            self, var=self.var[:, index], edf=self.edf[:, index], alpha=self.alpha[:, index]
        )

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dictionary (lists), suitable for JSON."""
        lo, hi = self.ci()
        return {
            "kind": self.kind,
            "input": self.input,
            "fs": self.fs,
            "n_samples": self.n_samples,
            "units": self.units,
            "tau": self.tau.tolist(),
            "m": self.m.tolist(),
            "var": self.var.tolist(),
            "dev": self.dev.tolist(),
            "n_terms": self.n_terms.tolist(),
            "edf": self.edf.tolist(),
            "alpha": self.alpha.tolist(),
            "dev_low_68": lo.tolist(),
            "dev_high_68": hi.tolist(),
        }

    def to_json(self, **kwargs: Any) -> str:
        """JSON text of :meth:`to_dict`."""
        return json.dumps(self.to_dict(), **kwargs)

    def _columns(self) -> dict[str, NDArray[Any]]:
        lo, hi = self.ci()
        cols: dict[str, NDArray[Any]] = {"tau": self.tau, "m": self.m, "n_terms": self.n_terms}
        var2 = self.var.reshape(self.tau.size, -1)
        parts = {
            "var": var2,
            "dev": np.sqrt(var2),
            "dev_low_68": lo.reshape(var2.shape),
            "dev_high_68": hi.reshape(var2.shape),
            "edf": self.edf.reshape(var2.shape),
            "alpha": self.alpha.reshape(var2.shape),
        }
        for name, values in parts.items():
            for c in range(var2.shape[1]):
                key = name if self.var.ndim == 1 else f"{name}_{c}"
                cols[key] = values[:, c]
        return cols

    def to_frame(self) -> Any:
        """Return a :class:`pandas.DataFrame` with one row per tau (needs the ``pandas`` extra)."""
        pd = require("pandas", extra="pandas", purpose="to_frame()")
        return pd.DataFrame(self._columns())

    def to_csv(self, path: str | Path) -> None:
        """Write the table of :meth:`to_frame` as CSV (no pandas needed)."""
        cols = self._columns()
        header = ",".join(cols)
        table = np.column_stack([np.asarray(v, dtype=np.float64) for v in cols.values()])
        np.savetxt(path, table, delimiter=",", header=header, comments="", fmt="%.17g")


def prepare_record(x: ArrayLike, *, name: str = "x") -> tuple[NDArray[Any], bool]:
    """Validate a record and return it as a 2-D ``(N, C)`` view (no copy when possible).

    Parameters
    ----------
    x : array_like
        Record of shape ``(N,)`` or ``(N, C)``.
    name : str
        Name used in error messages.

    Returns
    -------
    tuple
        The 2-D array (dtype one of float64, float32, int16, int32, int64) and whether the
        input was 1-D.
    """
    arr = np.asarray(x)
    if arr.dtype == np.bool_ or not (
        np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)
    ):
        raise TypeError(
            f"{name} has dtype {arr.dtype}; give real numbers (float64, float32, int16, int32, "
            "int64)"
        )
    if arr.dtype.type not in _ACCEPTED:
        if np.issubdtype(arr.dtype, np.unsignedinteger) and arr.dtype.itemsize == 8:
            raise TypeError(
                f"{name} has dtype uint64, which may overflow; convert to int64 or float64"
            )
        arr = arr.astype(np.float64 if arr.dtype.kind == "f" else np.int64)
    if not arr.dtype.isnative:
        arr = arr.astype(arr.dtype.newbyteorder("="))
    if arr.ndim == 1:
        return arr.reshape(-1, 1), True
    if arr.ndim != 2:
        raise ValueError(
            f"{name} must be 1-D (samples) or 2-D (samples, channels), got shape {arr.shape}"
        )
    if arr.shape[0] < 3:
        raise ValueError(f"{name} is too short: {arr.shape[0]} samples; need at least 3")
    if arr.shape[0] < arr.shape[1]:
        raise ValueError(
            f"{name} has shape {arr.shape}: fewer samples than channels. Records are (samples, "
            "channels); pass x.T if your channels are rows"
        )
    return arr, False


def _check_fs(fs: float) -> float:
    try:
        value = float(fs)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"fs must be a number in Hz, got {fs!r}") from exc
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"fs must be a positive, finite sampling frequency in Hz, got {fs!r}")
    return value


def _check_threads(threads: int | None) -> int:
    if threads is None:
        return 0
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ValueError(f"threads must be a positive integer or None, got {threads!r}")
    return int(threads)


def _given_alpha(alpha: int | ArrayLike | str | None, shape: tuple[int, ...]) -> NDArray[np.int64]:
    """Caller's noise exponents broadcast to ``(T, C)``: a scalar, one per tau, or per channel."""
    given = np.asarray(alpha)
    if given.dtype.kind not in "iuf" or not np.all(np.isfinite(given)):
        raise TypeError(f"alpha must be integers between -4 and 2, got {alpha!r}")
    if np.any(given != np.round(given)) or np.any(given < -4) or np.any(given > 2):
        raise ValueError(
            f"alpha must hold integer power-law exponents in [-4, 2] (2 white PM ... -2 random "
            f"walk FM), got {alpha!r}"
        )
    values = given.astype(np.int64)
    if values.ndim == 1:
        values = values.reshape(-1, 1)
    try:
        return np.broadcast_to(values, shape).copy()
    except ValueError:
        raise ValueError(
            f"alpha has shape {given.shape}; give a scalar, one value per tau ({shape[0]}) or a "
            f"(taus, channels) array {shape}"
        ) from None


def avar(
    x: ArrayLike,
    fs: float = 1.0,
    *,
    input: InputKind = "rate",
    kind: Kind = "overlapping",
    taus: TauSpec = "log",
    m: ArrayLike | None = None,
    points: int = 100,
    alpha: int | ArrayLike | str | None = None,
    threads: int | None = None,
    units: str | None = None,
    memory_limit: int | float | str | None = None,
    progress: Any = None,
    fast: bool | int = False,
) -> AllanResult:
    r"""Allan-family variance of a record for a grid of averaging times.

    For rate samples :math:`y_k` the phase is :math:`x_k = \sum_{i<k} y_i` (compensated, mean
    removed) and the overlapping Allan variance is

    .. math:: \sigma^2(\tau) = \frac{1}{2\tau^2(M-2m)}\sum_{k=0}^{M-2m-1}
              (x_{k+2m} - 2x_{k+m} + x_k)^2 \,\tau_0^2,\qquad \tau = m\tau_0,

    (NIST SP1065 eq. 11). Angle input uses the angle itself as the phase (the integrating-gyro
    case); increment input integrates the angle increments.

    Parameters
    ----------
    x : array_like
        Record, shape ``(N,)`` or ``(N, C)`` (samples, channels); float64, float32, int16,
        int32 or int64 (strided views are read without a copy).
    fs : float
        Sampling frequency in Hz.
    input : {"rate", "increment", "angle"}
        Rate samples, angle increments per sample, or angle.
    kind : {"overlapping", "standard", "modified", "hadamard", "standard_hadamard", "total", \
"time"}
        Estimator. ``time`` is the time variance :math:`\tau^2\,\mathrm{MVAR}/3`.
    taus : {"log", "octave", "decade", "all"} or array_like
        Tau grid, or explicit averaging times in seconds. ``"log"`` is the original program's
        grid ``unique(ceil(logspace(0, log10(2^floor(log2(N/2))), points)))``.
    m : array_like of int, optional
        Explicit averaging factors (overrides ``taus``).
    points : int
        Number of points of the ``"log"`` grid.
    alpha : int or array_like, optional
        Power-law noise exponent (2 white PM ... -2 random walk FM, down to -4 for the Hadamard
        kinds) for the EDF: a scalar, one per tau, or ``(taus, channels)``. When omitted it is
        identified from the data at every tau as Stable32 does (lag-1 autocorrelation with at
        least 30 decimated points, else the B1 ratio and R(n); :func:`allanite.edf.identify_alpha`),
        then an isolated flip between two agreeing neighbours is replaced by their exponent
        (:func:`allanite.edf.smooth_isolated_alpha`) so the intervals do not jump at one tau.
        ``alpha="stable32"`` keeps Stable32's per-tau identification, flips included.
        The EDF follows Greenhall & Riley (2003) for every kind but ``total``, which uses the
        SP1065 formulas (:mod:`allanite.edf`).
    threads : int, optional
        Worker threads (default: all cores). Results are identical for any thread count.
    units : str, optional
        Unit of the record, carried into the result as its rate unit: an angular rate
        (``deg/s``, ``deg/h``, ``dph``, ``rad/s``, ...) or an acceleration (``m/s^2``, ``g``,
        ``mg``, ``ug``, ...); for angle/increment samples also their angle (``deg``) or
        velocity (``m/s``), read as that unit per second. Checked by
        :func:`allanite.units.record_rate_unit` (a unit that is not one of these raises).
    memory_limit, progress, fast
        Large records (:func:`allanite.large.avar_large`, which also reads files in chunks):
        a working-memory budget like ``"1GB"`` beyond which the phase array goes to a
        temporary file; a ``progress(stage, done, total)`` callback; fast mode (strided sums
        at large m with a stated error bound, :mod:`allanite.fast`). Same results otherwise.

    Returns
    -------
    AllanResult
        Variances, EDF and confidence intervals.

    References
    ----------
    W. J. Riley, *Handbook of Frequency Stability Analysis*, NIST SP1065 (2008).
    """
    units = record_rate_unit(units, input)  # one validation of the unit, for every caller
    if memory_limit is not None or progress is not None or (fast is not False and fast is not None):
        from allanite.large import avar_large

        return avar_large(
            x,
            fs,
            input=input,
            kind=kind,
            taus=taus,
            m=m,
            points=points,
            alpha=alpha,
            threads=threads,
            units=units,
            memory_limit=memory_limit,
            progress=progress,
            fast=fast,
        )
    if kind not in KERNEL_KIND:
        raise ValueError(f"unknown kind {kind!r}; use one of {', '.join(KINDS)}")
    if input not in INPUTS:
        raise ValueError(f"unknown input {input!r}; use 'rate', 'increment' or 'angle'")
    rate = _check_fs(fs)
    nthreads = _check_threads(threads)
    arr, was_1d = prepare_record(x)
    phase = _core.phase(arr, input)
    n_phase = int(phase.shape[0])
    factors = averaging_factors(
        taus, fs=rate, n_samples=arr.shape[0], n_phase=n_phase, kind=kind, m=m, points=points
    )
    kernel_kind = KERNEL_KIND[kind]
    var = np.asarray(_core.variance(phase, factors, kernel_kind, nthreads))
    if wants_identification(alpha):
        # Stable32 identifies phase data on the phase as recorded (its frequency offset makes
        # the lag-1 method difference at least once); frequency data on the averaged rates
        if input == "angle":
            alphas = identify_alpha(
                arr, factors, kernel_kind, data="phase", detrended=phase, threads=nthreads
            )
        else:
            alphas = identify_alpha(phase, factors, kernel_kind, data="frequency", threads=nthreads)
        if alpha is None:
            alphas = smooth_isolated_alpha(alphas, factors)
    else:
        alphas = _given_alpha(alpha, var.shape)
    return assemble_result(
        var,
        factors,
        alphas,
        rate=rate,
        input=input,
        kind=kind,
        n_phase=n_phase,
        n_samples=int(arr.shape[0]),
        units=units,
        was_1d=was_1d,
    )


def assemble_result(
    var: NDArray[np.float64],
    factors: NDArray[np.int64],
    alphas: NDArray[np.int64],
    *,
    rate: float,
    input: str,
    kind: str,
    n_phase: int,
    n_samples: int,
    units: str | None,
    was_1d: bool,
    meta: dict[str, Any] | None = None,
) -> AllanResult:
    """Scale kernel variances (tau0 = 1, phase units) to rate units and attach the EDF.

    Shared by :func:`avar` and the large-record path (:func:`allanite.large.avar_large`).
    ``var`` and ``alphas`` are ``(T, C)``; the result is 1-D per field when ``was_1d``.
    """
    kernel_kind = KERNEL_KIND[kind]
    tau = factors / rate
    # rate: phase in rate * samples; angle/increment: phase in angle units, divide by tau0^2
    scale = 1.0 if input == "rate" else rate * rate
    var = var * scale
    if kind == "time":
        var = var * (tau[:, None] ** 2) / 3.0
    n_terms = np.array(
        [_core.n_terms(kernel_kind, n_phase, int(f)) for f in factors], dtype=np.int64
    )
    edf = equivalent_dof(kernel_kind, alphas, factors, n_phase)
    if was_1d:
        var, edf, alphas = var[:, 0], edf[:, 0], alphas[:, 0]
    return AllanResult(
        tau=tau,
        m=factors,
        var=var,
        kind=kind,
        n_terms=n_terms,
        edf=np.asarray(edf, dtype=np.float64),
        alpha=np.asarray(alphas, dtype=np.int64),
        fs=rate,
        input=input,
        n_samples=n_samples,
        units=units,
        meta=dict(meta or {}),
    )


def _twin(kind: Kind, name: str, what: str) -> Any:
    def dev(x: ArrayLike, fs: float = 1.0, **kwargs: Any) -> AllanResult:
        return avar(x, fs, kind=kind, **kwargs)

    dev.__name__ = name
    dev.__qualname__ = name
    dev.__doc__ = (
        f"{what} of a record: ``avar(x, fs, kind={kind!r}, ...)``.\n\n"
        "Returns an :class:`AllanResult`; its ``dev`` is the deviation. See :func:`avar` for the "
        "parameters."
    )
    return dev


adev = _twin("standard", "adev", "Non-overlapping Allan deviation")
oadev = _twin("overlapping", "oadev", "Overlapping Allan deviation")
mdev = _twin("modified", "mdev", "Modified Allan deviation")
hdev = _twin("standard_hadamard", "hdev", "Non-overlapping Hadamard deviation")
ohdev = _twin("hadamard", "ohdev", "Overlapping Hadamard deviation")
tdev = _twin("time", "tdev", "Time deviation tau * sqrt(MVAR / 3)")
totdev = _twin("total", "totdev", "Total deviation (SP1065 reflected extension)")
