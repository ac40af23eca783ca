r"""The averaging-time view: where in tau the real Allan variance departs from the simulation.

Feature: the log of the overlapping Allan variance at octave-spaced averaging factors
``m = 1, 2, 4, ...`` up to ``N/10`` (so that every estimate has at least about five degrees of
freedom). The residual vector ``r = log AVAR_real - log AVAR_sim`` is judged with the covariance
``C`` of the null residuals from the Monte Carlo replicates of the simulated sensor, which
carries the strong correlation between neighbouring taus (about 0.5 between adjacent octaves
and more at long tau).

Gap statistic
-------------
``T = r^T C^{-1} r`` is a Mahalanobis distance; under the null it has mean ``T0 ~ k`` (``k`` taus)
and a p-value from a scaled chi-square matched to the leave-one-out null values. The gap

.. math:: G = \max(0,\; T - T_0)

is the part of ``T`` that chance does not explain; it is 0 for a perfect simulation and the
shrinkage of an added effect is ``1 - G_after / G_before``.

Per-tau residuals ``z_i = r_i / sqrt(C_ii)`` are flagged with a simultaneous threshold (the
``1 - alpha`` quantile of ``max_i |z_i|`` under the null), and flagged runs become the tau bands.

Null of a model: exact covariance instead of replicates
-------------------------------------------------------
When the simulated sensor is a model and the record is long, the null of the tau view needs no
Monte Carlo record at all (:func:`gaussian_tau_null`): the mean Allan variance is the model's
exact ``avar``, the covariance ``V`` of the overlapping estimates between taus is the model's
Gaussian (Whittle) covariance :func:`allanite.fit.covariance.avar_covariance` (the fit's
covariance, with quantization's fourth cumulant) plus the terms' non-Gaussian
``avar_excess_variance`` on the diagonal. Each estimate is a scaled chi-square with
``nu_i = 2 mu_i^2 / V_ii`` degrees of freedom, so its log has mean
``log mu_i + psi(nu_i/2) - log(nu_i/2)``; null draws of the log-AVAR vector are a Gaussian
copula with the correlation of ``V`` and these marginals. ``T``, the per-tau thresholds and
the band come from the draws exactly as from replicates (calibrated in
``benchmarks/calibrate_diagnosis_null.py``).

References
----------
D. W. Allan, "Statistics of atomic frequency standards", Proc. IEEE 54 (1966) 221-230.
C. A. Greenhall, W. J. Riley, "Uncertainty of stability variances based on finite
differences", 35th PTTI (2003): the correlation between AVAR estimates at different taus.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, ClassVar, cast

import numpy as np
from numpy.typing import NDArray
from scipy import special, stats

from allanite import _core
from allanite.diagnosis.null import NullEnsemble, chi2_like_sf, gumbel_isf, level_profiled, runs

if TYPE_CHECKING:
    from allanite.terms import Term

__all__ = [
    "TauModel",
    "TauView",
    "gaussian_tau_null",
    "octave_factors",
    "tau_covariance",
    "tau_features",
]

#: shrinkage of the Monte Carlo covariance toward its diagonal (stabilises the inverse)
COV_SHRINK = 0.05


def octave_factors(n: int) -> NDArray[np.int64]:
    """Octave averaging factors ``1, 2, 4, ...`` up to ``n / 10``."""
    top = max(int(np.floor(np.log2(max(n / 10.0, 1.0)))), 0)
    return (2 ** np.arange(top + 1)).astype(np.int64)


def tau_features(x: NDArray[np.float64], fs: float, m: NDArray[np.int64]) -> NDArray[np.float64]:
    """Log overlapping Allan variance of a rate record at factors ``m``.

    Calls the C++ kernels directly (the public :func:`allanite.avar` also computes EDFs and
    noise identification, which the Monte Carlo replicates do not need).
    """
    phase = _core.phase(x.reshape(-1, 1), "rate")
    var = np.asarray(_core.variance(phase, m, "overlapping", 1))[:, 0]
    return np.asarray(np.log(np.maximum(var, 1e-300)), dtype=np.float64)


def gaussian_tau_null(
    model: Any, m: NDArray[np.int64], fs: float, n: int, *, n_draw: int, seed: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Reference log AVAR, mean AVAR and ``n_draw`` null residual draws from the model alone.

    See the module docstring (*Null of a model*). The cost does not depend on ``n``.

    Parameters
    ----------
    model : NoiseModel
        The simulated sensor.
    m : numpy.ndarray
        Averaging factors.
    fs : float
        Sampling frequency in Hz.
    n : int
        Record length in samples.
    n_draw : int
        Number of null draws.
    seed : int
        Seed of the draws.

    Returns
    -------
    ref : numpy.ndarray
        Mean log AVAR per tau.
    avar : numpy.ndarray
        Mean AVAR per tau (the model's exact ``avar``).
    null : numpy.ndarray
        ``(n_draw, len(m))`` null residuals of the log AVAR (draw minus its mean).
    """
    dt = 1.0 / fs
    tau = np.asarray(m, dtype=np.float64) * dt
    mu = np.asarray(model.avar(tau, dt), dtype=np.float64)
    if np.any(mu <= 0):
        raise ValueError("the model's Allan variance is not positive at every tau; add noise terms")
    cov = tau_covariance(model, m, dt, n)
    cov[np.diag_indices_from(cov)] += np.asarray(model.avar_excess_variance(tau, dt, n))
    var = np.maximum(np.diag(cov), 1e-300)
    corr = cov / np.sqrt(np.outer(var, var))
    corr = 0.5 * (corr + corr.T)
    np.fill_diagonal(corr, 1.0)
    w, v = np.linalg.eigh(corr)  # nearest positive semi-definite correlation (clip eigenvalues)
    root = v * np.sqrt(np.maximum(w, 0.0))
    nu = 2.0 * mu * mu / var
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((n_draw, tau.size)) @ root.T
    z /= np.sqrt(np.maximum(np.sum(root * root, axis=1), 1e-300))
    draws = np.log(stats.chi2.isf(stats.norm.sf(z), nu) / nu)
    mean_log = special.digamma(nu / 2.0) - np.log(nu / 2.0)
    return (
        np.asarray(np.log(mu) + mean_log, dtype=np.float64),
        mu,
        np.asarray(draws - mean_log, dtype=np.float64),
    )


