"""Exact covariance propagation of small linear error models (linear SDEs).

A model ``x' = F x + G w`` (``w`` unit-intensity white noise, ``x(0) ~ N(0, P0)``) is
discretised exactly: over a step ``h`` the transition is ``Phi = expm(F h)`` and the process
noise ``Qd = int_0^h expm(F s) G G^T expm(F^T s) ds``, both from one matrix exponential
(Van Loan, "Computing integrals involving the matrix exponential", IEEE TAC 23, 1978). Long
steps are built by doubling from a short one, ``Phi(2h) = Phi(h)^2`` and
``Qd(2h) = Phi(h) Qd(h) Phi(h)^T + Qd(h)``, so that no exponential of a large or unstable
matrix is ever formed. The same discretisation drives the Monte Carlo sampler.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["LinearErrorModel", "discretize", "discretize_many"]

_MAX_NORM_STEP = 0.25


def _expm_small(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Batched ``expm`` of matrices of norm <= 0.25: Taylor series to order 16.

    The truncation error is below ``0.25^17 / 17! ~ 2e-25`` relative; one batched matrix
    product per order (scipy's ``expm`` works matrix by matrix, far slower for many small ones).
    """
    out = np.broadcast_to(np.eye(a.shape[-1]), a.shape).copy()
    term = out.copy()
    for k in range(1, 17):
        term = term @ a / k
        out += term
    return np.asarray(out, dtype=np.float64)


