r"""Generalized least squares of an Allan curve with the covariance of its own estimates.

Model: :math:`\sigma^2(\tau) = \sum_j \theta_j g_j(\tau; \phi_j)` with squared amplitudes
:math:`\theta_j \ge 0` (``N^2``, ``B^2``, ...) and at most one nonlinear parameter per term
(Gauss-Markov ``tau_c``, sinusoid frequency, fitted as :math:`\log\phi`). Given the covariance
:math:`C` of the AVAR estimates (:func:`~allanite.fit.covariance.avar_covariance` of the current
model), the estimate minimises :math:`r^\top C^{-1} r`, :math:`r = y - G(\phi)\theta`, subject to
:math:`\theta \ge 0` (non-negative least squares on the whitened problem, variable projection
over :math:`\phi`). :math:`C` is recomputed from the fitted model and the fit repeated until
the estimate settles (iteratively reweighted GLS, a quasi-likelihood estimator).

Uncertainty: the parameter covariance :math:`(J^\top C^{-1} J)^{-1}` at the estimate, with
:math:`J` the Jacobian with respect to :math:`(\theta, \log\phi)`; the unconstrained GLS
:math:`\theta` (which may be negative when a term is absent) is kept for the intervals, so that
the interval of an amplitude is ``sqrt`` of the normal interval of :math:`\theta` clipped at 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import optimize, stats

from allanite.fit.covariance import CovarianceBasis
from allanite.fit.spec import TermSpec
from allanite.model import NoiseModel
from allanite.terms import Term

__all__ = ["GLSData", "GLSSolution", "score_interval", "solve"]

_Vec = NDArray[np.float64]


@dataclass(frozen=True)
class GLSData:
    """The Allan curve to fit: variances ``y`` at factors ``m``, sample period, record length."""

    tau: NDArray[np.float64]
    m: NDArray[np.float64]
    y: NDArray[np.float64]
    dt: float
    n_samples: int
    units: str


@dataclass(frozen=True)
class GLSSolution:
    """Result of :func:`solve`."""

    specs: tuple[TermSpec, ...]
    theta: NDArray[np.float64]  # constrained squared amplitudes
    theta_free: NDArray[np.float64]  # unconstrained GLS squared amplitudes (same phi)
    log_phi: NDArray[np.float64]  # nonlinear parameters (log), one per spec with one
    param_cov: NDArray[np.float64]  # covariance of (theta..., log_phi...)
    cov: NDArray[np.float64]  # covariance of the AVAR estimates used: model + discrepancy
    model_cov: NDArray[np.float64]  # covariance under the fitted terms alone (goodness of fit)
    discrepancy: float  # relative model discrepancy delta (0: the terms fit)
    discrepancy_cov: NDArray[np.float64]  # the covariance added by it, cov - model_cov
    fitted: NDArray[np.float64]
    chi2: float  # generalized chi-square of the terms' own best fit (without discrepancy);
    # inf when every noise amplitude is 0 (no covariance of the fitted model exists)
    chi2_fit: float  # generalized chi-square under cov (what the estimate minimises); inf as chi2
    iterations: int
    jacobian: NDArray[np.float64]
    basis: CovarianceBasis | None
    design: NDArray[np.float64]  # unit-amplitude columns at the fitted nonlinear parameters
    y: NDArray[np.float64]

    def model(self, units: str) -> NoiseModel:
        """The fitted NoiseModel."""
        return NoiseModel(
            tuple(_terms(self.specs, self.theta, self.log_phi)), {"rate": units, "time": "s"}
        )


def _terms(
    specs: Sequence[TermSpec], theta: NDArray[np.float64], log_phi: NDArray[np.float64]
) -> list[Term]:
    out, k = [], 0
    for spec, th in zip(specs, theta, strict=True):
        nl = None
        if spec.nonlinear_name is not None:
            nl = math.exp(log_phi[k])
            k += 1
        out.append(spec.build(math.sqrt(max(th, 0.0)), nl))
    return out


def _design(
    specs: Sequence[TermSpec], data: GLSData, log_phi: NDArray[np.float64]
) -> NDArray[np.float64]:
    cols, k = [], 0
    for spec in specs:
        nl = None
        if spec.nonlinear_name is not None:
            nl = math.exp(log_phi[k])
            k += 1
        cols.append(spec.shape(data.tau, data.dt, nl))
    return np.column_stack(cols)


class _Whitener:
    """Solve with ``C = L L^T``: ``w(x) = L^{-1} x``."""

    def __init__(self, cov: NDArray[np.float64]) -> None:
        scale = np.sqrt(np.diag(cov))
        corr = cov / np.outer(scale, scale)
        corr[np.diag_indices_from(corr)] += 1e-10
        self.scale = scale
        try:
            chol = np.linalg.cholesky(corr)
        except np.linalg.LinAlgError:  # approximation not positive definite: floor the spectrum
            vals, vecs = np.linalg.eigh(corr)
            vals = np.maximum(vals, 1e-6 * vals.max())
            chol = np.linalg.cholesky((vecs * vals) @ vecs.T)
        # numpy rather than scipy.linalg: tiny matrices, no threaded-BLAS start-up cost
        self.inv = np.linalg.inv(chol)

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        z = x / (self.scale if x.ndim == 1 else self.scale[:, None])
        return self.inv @ z


def _nnls(
    white: _Whitener, g: NDArray[np.float64], y: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float]:
    gw, yw = white(g), white(y)
    norms = np.linalg.norm(gw, axis=0)
    norms[norms == 0] = 1.0
    sol, rnorm = optimize.nnls(gw / norms, yw, maxiter=50 * g.shape[1])
    return sol / norms, float(rnorm**2)


def _profile(
    specs: Sequence[TermSpec], data: GLSData, white: _Whitener, log_phi: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float]:
    return _nnls(white, _design(specs, data, log_phi), data.y)


def _nonlinear_grid(specs: Sequence[TermSpec], data: GLSData) -> list[NDArray[np.float64]]:
    grids = []
    for spec in specs:
        if spec.nonlinear_name == "tau_c":
            grids.append(np.log(np.geomspace(data.tau[0] / 4.0, data.tau[-1] * 2.0, 24)))
        elif spec.nonlinear_name == "bandwidth":  # a sensor filter: up to the Nyquist frequency
            low = max(0.05 / data.tau[-1], 1e-3 / data.dt)
            grids.append(np.log(np.geomspace(low, 0.45 / data.dt, 24)))
        elif spec.nonlinear_name == "frequency":
            grids.append(np.log(np.geomspace(0.1 / data.tau[-1], 0.5 / data.dt, 32)))
    return grids


def _best_phi(
    specs: Sequence[TermSpec],
    data: GLSData,
    white: _Whitener,
    start: NDArray[np.float64] | None,
) -> NDArray[np.float64]:
    grids = _nonlinear_grid(specs, data)
    if not grids:
        return np.zeros(0)

    def objective(p: NDArray[np.float64]) -> float:
        return _profile(specs, data, white, p)[1]

    candidates: list[NDArray[np.float64]] = []
    if start is not None:
        candidates.append(np.asarray(start, dtype=np.float64))
    mesh = np.meshgrid(*grids, indexing="ij")
    points = np.column_stack([g.ravel() for g in mesh])
    if len(grids) > 1:  # identical terms: keep one ordering only
        points = points[np.all(np.diff(points, axis=1) > 0, axis=1)]
    scores = np.array([objective(p) for p in points])
    order = np.argsort(scores)
    candidates.extend(points[order[:3]])
    best, best_score = candidates[0], objective(candidates[0])
    for p0 in candidates:
        res = optimize.minimize(
            objective, p0, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-6}
        )
        if res.fun < best_score:
            best, best_score = np.asarray(res.x), float(res.fun)
    return best


def _jacobian(
    specs: Sequence[TermSpec],
    data: GLSData,
    theta: NDArray[np.float64],
    log_phi: NDArray[np.float64],
) -> NDArray[np.float64]:
    g = _design(specs, data, log_phi)
    cols = [g]
    for k in range(log_phi.size):
        h = 1e-5
        up, dn = log_phi.copy(), log_phi.copy()
        up[k] += h
        dn[k] -= h
        deriv = (_design(specs, data, up) @ theta - _design(specs, data, dn) @ theta) / (2 * h)
        cols.append(deriv[:, None])
    return np.hstack(cols)


def _initial_cov(data: GLSData, edf: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.diag(2.0 * data.y**2 / np.maximum(edf, 1.0))


def _basis(
    specs: Sequence[TermSpec], data: GLSData, log_phi: NDArray[np.float64]
) -> CovarianceBasis:
    units = _terms(specs, np.ones(len(specs)), log_phi)
    return CovarianceBasis(units, data.m, data.dt, data.n_samples)


def _covariance(basis: CovarianceBasis, theta: NDArray[np.float64]) -> NDArray[np.float64] | None:
    cov = basis(np.maximum(theta, 0.0))
    if not np.all(np.isfinite(cov)) or np.any(np.diag(cov) <= 0):
        return None
    return cov


def _model_fit(
    specs: tuple[TermSpec, ...],
    data: GLSData,
    current: NDArray[np.float64],
    extra: NDArray[np.float64] | None,
    fixed: bool,
    iterations: int,
    rtol: float,
    log_phi: NDArray[np.float64] | None = None,
) -> tuple[_Vec, _Vec, _Vec, CovarianceBasis | None, int]:
    """Reweighting loop: returns ``theta, log_phi, covariance, basis, iterations``.

    The returned ``theta`` is the GLS estimate under the returned covariance (so the estimate,
    its covariance and the intervals built from them belong together). ``extra`` (the model
    discrepancy) is added to the model covariance when given.
    """
    basis: CovarianceBasis | None = None
    fitted = np.zeros_like(data.y)
    done = 0
    for done in range(1, (1 if fixed else iterations) + 1):
        white = _Whitener(current)
        new_phi = _best_phi(specs, data, white, log_phi)
        if basis is None or log_phi is None or not np.allclose(new_phi, log_phi, rtol=0, atol=1e-6):
            basis = None if fixed else _basis(specs, data, new_phi)
        log_phi = new_phi
        theta, _ = _profile(specs, data, white, log_phi)
        new_fitted = _design(specs, data, log_phi) @ theta
        change = np.max(np.abs(new_fitted - fitted) / np.maximum(new_fitted, 1e-300))
        fitted = new_fitted
        if basis is not None:
            updated = _covariance(basis, theta)
            if updated is not None:
                current = updated if extra is None else updated + extra
        if done > 1 and change < rtol:
            break
    assert log_phi is not None
    theta, _ = _profile(specs, data, _Whitener(current), log_phi)
    return theta, log_phi, current, basis, done


def _discrepancy_shape(y: NDArray[np.float64], fitted: NDArray[np.float64]) -> NDArray[np.float64]:
    r"""Variance shape :math:`D_i = y_i f_i` of the relative model discrepancy.

    The geometric mean of the estimate and the fitted value: the discrepancy term
    :math:`(y - f)^2 / (\delta^2 y f) = (\sqrt{y/f} - \sqrt{f/y})^2/\delta^2` penalises a
    model above the data as much as one equally far below (in ratio). With :math:`y^2` a model
    far above a few points would dominate (and pull the whole curve low); with :math:`f^2`
    a term could inflate its own allowance.
    """
    return y * np.maximum(fitted, 1e-3 * y)


def _discrepancy_scale(
    resid: NDArray[np.float64], cov: NDArray[np.float64], shape: NDArray[np.float64], dof: int
) -> float:
    r"""Paule-Mandel ``delta^2``: :math:`r^\top (C + \delta^2 D)^{-1} r = \nu`, ``D = diag(shape)``.

    Returns 0 when the chi-square without the discrepancy is already at most ``dof``.
    """

    def excess(d2: float) -> float:
        w = _Whitener(cov + d2 * np.diag(shape))(resid)
        return float(w @ w) - dof

    if excess(0.0) <= 0:
        return 0.0
    hi = float(np.max(resid**2 / shape))
    while excess(hi) > 0:
        hi *= 4.0
    return float(optimize.brentq(excess, 0.0, hi, xtol=1e-12 * hi, rtol=1e-10))


def solve(
    specs: Sequence[TermSpec],
    data: GLSData,
    edf: NDArray[np.float64],
    *,
    cov: NDArray[np.float64] | None = None,
    start: NDArray[np.float64] | None = None,
    iterations: int = 10,
    rtol: float = 1e-4,
    misfit_level: float = 0.001,
) -> GLSSolution:
    r"""Iteratively reweighted GLS fit of ``specs`` to ``data``, with a model discrepancy.

    First the terms are fitted with the covariance :math:`C(\theta)` of the estimates under
    the fitted model. If that fit is rejected (generalized chi-square p-value below
    ``misfit_level``), the model does not describe the curve to the estimates' precision
    (a real sensor's digital filter, quantised samples, structure the IEEE terms lack), and
    :math:`C(\theta)` alone would let the precise short-tau points dictate every coefficient
    and let a term inflate its own predicted variance to escape the points contradicting it.
    A relative model discrepancy is then added, independent between taus,

    .. math:: C_\delta = C(\theta) + \delta^2\,\mathrm{diag}(y_i f_i),

    with :math:`f_i` the fitted value (see :func:`_discrepancy_shape`), and :math:`\delta`
    chosen by the Paule-Mandel rule, the generalized chi-square under
    :math:`C_\delta` equal to its degrees of freedom, iterated jointly with :math:`\theta`.
    The coefficients and their intervals then carry the model error ("dark uncertainty");
    the reported chi-square stays the one of the terms' own best fit (before the
    discrepancy), the statistic the test rejected, so the misfit remains visible and is not
    overstated by the coefficients that follow the whole curve.

    Parameters
    ----------
    specs : sequence of TermSpec
        The terms.
    data : GLSData
        The curve.
    edf : numpy.ndarray
        Equivalent degrees of freedom of the points (for the first, diagonal weights only).
    cov : numpy.ndarray, optional
        A fixed covariance of the estimates (then no reweighting and no discrepancy).
    start : numpy.ndarray, optional
        Covariance of the estimates to start the reweighting from (default: diagonal, from
        ``edf``). The reweighted fit is not convex; :func:`allanite.fit` tries several starts.
    iterations : int
        Maximum number of covariance updates.
    rtol : float
        Stop when the fitted curve changes by less than this (relative) between updates.
    misfit_level : float
        Significance level of the goodness-of-fit test that switches the discrepancy on
        (0 never switches it on).

    References
    ----------
    R. C. Paule and J. Mandel, "Consensus values and weighting factors", J. Res. NBS 87
    (1982); M. C. Kennedy and A. O'Hagan, "Bayesian calibration of computer models",
    J. R. Stat. Soc. B 63 (2001), for the model-discrepancy term.
    """
    specs = tuple(specs)
    fixed = cov is not None
    if cov is not None:
        first = cov
    elif start is not None:
        first = start
    else:
        first = _initial_cov(data, edf)
    theta, log_phi, current, basis, done = _model_fit(
        specs, data, first, None, fixed, iterations, rtol
    )
    model_cov = current
    n_params = len(specs) + log_phi.size
    dof = data.y.size - n_params
    delta2 = 0.0
    shape = data.y**2
    g = _design(specs, data, log_phi)
    chi2 = _chi2(model_cov, data.y - g @ theta)
    if _noiseless(basis, theta, fixed):
        # every noise amplitude came out 0 (a ramp or a sinusoid alone is left): the model
        # predicts estimates without spread, and ``current`` is a covariance of an earlier
        # iteration, under which a curve thousands of times above the fit once passed the
        # test (chi-square 6.7 on 14 dof): such a model cannot describe a noisy curve
        chi2 = math.inf
    if not fixed and dof > 0 and misfit_level > 0 and stats.chi2.sf(chi2, dof) < misfit_level:
        shape = _discrepancy_shape(data.y, g @ theta)
        for _ in range(iterations):
            assert basis is not None
            updated = _covariance(basis, theta)
            model_cov = model_cov if updated is None else updated
            new_delta2 = _discrepancy_scale(data.y - g @ theta, model_cov, shape, dof)
            extra = new_delta2 * np.diag(shape)
            theta, log_phi, current, basis, more = _model_fit(
                specs, data, model_cov + extra, extra, fixed, iterations, rtol, log_phi
            )
            done += more
            g = _design(specs, data, log_phi)
            new_shape = _discrepancy_shape(data.y, g @ theta)
            settled = abs(new_delta2 - delta2) <= 1e-3 * max(new_delta2, 1e-300) and np.allclose(
                new_shape, shape, rtol=1e-3, atol=0.0
            )
            delta2 = new_delta2
            if settled:
                break
            shape = new_shape
        updated = _covariance(basis, theta) if basis is not None else None
        model_cov = model_cov if updated is None else updated
        # ``chi2`` stays the one of the terms' own best fit, the statistic the test rejected:
        # the coefficients with the discrepancy follow the whole curve on purpose, and their
        # chi-square under the terms' covariance (on a validation record 73.9 on 12 dof,
        # p = 6e-11, against 33.0, p = 0.00098, for the best fit) would overstate the misfit
    gw = _Whitener(current)(g)
    col = np.linalg.norm(gw, axis=0)
    col[col == 0] = 1.0
    theta_free = np.asarray(
        np.linalg.lstsq(gw / col, _Whitener(current)(data.y), rcond=None)[0] / col,
        dtype=np.float64,
    )
    jac = _jacobian(specs, data, theta, log_phi)
    param_cov = _parameter_covariance(jac, current)
    return GLSSolution(
        specs=specs,
        theta=theta,
        theta_free=theta_free,
        log_phi=log_phi,
        param_cov=param_cov,
        cov=current,
        model_cov=model_cov,
        discrepancy=math.sqrt(delta2),
        discrepancy_cov=delta2 * np.diag(shape) if delta2 > 0 else np.zeros_like(current),
        fitted=g @ theta,
        chi2=chi2,
        chi2_fit=math.inf
        if _noiseless(basis, theta, fixed)
        else _chi2(current, data.y - g @ theta),
        iterations=done,
        jacobian=jac,
        design=g,
        y=data.y,
        basis=basis,
    )


def _noiseless(basis: CovarianceBasis | None, theta: NDArray[np.float64], fixed: bool) -> bool:
    """Whether the fitted model has no covariance of its own (every noise amplitude 0)."""
    return not fixed and basis is not None and _covariance(basis, theta) is None


def _chi2(cov: NDArray[np.float64], resid: NDArray[np.float64]) -> float:
    w = _Whitener(cov)(resid)
    return float(w @ w)


def _parameter_covariance(
    jac: NDArray[np.float64], cov: NDArray[np.float64]
) -> NDArray[np.float64]:
    jw = _Whitener(cov)(jac)
    norms = np.linalg.norm(jw, axis=0)
    norms[norms == 0] = 1.0
    info = (jw / norms).T @ (jw / norms)
    return np.linalg.pinv(info) / np.outer(norms, norms)


def score_interval(sol: GLSSolution, j: int, z: float) -> tuple[float, float]:
    r"""Interval of the squared amplitude ``theta_j`` with the covariance evaluated at the bound.

    The set of :math:`\theta_0 \ge 0` with :math:`|\hat\theta_j - \theta_0| \le z\,
    \mathrm{se}_j(\theta_0)`, where :math:`\hat\theta_j \ge 0` is the reported (constrained)
    estimate and :math:`\mathrm{se}_j(\theta_0)` comes from the covariance of the AVAR estimates
    under the fitted model with :math:`\theta_j` set to :math:`\theta_0` (plus the fitted model
    discrepancy, see :func:`solve`): a score-type interval, like Wilson's for a proportion (an
    AVAR estimate's spread grows with its mean, so a Wald interval with the spread at the
    estimate under-covers). The interval always contains the estimate; an estimate at the
    bound 0 gets ``[0, upper]`` with ``upper > 0``. Falls back to the Wald interval when no
    covariance basis is available.
    """
    est = max(float(sol.theta[j]), 0.0)
    se_hat = math.sqrt(max(sol.param_cov[j, j], 0.0))
    if sol.basis is None or se_hat == 0:
        return max(est - z * se_hat, 0.0), est + z * se_hat
    basis = sol.basis
    extra = sol.discrepancy_cov

    white = _Whitener(sol.cov)
    others = [k for k in range(sol.theta.size) if k != j]

    def se(theta0: float) -> float:
        # profile: the other amplitudes re-fitted with theta_j held at theta0
        theta = np.maximum(sol.theta, 0.0).copy()
        theta[j] = max(theta0, 0.0)
        if others:
            rest, _ = _nnls(white, sol.design[:, others], sol.y - theta[j] * sol.design[:, j])
            theta[others] = rest
        cov = _covariance(basis, theta)
        if cov is None:
            return se_hat
        return math.sqrt(max(_parameter_covariance(sol.jacobian, cov + extra)[j, j], 0.0))

    def g(theta0: float) -> float:
        return (est - theta0) / max(se(theta0), 1e-300)

    hi = est + z * se_hat
    for _ in range(40):
        if g(hi) <= -z:
            break
        hi = hi * 2.0 + z * se_hat
    if g(hi) > -z:  # the spread grows as fast as the value: no upper limit at this level
        upper = math.inf
    else:
        upper = optimize.brentq(lambda t: g(t) + z, est, hi, xtol=1e-12 * hi + 1e-300)
    if est <= 0 or g(0.0) <= z:
        lower = 0.0
    else:
        lower = optimize.brentq(lambda t: g(t) - z, 0.0, est, xtol=1e-12 * est + 1e-300)
    return float(lower), float(upper)