@dataclass(frozen=True)
class _RecordMeanSpectrum:
    """A term whose level follows a profile, seen through its record-mean spectrum."""

    term: Any
    stationary: ClassVar[bool] = True

    def psd_sampled(self, f: Any, dt: float) -> Any:
        return self.term.psd_sampled(f, dt)


def _profile_moment(term: Any, n: int, dt: float) -> float:
    """Record mean of the squared level profile ``(N(t)^2 / N^2)^2`` (1 for a steady level)."""
    k = min(n, 2**16)  # the profile is piecewise linear: 2^16 midpoints resolve it
    t = (np.arange(k) + 0.5) * (n * dt / k)
    v = np.asarray(term.variance_scale(t), dtype=np.float64)
    return float(np.mean(v * v) / np.mean(v) ** 2)


#: at most this many lags per pair of taus in the sums over the bursts' overlap
BURST_LAGS = 2048


def _haar_acf(m: int, lag: NDArray[np.float64]) -> NDArray[np.float64]:
    """Autocorrelation of the Allan difference filter at factor ``m`` (``g_m(l)``, ``l >= 0``).

    The filter is ``-1/m`` on ``m`` samples, then ``+1/m`` on the next ``m``:
    ``g(l) = (2m - 3l) / m^2`` for ``l <= m``, ``-(2m - l) / m^2`` for ``m <= l <= 2m``, 0 beyond.
    """
    a = np.abs(lag)
    return np.asarray(
        np.where(a <= m, (2.0 * m - 3.0 * a), np.where(a <= 2 * m, -(2.0 * m - a), 0.0)) / m**2
    )


def _span_overlap(spans: NDArray[np.float64], lag: NDArray[np.float64]) -> NDArray[np.float64]:
    """``|B ∩ (B + l)|``: samples inside a span whose ``l``-th successor is in one too.

    The overlap of two boxes shifted by ``l`` is a trapezoid in ``l``, a sum of four ramps
    ``max(l - c, 0)`` (corners ``c`` at the differences of their ends); all pairs' ramps are
    summed at once by sorting the corners (``O(K^2 log K + L log K)`` for ``K`` spans).
    """
    s, e = spans[:, 0], spans[:, 1]
    corners = np.concatenate(
        [
            (s[:, None] - e[None, :]).ravel(),
            (s[:, None] - s[None, :]).ravel(),
            (e[:, None] - e[None, :]).ravel(),
            (e[:, None] - s[None, :]).ravel(),
        ]
    )
    k2 = s.size * s.size
    weight = np.repeat([1.0, -1.0, -1.0, 1.0], k2)
    order = np.argsort(corners, kind="stable")
    c, w = corners[order], weight[order]
    cw = np.concatenate([[0.0], np.cumsum(w)])
    cwc = np.concatenate([[0.0], np.cumsum(w * c)])
    i = np.searchsorted(c, lag, side="right")
    return np.asarray(np.maximum(lag * cw[i] - cwc[i], 0.0))


