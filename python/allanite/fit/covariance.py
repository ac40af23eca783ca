r"""Covariance of overlapping Allan variance estimates at different tau, for a given model.

For a Gaussian stationary rate with one-sided sampled PSD :math:`S(f)`, the overlapping AVAR
estimate at :math:`\tau_i = m_i\Delta t` is the mean of :math:`d_{ik}^2` where :math:`d_i` is
the rate filtered by :math:`|H_i(f)|^2 = 2\sin^4(\pi f\tau_i)/(m_i\sin(\pi f\Delta t))^2`.
By the Whittle (periodogram) approximation

.. math:: \mathrm{Cov}(\hat\sigma^2_i, \hat\sigma^2_j) \approx \frac{1}{T_{ij}}
          \int_0^{f_s/2} |H_i(f)|^2 |H_j(f)|^2 S(f)^2\,df,

with the effective length :math:`T_{ij} = \Delta t\sqrt{(n-m_i)(n-m_j)}` (halfway between the
record length and the span of the overlapping differences; calibrated against Monte Carlo in
``tests/test_fit_covariance.py``). Two non-Gaussian corrections are added:

* angle quantization (uniform error, excess kurtosis -6/5) adds the fourth-cumulant term
  :math:`-\tfrac{6}{5} Q^4 \cdot 9 n / (\tau_i^2\tau_j^2 M_i M_j)`, :math:`M = n - 2m`;
* a sinusoid (a spectral line of power :math:`P = A^2/2`) adds the signal-times-noise term
  :math:`(2P/T)\,|H_i(f_0)|^2|H_j(f_0)|^2 S(f_0)`.

* a rate ramp ``R t`` adds the ramp-times-noise term. The ramp's differences are the
  constant :math:`R\tau/\sqrt2`, so the estimate holds :math:`(R\tau\sqrt2/M)\sum_k d_k`
  of the noise differences, and that sum telescopes to the record's ends:
  :math:`(R\tau m/M)\,\Delta`, :math:`\Delta` = (triangular average of the last
  :math:`2m-1` samples) - (same of the first), :math:`M = n + 1 - 2m`. It does not average
  out with the record length like the noise's own term; on ramp-dominated records it is
  the main uncertainty of ``R`` (see :func:`_end_difference_integrals`).

References
----------
P. Whittle, "Curve and periodogram smoothing", J. R. Stat. Soc. B 19 (1957);
C. A. Greenhall, "Estimating the modified Allan variance", IEEE FCS (1995), for the same
spectral approach to the variance of variance estimates.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from allanite.model import NoiseModel
from allanite.terms import Quantization, RateRamp, Sine, Term
from allanite.variance.transfer import avar_transfer

__all__ = ["CovarianceBasis", "avar_covariance", "avar_transfer", "ramp_cross_basis"]

#: excess kurtosis of a uniform quantization error
UNIFORM_EXCESS_KURTOSIS = -1.2


#: sin^4(x) = sum_p C4[p] cos(2 p x)
_C4 = np.array([3.0 / 8.0, -0.5, 1.0 / 8.0])


def _frequency_bins(tau_max: float, dt: float, ratio: float) -> tuple[NDArray[np.float64], ...]:
    """Geometric bins from ``1e-3 / tau_max`` to the Nyquist frequency: edges, centres, widths."""
    nyquist = 0.5 / dt
    low = min(1e-3 / tau_max, 1e-3 * nyquist)
    count = int(np.ceil(np.log(nyquist / low) / np.log(ratio)))
    edges = np.geomspace(low, nyquist, count + 1)
    edges[0] = 0.0
    return edges, 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)


@lru_cache(maxsize=8)
def _oscillation_integrals(
    m: tuple[float, ...], dt: float, ratio: float
) -> tuple[NDArray[np.float64], ...]:
    r"""Exact bin integrals of ``sin^4(pi f tau_i) sin^4(pi f tau_j)`` (model independent).

    Expanding :math:`\sin^4 x = (3 - 4\cos 2x + \cos 4x)/8`, the product is a sum of cosines
    whose bin integrals are :math:`\Delta\cos(2\pi\omega f_c)\,\mathrm{sinc}(\omega\Delta)`;
    the smooth rest of the integrand (spectra, ``1/sin^2(pi f dt)``) is taken at the bin
    centre. Returns the bin centres and the ``(bins, T, T)`` integrals.
    """
    tau = np.asarray(m) * dt
    _, centre, width = _frequency_bins(float(tau.max()), dt, ratio)
    size = tau.size
    out = np.zeros((centre.size, size, size))
    p = np.arange(3.0)
    for i in range(size):
        for j in range(i, size):
            # where the bins are fine against the oscillation, the midpoint rule is exact
            # enough; the cosine expansion would cancel catastrophically there (f tau << 1)
            fine = width * max(tau[i], tau[j]) < 0.05
            acc = np.zeros(centre.size)
            coarse = ~fine
            fc, wc = centre[coarse], width[coarse]
            for a in range(3):
                for b in range(3):
                    coef = 0.5 * _C4[a] * _C4[b]
                    for omega in (p[a] * tau[i] - p[b] * tau[j], p[a] * tau[i] + p[b] * tau[j]):
                        acc[coarse] += coef * np.cos(2 * np.pi * omega * fc) * np.sinc(omega * wc)
            acc[coarse] *= wc
            fm, wm = centre[fine], width[fine]
            acc[fine] = np.sin(np.pi * fm * tau[i]) ** 4 * np.sin(np.pi * fm * tau[j]) ** 4 * wm
            out[:, i, j] = out[:, j, i] = acc
    out.setflags(write=False)
    centre.setflags(write=False)
    return centre, out


def _cosines(
    factors: Sequence[tuple[tuple[float, float], ...]],
) -> list[tuple[float, float]]:
    """Expand a product of sums of cosines ``sum c cos(2 pi w f)`` into one such sum."""
    out = [(1.0, 0.0)]
    for factor in factors:
        out = [
            (0.5 * c1 * c2, w) for c1, w1 in out for c2, w2 in factor for w in (w1 - w2, w1 + w2)
        ]
    return out


@lru_cache(maxsize=8)
def _end_difference_integrals(
    m: tuple[float, ...], dt: float, n: float, ratio: float
) -> tuple[NDArray[np.float64], ...]:
    r"""Bin integrals of the covariance of the end differences :math:`\Delta_i` (model free).

    With :math:`A_i(f) = \sin^2(\pi f\tau_i)/(m_i\sin\pi f\Delta t)^2` the triangular
    window's transfer and one-sided PSD :math:`S`,

    .. math:: \mathrm{Cov}(\Delta_i, \Delta_j) = 2\int_0^{f_s/2} S A_i A_j
              [\cos 2\pi f c - \cos 2\pi f d]\,df
              = \int_0^{f_s/2} \frac{S}{2 m_i^2 m_j^2 \sin^4 \pi f\Delta t}
              P_i P_j P_{ij}\,df,

    :math:`c = (m_i - m_j)\Delta t`, :math:`d = (n + 1 - m_i - m_j)\Delta t` (the distance
    between the first and the last windows), :math:`P_i = 1 - \cos 2\pi f\tau_i`,
    :math:`P_{ij} = \cos 2\pi f c - \cos 2\pi f d` (finite for a random walk: its
    increments are stationary). In each geometric bin a factor that barely changes is taken at
    the centre (in a cancellation-free product form); the others are expanded into cosines
    and integrated exactly. Returns the bin centres and the ``(bins, T, T)`` integrals of
    :math:`P_i P_j P_{ij}`.
    """
    tau = np.asarray(m) * dt
    _, centre, width = _frequency_bins(float(tau.max()), dt, ratio)
    size = tau.size
    out = np.zeros((centre.size, size, size))
    mm = np.asarray(m)
    for i in range(size):
        for j in range(i, size):
            c = (mm[i] - mm[j]) * dt
            d = (n + 1.0 - mm[i] - mm[j]) * dt
            factors = (
                (((1.0, 0.0), (-1.0, tau[i])), 2.0 * np.sin(np.pi * centre * tau[i]) ** 2, tau[i]),
                (((1.0, 0.0), (-1.0, tau[j])), 2.0 * np.sin(np.pi * centre * tau[j]) ** 2, tau[j]),
                (
                    ((1.0, c), (-1.0, d)),
                    2.0 * np.sin(np.pi * (d + c) * centre) * np.sin(np.pi * (d - c) * centre),
                    max(abs(c), abs(d)),
                ),
            )
            oscillates = [width * top >= 0.05 for _, _, top in factors]
            acc = np.zeros(centre.size)
            for pattern in range(8):
                chosen = [bool(pattern >> k & 1) for k in range(3)]
                mask = np.ones(centre.size, dtype=bool)
                for k in range(3):
                    mask &= oscillates[k] if chosen[k] else ~oscillates[k]
                if not np.any(mask):
                    continue
                fc, wc = centre[mask], width[mask]
                value = wc.copy()
                for k in range(3):
                    if not chosen[k]:
                        value *= factors[k][1][mask]
                expanded = _cosines([factors[k][0] for k in range(3) if chosen[k]])
                if len(expanded) > 1 or expanded[0][1] != 0.0:
                    value *= sum(
                        coef * np.cos(2 * np.pi * w * fc) * np.sinc(w * wc) for coef, w in expanded
                    )
                acc[mask] = value
            out[:, i, j] = out[:, j, i] = acc
    out.setflags(write=False)
    centre.setflags(write=False)
    return centre, out


def ramp_cross_basis(
    term: Term, m: NDArray[np.float64], dt: float, n_samples: int, *, ratio: float = 1.01
) -> NDArray[np.float64]:
    r"""Covariance added by a unit rate ramp (``R = 1``) times the unit noise ``term``.

    :math:`\mathrm{Cov} = \tau_i\tau_j\,m_i m_j/(M_i M_j)\,\mathrm{Cov}(\Delta_i,
    \Delta_j)` under ``term`` (see the module and :func:`_end_difference_integrals`);
    scale by ``R**2`` times the term's weight.
    """
    mm = np.asarray(m, dtype=np.float64)
    n = float(n_samples)
    centre, integrals = _end_difference_integrals(tuple(mm.tolist()), float(dt), n, float(ratio))
    weight = term.psd_sampled(centre, dt) / (2.0 * np.sin(np.pi * centre * dt) ** 4)
    cov_delta = np.tensordot(weight, integrals, axes=(0, 0)) / np.outer(mm, mm) ** 2
    tau = mm * dt
    big_m = np.maximum(n + 1.0 - 2.0 * mm, 1.0)
    factor = tau * mm / big_m
    return np.asarray(np.outer(factor, factor) * cov_delta, dtype=np.float64)


def _fourth_cumulant(m: NDArray[np.float64], dt: float, n: float) -> NDArray[np.float64]:
    """``sum_p A_i(p) A_j(p) / (M_i M_j)`` for the quantization fourth-cumulant term.

    The estimate at factor ``m`` is the mean of ``M = n + 1 - 2m`` squared differences
    ``(e_k - 2 e_{k+m} + e_{k+2m}) / (sqrt(2) tau)`` of the angle errors ``e``; ``A(p)`` is the
    sum of the squared weights that error ``p`` receives, piecewise constant in ``p``.
    """
    size = m.size
    big_m = np.maximum(n + 1.0 - 2.0 * m, 1.0)
    pieces = []
    for i in range(size):
        mi, Mi = m[i], big_m[i]
        starts = (0.0, mi, 2 * mi)
        weights = (1.0, 4.0, 1.0)
        edges = np.unique([s + d for s in starts for d in (0.0, Mi)])
        left = edges[:-1]
        value = np.zeros(left.size)
        for s0, w in zip(starts, weights, strict=True):
            value += w * ((left >= s0) & (left < s0 + Mi))
        pieces.append((edges, value / (2.0 * (mi * dt) ** 2)))
    out = np.zeros((size, size))
    for i in range(size):
        for j in range(i, size):
            edges = np.unique(np.concatenate([pieces[i][0], pieces[j][0]]))
            left, length = edges[:-1], np.diff(edges)
            vi = _piecewise(pieces[i], left)
            vj = _piecewise(pieces[j], left)
            out[i, j] = out[j, i] = float(np.sum(length * vi * vj)) / (big_m[i] * big_m[j])
    return out


def _piecewise(
    piece: tuple[NDArray[np.float64], NDArray[np.float64]], x: NDArray[np.float64]
) -> NDArray[np.float64]:
    edges, value = piece
    idx = np.searchsorted(edges, x, side="right") - 1
    inside = (idx >= 0) & (idx < value.size)
    return np.where(inside, value[np.clip(idx, 0, value.size - 1)], 0.0)


@lru_cache(maxsize=256)
def _whittle_block(
    a: Term, b: Term, m: tuple[float, ...], dt: float, n_samples: int, ratio: float
) -> NDArray[np.float64]:
    """Whittle covariance block of the unit stationary terms ``a`` and ``b`` (cached)."""
    mm = np.asarray(m)
    n = float(n_samples)
    centre, integrals = _oscillation_integrals(m, dt, ratio)
    # |H_i|^2 |H_j|^2 = 4 sin^4 sin^4 / (m_i m_j sin^2(pi f dt))^2
    envelope = 4.0 / np.sin(np.pi * centre * dt) ** 4
    weight = envelope * a.psd_sampled(centre, dt) * b.psd_sampled(centre, dt)
    block: NDArray[np.float64] = (
        np.tensordot(weight, integrals, axes=(0, 0)) / np.outer(mm, mm) ** 2
    )
    # two means over nested spans share only the shorter one: Cov ~ W_ij / max(L_i, L_j)
    eff = n - 2.0 * mm
    block /= dt * np.maximum.outer(eff, eff)
    block.setflags(write=False)
    return block


@lru_cache(maxsize=32)
def _fourth_cumulant_cached(m: tuple[float, ...], dt: float, n_samples: int) -> NDArray[np.float64]:
    out = _fourth_cumulant(np.asarray(m), dt, float(n_samples))
    out.setflags(write=False)
    return out


@lru_cache(maxsize=256)
def _ramp_block(
    term: Term, m: tuple[float, ...], dt: float, n_samples: int, ratio: float
) -> NDArray[np.float64]:
    out = ramp_cross_basis(term, np.asarray(m), dt, n_samples, ratio=ratio)
    out.setflags(write=False)
    return out


class CovarianceBasis:
    r"""The covariance of the AVAR estimates as a quadratic form in the term weights.

    With terms :math:`u_a` and weights :math:`\theta_a` (squared amplitudes), the spectrum is
    :math:`S = \sum_a \theta_a S_a`, so :math:`C(\theta) = \sum_{ab}\theta_a\theta_b B_{ab}`;
    the basis :math:`B_{ab}` is computed once and :math:`C` is then cheap for any weights (the
    iterated fit and the score intervals need many).

    The frequency integral runs over geometric bins (``ratio`` between edges) with the
    oscillating factors :math:`\sin^4(\pi f\tau_i)\sin^4(\pi f\tau_j)` integrated exactly in
    each bin, so the long and the short taus are both resolved at any record length.

    Parameters
    ----------
    terms : sequence of Term
        The unit terms :math:`u_a` (non-stationary ones contribute nothing).
    m : array_like of int
        Averaging factors.
    dt : float
        Sample period in seconds.
    n_samples : int
        Record length.
    ratio : float
        Ratio of consecutive bin edges.
    """

    def __init__(
        self,
        terms: Sequence[Term],
        m: NDArray[np.int64] | NDArray[np.float64],
        dt: float,
        n_samples: int,
        *,
        ratio: float = 1.01,
    ) -> None:
        mm = np.asarray(m, dtype=np.float64)
        key = (tuple(mm.tolist()), float(dt), int(n_samples), float(ratio))
        n = float(n_samples)
        T = n * dt
        k = len(terms)
        basis = np.zeros((k, k, mm.size, mm.size))
        stationary = [a for a, t in enumerate(terms) if t.stationary and not isinstance(t, Sine)]
        for a in stationary:
            for b in stationary:
                if b >= a:
                    basis[a, b] = basis[b, a] = _whittle_block(terms[a], terms[b], *key)
        for a, term in enumerate(terms):
            if isinstance(term, Quantization):
                basis[a, a] += (
                    UNIFORM_EXCESS_KURTOSIS * term.Q**4 * _fourth_cumulant_cached(*key[:3])
                )
            if isinstance(term, RateRamp):
                for b in stationary:
                    cross = 0.5 * term.R**2 * _ramp_block(terms[b], *key)
                    basis[a, b] += cross
                    basis[b, a] += cross
            if isinstance(term, Sine):
                f0 = float(term.frequency) % (1.0 / dt)
                f0 = min(f0, 1.0 / dt - f0)
                if f0 <= 0:
                    continue
                h0 = avar_transfer(np.array([f0]), mm, dt)[:, 0]
                for b in stationary:
                    s0 = float(terms[b].psd_sampled(np.array([f0]), dt)[0])
                    cross = 0.5 * term.amplitude**2 * s0 / T * np.outer(h0, h0)
                    basis[a, b] += cross
                    basis[b, a] += cross
        self.basis = basis

    def __call__(self, weights: NDArray[np.float64]) -> NDArray[np.float64]:
        """Covariance matrix for the term weights ``weights`` (one per term)."""
        w = np.asarray(weights, dtype=np.float64)
        cov: NDArray[np.float64] = np.einsum("a,b,abij->ij", w, w, self.basis)
        out: NDArray[np.float64] = 0.5 * (cov + cov.T)
        return out


def avar_covariance(
    model: NoiseModel,
    m: NDArray[np.int64] | NDArray[np.float64],
    dt: float,
    n_samples: int,
    *,
    ratio: float = 1.01,
) -> NDArray[np.float64]:
    """Covariance matrix of the overlapping AVAR estimates at factors ``m`` under ``model``.

    Parameters
    ----------
    model : NoiseModel
        The (current) noise model; non-stationary terms are left out of the spectrum.
    m : array_like of int
        Averaging factors.
    dt : float
        Sample period in seconds.
    n_samples : int
        Record length.
    ratio : float
        Ratio of consecutive frequency bin edges of the integration.

    Returns
    -------
    numpy.ndarray
        ``(len(m), len(m))`` covariance in squared AVAR units.
    """
    basis = CovarianceBasis(model.terms, m, dt, n_samples, ratio=ratio)
    return basis(np.ones(len(model.terms)))
