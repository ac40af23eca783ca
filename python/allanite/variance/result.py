"""The result of an Allan-family variance (:class:`AllanResult`) and its assembly from sums."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from allanite import _core
from allanite.confidence import DEFAULT_LEVEL, ONE_SIGMA, check_level, level_tag
from allanite.extras import require
from allanite.notebook import allan_html
from allanite.variance.edf import equivalent_dof
from allanite.variance.taus import KERNEL_KIND

__all__ = ["AllanResult", "assemble_result"]


@dataclass(frozen=True, repr=False)
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
    _repr_html_ = allan_html  # Jupyter: a compact table and the plot (allanite.notebook)

    def __repr__(self) -> str:
        """One line: kind, grid, channels, record and unit (the arrays are attributes)."""
        channels = 1 if self.var.ndim == 1 else self.var.shape[1]
        taus = (
            f"{self.tau.size} taus {self.tau[0]:.3g}-{self.tau[-1]:.3g} s"
            if self.tau.size
            else "no taus"
        )
        return (
            f"AllanResult(kind={self.kind!r}, {taus}, channels={channels}, "
            f"n_samples={self.n_samples}, fs={self.fs:g} Hz, input={self.input!r}, "
            f"units={self.units!r})"
        )

    @property
    def dev(self) -> NDArray[np.float64]:
        """Deviation, the square root of :attr:`var`."""
        return np.sqrt(self.var)

    @property
    def n_channels(self) -> int:
        """Number of channels (1 for a 1-D record)."""
        return 1 if self.var.ndim == 1 else int(self.var.shape[1])

    def var_ci(
        self, level: float = DEFAULT_LEVEL
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Chi-square confidence limits of the variance.

        ``var * edf / chi2.ppf((1 + level) / 2, edf)`` to ``var * edf / chi2.ppf((1 - level) / 2,
        edf)`` (SP1065 eq. 41).

        Parameters
        ----------
        level : float
            Two-sided confidence level in (0, 1); default
            :data:`allanite.confidence.DEFAULT_LEVEL` (0.95), 0.683 for 1-sigma error bars.

        Returns
        -------
        tuple of numpy.ndarray
            Lower and upper limits, shaped like :attr:`var`.
        """
        level = check_level(level)
        lo = self.var * self.edf / stats.chi2.ppf(0.5 + level / 2.0, self.edf)
        hi = self.var * self.edf / stats.chi2.ppf(0.5 - level / 2.0, self.edf)
        return lo, hi

    def ci(self, level: float = DEFAULT_LEVEL) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
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
        names = self.meta.get("channels")
        meta = {**self.meta, "channels": [names[index]]} if names else self.meta
        return dataclasses.replace(
            self,
            var=self.var[:, index],
            edf=self.edf[:, index],
            alpha=self.alpha[:, index],
            meta=meta,
        )

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dictionary (lists), suitable for JSON."""
        lo, hi = self.ci(ONE_SIGMA)  # the dev_low_68/dev_high_68 columns
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

    def _columns(self, level: float | None = None) -> dict[str, NDArray[Any]]:
        level = ONE_SIGMA if level is None else level
        lo, hi = self.ci(level)  # the dev_low_TAG/dev_high_TAG columns (TAG = level_tag)
        tag = level_tag(level)
        cols: dict[str, NDArray[Any]] = {"tau": self.tau, "m": self.m, "n_terms": self.n_terms}
        var2 = self.var.reshape(self.tau.size, -1)
        parts = {
            "var": var2,
            "dev": np.sqrt(var2),
            f"dev_low_{tag}": lo.reshape(var2.shape),
            f"dev_high_{tag}": hi.reshape(var2.shape),
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

    def to_csv(self, path: str | Path, level: float | None = None) -> None:
        """Write the table of :meth:`to_frame` as CSV (no pandas needed).

        The interval columns hold the two-sided interval at ``level``, named by it
        (``dev_low_68`` for the default, None: 1 sigma; ``dev_low_95`` for 0.95; see
        :func:`allanite.confidence.level_tag`).
        """
        cols = self._columns(level)
        header = ",".join(cols)
        table = np.column_stack([np.asarray(v, dtype=np.float64) for v in cols.values()])
        np.savetxt(path, table, delimiter=",", header=header, comments="", fmt="%.17g")


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

    Shared by :func:`avar` and the large-record path (:func:`~allanite.variance.avar_large`).
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