def burst_factor(
    m: NDArray[np.int64], spans: Any, n: int, white: float, burst: float
) -> NDArray[np.float64]:
    r"""Factor of the white block of the AVAR covariance when white noise comes in bursts.

    White noise of variance ``white`` everywhere and ``white + burst`` inside the sample
    ``spans`` (``[start, stop)``, duty ``d``). The overlapping estimate at factor ``m`` is a
    quadratic form ``x^T Q_m x`` with ``Q_m[t, u] ~ g_m(t - u) / 2M`` (:func:`_haar_acf`), so the
    covariance of white noise with a variance profile ``v_t`` is
    ``2 sum_{t,u} Q_a[t,u] Q_b[t,u] v_t v_u = sum_l g_a(l) g_b(l) sum_t v_t v_{t+l} / 2 M_a M_b``:
    against a steady level ``v`` (the record mean) the factor is

    .. math:: F_{ab} = \frac{(w^2 + 2 w b d) \sum_l g_a g_b (n - |l|)
              + b^2 \sum_l g_a g_b |B \cap (B + l)|}{\bar v^2 \sum_l g_a g_b (n - |l|)},

    exact at every ``tau`` up to the edges of the record (short taus: ``E[v^2]/E[v]^2``; taus
    comparable to the burst length and longer: the bursts' overlap with themselves at the
    filters' lags, which falls as the filters span whole bursts). The lags are summed on at most
    :data:`BURST_LAGS` points per pair (a midpoint rule: the terms are piecewise cubic in
    ``l``, smooth between the filters' breakpoints, so the sum is approximate there).
    """
    sp = np.asarray(spans, dtype=np.float64).reshape(-1, 2)
    mm = np.asarray(m, dtype=np.int64)
    k = mm.size
    out = np.ones((k, k))
    if sp.size == 0 or burst <= 0:
        return out
    d = float(np.sum(sp[:, 1] - sp[:, 0])) / n
    mean = white + burst * d
    grids: dict[int, tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]] = {}
    for i in range(k):
        for j in range(i, k):
            lo = int(min(mm[i], mm[j]))
            if lo not in grids:
                step = max(1, -(-2 * lo // BURST_LAGS))
                lag = np.concatenate([[0.0], np.arange(1, 2 * lo, step) + 0.5 * (step - 1)])
                wt = np.concatenate([[1.0], np.full(lag.size - 1, 2.0 * step)])
                grids[lo] = (lag, wt, _span_overlap(sp, lag))
            lag, wt, ov = grids[lo]
            gg = wt * _haar_acf(int(mm[i]), lag) * _haar_acf(int(mm[j]), lag)
            steady = float(np.sum(gg * (n - lag)))
            if steady <= 0:
                continue
            own = float(np.sum(gg * ov)) / steady
            out[i, j] = out[j, i] = (white**2 + 2.0 * white * burst * d + burst**2 * own) / mean**2
    return out


def _is_white(term: Any) -> bool:
    return getattr(term, "type", "") in ("white", "white_bursts")


def _is_burst(term: Any) -> bool:
    return getattr(term, "type", "") == "white_bursts"


def tau_covariance(
    model: Any, m: NDArray[np.int64], dt: float, n: int, *, bursts: Any = ()
) -> NDArray[np.float64]:
    r"""Covariance of the overlapping AVAR estimates at factors ``m`` under ``model``.

    The Gaussian (Whittle) covariance :func:`allanite.fit.covariance.avar_covariance` of the
    stationary terms, and of every term whose level follows a profile over the record (a
    ``variance_scale(t)``, mean 1: :class:`allanite.terms.WhiteDrift`), which that function
    leaves out as non-stationary although it dominates the short taus. Such a term enters
    with its record-mean spectrum; each squared difference of the estimate carries the local
    variance, so the term's own block is scaled by :math:`\overline{v^2}/\bar v^2` (``v``
    the profile; its products with the other terms by :math:`\bar v = 1`). Exact for a
    profile that is slow against ``tau``; a model without such a term gets
    ``avar_covariance`` unchanged.

    ``bursts``: the sample spans ``[start, stop)`` where the record's white noise is raised
    (:func:`allanite.diagnosis.noise_level.burst_spans`). Then a
    :class:`allanite.terms.WhiteBursts` term is on in those spans only, and the whole white
    block (the model's white noise and the bursts' together) carries that variance profile:
    it is scaled per pair of taus by :func:`burst_factor` (about ``E[v^2]/E[v]^2`` at short
    taus, less once the filters span the bursts).
    """
    cov, block, white, burst = _covariance_parts(model, m, dt, n)
    if len(bursts) and burst > 0:
        cov = cov + (burst_factor(m, bursts, n, white, burst) - 1.0) * block
    return cov


def _covariance_parts(
    model: Any, m: NDArray[np.int64], dt: float, n: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], float, float]:
    """Steady covariance, the white block in it, the white and burst variances per sample."""
    from allanite.fit.covariance import CovarianceBasis

    profiled = [level_profiled(t) for t in model.terms]
    terms = [_RecordMeanSpectrum(t) if p else t for t, p in zip(model.terms, profiled, strict=True)]
    basis = CovarianceBasis(cast("list[Term]", terms), m, dt, n)
    cov = basis(np.ones(len(terms)))
    for a, p in enumerate(profiled):
        if p:
            cov = cov + (_profile_moment(model.terms[a], n, dt) - 1.0) * basis.basis[a, a]
    whites = [a for a, t in enumerate(model.terms) if _is_white(t) and not profiled[a]]
    block = np.zeros_like(cov)
    for a in whites:
        for b in whites:
            block = block + basis.basis[a, b]
    # white noise as a variance per sample, N^2 / dt (the bursts': inside them)
    burst = sum(float(model.terms[a].N) ** 2 for a in whites if _is_burst(model.terms[a]))
    white = sum(float(model.terms[a].N) ** 2 for a in whites) - burst
    return np.array(cov, dtype=np.float64), block, white / dt, burst / dt


def _root(c: NDArray[np.float64], power: float) -> NDArray[np.float64]:
    """Symmetric power of a covariance (eigenvalues clipped at a relative 1e-12)."""
    w, v = np.linalg.eigh(0.5 * (c + c.T))
    w = np.maximum(w, 1e-12 * float(np.max(w)))
    return np.asarray((v * w**power) @ v.T, dtype=np.float64)


def _mean_log(nu: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mean of ``log(chi2_nu / nu)``."""
    return np.asarray(special.digamma(nu / 2.0) - np.log(nu / 2.0))


def _shrunk_inverse(null: NDArray[np.float64]) -> NDArray[np.float64]:
    cov = np.cov(null, rowvar=False, ddof=1)
    cov = np.atleast_2d(cov)
    cov = (1.0 - COV_SHRINK) * cov + COV_SHRINK * np.diag(np.diag(cov))
    return np.asarray(np.linalg.inv(cov), dtype=np.float64)


@dataclass(frozen=True)
class TauModel:
    """What candidate fits need from the tau view: data, reference and inverse covariance.

    ``statistic(extra)`` is ``T`` for the simulated sensor plus an effect whose Allan variance
    is ``extra``: the reference log AVAR becomes ``ref + log(1 + extra / S)`` with ``S`` the
    mean simulated Allan variance.

    ``model`` and ``bursts`` (the simulated sensor, when a model, and the sample spans of the
    record's bursts, :func:`allanite.diagnosis.noise_level.burst_spans`) let :meth:`holding`
    judge a set of effects against a null that holds them where they change the covariance.
    """

    tau: NDArray[np.float64]
    dt: float
    duration: float
    real: NDArray[np.float64]
    ref: NDArray[np.float64]
    sim_avar: NDArray[np.float64]
    cov_inv: NDArray[np.float64]
    real_scale: float
    null_t: NDArray[np.float64]
    null_sd: NDArray[np.float64] | None = None
    model: Any = None
    bursts: tuple[tuple[int, int], ...] = ()

    def with_bursts(self, model: Any, spans: Any) -> TauModel:
        """Return the tau model knowing the simulated sensor (a model or None) and burst spans."""
        return replace(self, model=model, bursts=tuple((int(a), int(b)) for a, b in spans))

    def holding(self, added: Any) -> TauModel:
        r"""The tau model whose null holds the effects ``added`` (terms; None entries skipped).

        An effect that only adds Allan variance moves the reference (:meth:`reference`); one
        that changes the noise level over the record changes the covariance too. Bursts
        (:class:`allanite.terms.WhiteBursts`, on in the record's :attr:`bursts` spans) make
        the white block a scale mixture: :func:`tau_covariance` with the spans gives the
        covariance ``V_1`` of the sensor plus the effects, against ``V_0`` the same with a
        steady level. The null's covariance ``C`` (replicates or exact draws of the sensor)
        is carried over by ``A = L_1^{1/2} L_0^{-1/2}`` (``L = V / mu mu^T``, the log scale):
        the real residual is judged with ``(A C A^T)^{-1}``, and since ``T`` is invariant
        under a common linear map of the residuals, the null ``T`` values stay calibrated.
        The reference moves by the change of the mean log of a scaled chi-square with
        ``nu = 2 / L_ii``. Without bursts among ``added`` (or no spans, no model) this is
        ``self``.
        """
        terms = tuple(t for t in added if t is not None)
        if self.model is None or not self.bursts or not any(_is_burst(t) for t in terms):
            return self
        n = round(self.duration / self.dt)
        m = np.rint(self.tau / self.dt).astype(np.int64)
        full = replace(self.model, terms=(*self.model.terms, *terms))
        mu = np.asarray(full.avar(self.tau, self.dt), dtype=np.float64)
        steady, block, white, burst = _covariance_parts(full, m, self.dt, n)
        steady[np.diag_indices_from(steady)] += np.asarray(
            full.avar_excess_variance(self.tau, self.dt, n)
        )
        held = steady + (burst_factor(m, self.bursts, n, white, burst) - 1.0) * block
        scale = np.outer(mu, mu)
        l0, l1 = steady / scale, held / scale
        a_inv = _root(l0, 0.5) @ _root(l1, -0.5)
        shift = _mean_log(2.0 / np.diag(l1)) - _mean_log(2.0 / np.diag(l0))
        return replace(
            self, cov_inv=a_inv.T @ self.cov_inv @ a_inv, ref=self.ref + shift, bursts=()
        )

    @property
    def t0(self) -> float:
        """Mean of ``T`` under the null (about the number of taus)."""
        return float(np.mean(self.null_t))

    def reference(self, extra: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Return the reference log AVAR with an extra additive Allan variance."""
        if extra is None:
            return self.ref
        ratio = np.maximum(1.0 + np.asarray(extra) / self.sim_avar, 1e-12)
        return np.asarray(self.ref + np.log(ratio))

    def residual(self, extra: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Real residual (scaled to one null residual) against the reference."""
        return np.asarray((self.real - self.reference(extra)) / np.sqrt(self.real_scale))

    def statistic(self, extra: NDArray[np.float64] | None = None) -> float:
        """Mahalanobis statistic ``T = r^T C^{-1} r``."""
        r = self.residual(extra)
        return float(r @ self.cov_inv @ r)

    def gap(self, extra: NDArray[np.float64] | None = None) -> float:
        """``G = max(0, T - T0)``."""
        return max(0.0, self.statistic(extra) - self.t0)

    def p_value(self, extra: NDArray[np.float64] | None = None, n_params: int = 0) -> float:
        """Calibrated p-value of ``T`` (scaled chi-square matched to the null).

        With ``n_params`` fitted parameters the degrees of freedom of the matched law are
        reduced by ``n_params`` (the fit absorbs that many directions of the residual).
        """
        t = self.statistic(extra)
        if n_params <= 0:
            return chi2_like_sf(t, self.null_t)
        mean = float(np.mean(self.null_t))
        shifted = self.null_t * max(mean - n_params, 1.0) / mean
        return chi2_like_sf(t, shifted)


@dataclass(frozen=True)
class TauView:
    """Result of the averaging-time view (plotting-ready arrays).

    Attributes
    ----------
    tau : numpy.ndarray
        Averaging times in seconds.
    real_avar, sim_avar : numpy.ndarray
        Allan variance of the real record and of the simulated sensor (reference).
    sim_low, sim_high : numpy.ndarray
        Band of the simulated Allan variance that contains a real record's estimate with
        probability ``1 - alpha`` per tau (from the null residual quantiles).
    z : numpy.ndarray
        Per-tau normalised residuals ``r_i / sqrt(C_ii)``.
    z_threshold : float
        Simultaneous threshold on ``|z|`` (familywise level ``alpha``).
    correlation : numpy.ndarray
        Correlation matrix of the residuals between taus.
    statistic : float
        ``T = r^T C^{-1} r``.
    t0 : float
        Mean of ``T`` under the null.
    gap : float
        ``G = max(0, T - t0)``.
    p_value : float
        Calibrated p-value of ``T``.
    bands_s : list of (float, float)
        Tau bands (seconds) where the gap is significant, edges half an octave out.
    """

    tau: NDArray[np.float64]
    real_avar: NDArray[np.float64]
    sim_avar: NDArray[np.float64]
    sim_low: NDArray[np.float64]
    sim_high: NDArray[np.float64]
    z: NDArray[np.float64]
    z_threshold: float
    correlation: NDArray[np.float64]
    statistic: float
    t0: float
    gap: float
    p_value: float
    bands_s: list[tuple[float, float]]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "tau_s": self.tau.tolist(),
            "real_avar": self.real_avar.tolist(),
            "sim_avar": self.sim_avar.tolist(),
            "sim_avar_low": self.sim_low.tolist(),
            "sim_avar_high": self.sim_high.tolist(),
            "z": self.z.tolist(),
            "z_threshold": self.z_threshold,
            "correlation": self.correlation.tolist(),
            "statistic": self.statistic,
            "t0": self.t0,
            "gap": self.gap,
            "p_value": self.p_value,
            "bands_s": [list(b) for b in self.bands_s],
        }


def build_tau_model(
    real: dict[str, NDArray[np.float64]],
    ens: NullEnsemble,
    tau: NDArray[np.float64],
    dt: float,
    sim_avar: NDArray[np.float64],
    duration: float,
    *,
    loo: bool = True,
) -> TauModel:
    """Build the :class:`TauModel` of a real record against the null ensemble.

    With ``loo`` (replicates) each null ``T`` uses the covariance of the other replicates,
    like the real record, which is not part of the estimate either; without it (many draws
    from a known law, :func:`gaussian_tau_null`) all draws share one covariance.
    """
    null = ens.null["log_avar"]
    cov_inv = _shrunk_inverse(null)
    n = null.shape[0]
    if loo:
        null_t = np.empty(n)
        for j in range(n):
            keep = np.ones(n, dtype=bool)
            keep[j] = False
            inv_j = _shrunk_inverse(null[keep])
            null_t[j] = float(null[j] @ inv_j @ null[j])
    else:
        null_t = np.einsum("ij,jk,ik->i", null, cov_inv, null)
    return TauModel(
        tau=tau,
        dt=dt,
        duration=duration,
        real=real["log_avar"],
        ref=ens.ref["log_avar"],
        sim_avar=sim_avar,
        cov_inv=cov_inv,
        real_scale=ens.real_scale,
        null_t=null_t,
        null_sd=null.std(axis=0, ddof=1),
    )


def tau_view(model: TauModel, ens: NullEnsemble, alpha: float) -> TauView:
    """Per-tau residuals, bands and the global statistic of the tau view."""
    null = ens.null["log_avar"]
    sd = null.std(axis=0, ddof=1)
    r = model.residual()
    z = r / sd
    zmax_null = np.max(np.abs(null / sd), axis=1)
    thr = gumbel_isf(alpha, zmax_null)
    cov = np.cov(null, rowvar=False, ddof=1)
    corr = cov / np.outer(sd, sd)
    lo_q, hi_q = np.quantile(null, [alpha / 2, 1 - alpha / 2], axis=0) * np.sqrt(model.real_scale)
    ref_var = np.exp(model.ref)
    bands: list[tuple[float, float]] = []
    for a, b in runs(np.abs(z) > thr):
        bands.append((float(model.tau[a] / np.sqrt(2.0)), float(model.tau[b] * np.sqrt(2.0))))
    t = model.statistic()
    return TauView(
        tau=model.tau,
        real_avar=np.exp(model.real),
        sim_avar=ref_var,
        sim_low=ref_var * np.exp(lo_q),
        sim_high=ref_var * np.exp(hi_q),
        z=z,
        z_threshold=thr,
        correlation=corr,
        statistic=t,
        t0=model.t0,
        gap=max(0.0, t - model.t0),
        p_value=model.p_value(),
        bands_s=bands,
    )