def _van_loan(
    f: NDArray[np.float64], qc: NDArray[np.float64], h: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Batched Van Loan: ``(Phi, Qd)`` for every step in ``h``, shapes ``(len(h), n, n)``.

    ``Qd`` is linear in ``Qc``, so ``Qc`` is normalised first and the result rescaled; the
    block matrix then has a norm of at most ``||F|| + ||Qc / max|Qc| ||``, which the caller
    keeps below 0.25 by the choice of ``h``.
    """
    n = f.shape[0]
    q_scale = float(np.abs(qc).max()) or 1.0
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -f
    m[:n, n:] = qc / q_scale
    m[n:, n:] = f.T
    e = _expm_small(h[:, None, None] * m[None, :, :])
    phi = np.swapaxes(e[:, n:, n:], 1, 2)
    qd = phi @ e[:, :n, n:] * q_scale
    return phi, 0.5 * (qd + np.swapaxes(qd, 1, 2))


def discretize_many(
    f: NDArray[np.float64], qc: NDArray[np.float64], dts: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact ``(Phi, Qd)`` of ``x' = F x + w``, ``E[w w^T] = Qc``, for many steps at once.

    Every step is split into ``2^k`` equal parts, ``k`` set by the longest step so that
    ``(||F|| + ||Qc / max|Qc| ||) h <= 0.25`` (infinity norms); one batched Van Loan
    exponential gives the parts and ``k`` doublings rebuild the steps.

    Parameters
    ----------
    f, qc : numpy.ndarray
        Continuous dynamics and white-noise intensity, shape ``(n, n)``.
    dts : array_like
        Steps in seconds (>= 0).

    Returns
    -------
    (Phi, Qd) : tuple of numpy.ndarray
        Shapes ``(len(dts), n, n)``.
    """
    steps = np.atleast_1d(np.asarray(dts, dtype=np.float64))
    if np.any(steps < 0) or not np.all(np.isfinite(steps)):
        raise ValueError("time steps must be finite and >= 0")
    q_scale = float(np.abs(qc).max()) or 1.0
    norm = float(np.abs(f).sum(axis=1).max() + np.abs(qc / q_scale).sum(axis=1).max())
    longest = float(steps.max()) if steps.size else 0.0
    doublings = 0
    if norm * longest > _MAX_NORM_STEP:
        doublings = math.ceil(math.log2(norm * longest / _MAX_NORM_STEP))
    phi, qd = _van_loan(f, qc, steps / 2.0**doublings)
    for _ in range(doublings):
        qd = phi @ qd @ np.swapaxes(phi, 1, 2) + qd
        phi = phi @ phi
    return phi, 0.5 * (qd + np.swapaxes(qd, 1, 2))


def discretize(
    f: NDArray[np.float64], qc: NDArray[np.float64], dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact transition matrix and process-noise covariance of ``x' = F x + w``, ``E[w w^T] = Qc``.

    Parameters
    ----------
    f, qc : numpy.ndarray
        Continuous dynamics and white-noise intensity, shape ``(n, n)``.
    dt : float
        Step in seconds (>= 0).

    Returns
    -------
    (Phi, Qd) : tuple of numpy.ndarray
        ``Phi = expm(F dt)``, ``Qd = int_0^dt expm(F s) Qc expm(F^T s) ds``.
    """
    if dt < 0:
        raise ValueError(f"time step must be >= 0, got {dt}")
    phi, qd = discretize_many(f, qc, [dt])
    return phi[0], qd[0]


@dataclass(frozen=True)
class LinearErrorModel:
    """A linear error model with named scalar outputs ``y = c^T x``.

    Attributes
    ----------
    f : numpy.ndarray
        Dynamics matrix, shape ``(n, n)``.
    g : numpy.ndarray
        Input matrix of unit-intensity white noise, shape ``(n, k)``.
    p0 : numpy.ndarray
        Initial covariance, shape ``(n, n)``.
    outputs : dict of str to numpy.ndarray
        Output name to row vector ``c`` of length ``n``.
    """

    f: NDArray[np.float64]
    g: NDArray[np.float64]
    p0: NDArray[np.float64]
    outputs: dict[str, NDArray[np.float64]]

    @property
    def qc(self) -> NDArray[np.float64]:
        """Continuous process-noise intensity ``G G^T``."""
        return np.asarray(self.g @ self.g.T, dtype=np.float64)

    def covariance(self, t: ArrayLike) -> NDArray[np.float64]:
        """State covariance at increasing times ``t`` (s, >= 0), shape ``(len(t), n, n)``."""
        times = _check_times(t)
        out = np.empty((times.size, *self.f.shape))
        phis, qds = discretize_many(self.f, self.qc, np.diff(times, prepend=0.0))
        p = self.p0.copy()
        for i in range(times.size):
            p = phis[i] @ p @ phis[i].T + qds[i]
            out[i] = p
        return out

    def sigma(self, t: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """Return the standard deviation of every output at times ``t``."""
        cov = self.covariance(t)
        return {
            name: np.sqrt(np.maximum(np.einsum("i,tij,j->t", c, cov, c), 0.0))
            for name, c in self.outputs.items()
        }

    def sample(
        self, t: ArrayLike, n_paths: int, rng: np.random.Generator
    ) -> dict[str, NDArray[np.float64]]:
        """Monte Carlo realisations of the outputs at times ``t``, shape ``(n_paths, len(t))``.

        Every step uses the exact discretisation, so the samples have exactly the model's
        distribution at the requested times whatever their spacing.
        """
        times = _check_times(t)
        n = self.f.shape[0]
        x = rng.standard_normal((n_paths, n)) @ _psd_sqrt(self.p0).T
        rows = {name: np.empty((n_paths, times.size)) for name in self.outputs}
        phis, qds = discretize_many(self.f, self.qc, np.diff(times, prepend=0.0))
        for i in range(times.size):
            x = x @ phis[i].T + rng.standard_normal((n_paths, n)) @ _psd_sqrt(qds[i]).T
            for name, c in self.outputs.items():
                rows[name][:, i] = x @ c
        return rows


def _psd_sqrt(p: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return a matrix square root ``L`` with ``L L^T = P`` for a possibly singular PSD ``P``.

    The decomposition works on the correlation matrix (``P`` scaled by its diagonal), so states
    of very different magnitude (rad next to km) keep their relative accuracy.
    """
    sym = 0.5 * (p + p.T)
    d = np.sqrt(np.maximum(np.diag(sym), 0.0))
    scale = np.where(d > 0, d, 1.0)
    w, v = np.linalg.eigh(sym / np.outer(scale, scale))
    return np.asarray(scale[:, None] * (v * np.sqrt(np.maximum(w, 0.0))), dtype=np.float64)


def _check_times(t: ArrayLike) -> NDArray[np.float64]:
    times = np.atleast_1d(np.asarray(t, dtype=np.float64))
    if times.ndim != 1 or times.size == 0:
        raise ValueError("times must be a non-empty 1-D array of seconds")
    if not np.all(np.isfinite(times)) or times[0] < 0 or np.any(np.diff(times) < 0):
        raise ValueError("times must be finite, >= 0 and increasing")
    return times
