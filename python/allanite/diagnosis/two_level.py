r"""Two levels or a Gaussian process of the same spectrum: the telegraph's own test.

A random telegraph signal ``+-a`` of correlation time ``T_c`` has exactly the Allan variance
and the spectrum of a Gauss-Markov process of standard deviation ``a`` (its *Gaussian twin*):
only its two levels tell it apart. The time view's ``kurt_lf`` looks for platykurtic block
means at fixed block sizes against the simulated sensor alone. Next to more white noise, which
dilutes the fourth cumulant of block means, it misses a telegraph that the tau view sees
clearly; and even at the best block size the kurtosis of a Gaussian slow process over a
record of a few dozen correlation times scatters so widely (standard deviation ~0.3-0.5) that
a diluted telegraph (excess ~ -0.8) stands out by little more than 2 sigma.

This test uses the time structure instead. The record's means over blocks of
``b ~ T_c / 4`` samples (:func:`matched_block`), with a least-squares line removed (a ramp's
block means are not two levels), are scored by the log-likelihood ratio of two hypotheses
with the same second-order law (:func:`_log_likelihoods`): a two-state hidden Markov chain
``+-a`` switching with probability ``(1 - phi) / 2`` per block, against a Gaussian AR(1)
state (Kalman filter), both with block-to-block correlation ``phi = exp(-b dt / T_c)`` and
independent noise of the record's remaining block-mean variance. Within a dwell (``2 T_c``
on average) the telegraph's level is constant, which the chain exploits and a marginal
statistic cannot.

The null law of the ratio is that of the simulated sensor, plus the effects the joint
attribution has already chosen, plus the Gaussian twin: each of ``n_rep`` replicates of the
sensor's model (simulated once per diagnosis at the fitted length, kept as 8-sample block
means) plus one replicate of each chosen effect's process (``ctx["background"]``, set by
:func:`with_set`; simulated at :data:`SET_SEED`, cached per term) plus :data:`PAIRINGS`
replicates of a unit Gauss-Markov process of the twin's ``T_c`` scaled to its ``sigma``
(cached per ``T_c``), plus white noise making up the record's own block-mean variance (its
excess over all of these); the one-sided p-value is the normal tail of
``(LR_real - mean) / sd`` over these sums. Without the chosen effects the null is wrong inside
the joint attribution: a slow process already in the set is taken for white noise. The twin
is itself an estimate, so the caller may pass several plausible twins (``twins``): the
largest p-value counts. A telegraph
is shown when it is below the evidence level. The same construction with the twin replaced
by a unit telegraph at its most favourable level (all the record's block-mean variance beyond
the sensor) gives the ratio the candidate itself predicts: a record with much more of a
two-level look than that (a step) is not explained by the telegraph.

References
----------
S. Machlup, "Noise in semiconductors: spectrum of a two-parameter random signal", J. Appl.
Phys. 25 (1954) 341-343 (the telegraph's Lorentzian spectrum).
L. R. Rabiner, "A tutorial on hidden Markov models and selected applications in speech
recognition", Proc. IEEE 77 (1989) 257-286 (the forward algorithm).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

__all__ = [
    "TWO_LEVEL_BLOCK",
    "TWO_LEVEL_REPLICATES",
    "matched_block",
    "two_level_context",
    "two_level_p",
    "with_set",
]

#: the record and the model's replicates are kept as means of this many samples
TWO_LEVEL_BLOCK = 8
#: replicates of the simulated sensor and of the unit processes (their sums: the square)
TWO_LEVEL_REPLICATES = 40
#: each sensor replicate is summed with this many of the unit process's replicates
PAIRINGS = 10
#: the matched block must leave at least this many blocks in the record
MIN_BLOCKS = 64
#: the block is this fraction of the correlation time
BLOCK_FRACTION = 0.25
#: at most this many blocks (the forward recursion's length: its cost)
MAX_BLOCKS = 1024
#: seed of the unit processes' replicates (fixed: a diagnosis is reproducible)
UNIT_SEED = 20261126
#: seed of the replicates of the effects already chosen (the set's part of the null)
SET_SEED = 20261127

_UNIT_CACHE: dict[tuple[str, float, float, int, int], NDArray[np.float64]] = {}


def _block_means(x: NDArray[np.float64], b: int) -> NDArray[np.float64]:
    """Means of consecutive ``b``-sample blocks along the last axis."""
    nb = x.shape[-1] // b
    return np.asarray(x[..., : nb * b].reshape(*x.shape[:-1], nb, b).mean(axis=-1))


def two_level_context(
    x: NDArray[np.float64], model: Any, fs: float, *, seed: int, n_rep: int = TWO_LEVEL_REPLICATES
) -> dict[str, Any]:
    """The record's and the simulated sensor's 8-sample block means for :func:`two_level_p`.

    Parameters
    ----------
    x : numpy.ndarray
        The fitted part of the real record.
    model : NoiseModel
        The simulated sensor.
    fs : float
        Sampling frequency in Hz.
    seed : int
        Seed of the sensor's replicates.
    n_rep : int
        Number of replicates.

    Returns
    -------
    dict
        ``means`` (the record's), ``null_means`` (``n_rep`` rows), ``fs`` and ``n``.
    """
    reps = np.asarray(model.simulate(x.size, fs=fs, n_channels=n_rep, seed=seed), dtype=float)
    reps = reps.reshape(x.size, n_rep).T
    return {
        "means": _block_means(np.asarray(x, dtype=np.float64), TWO_LEVEL_BLOCK),
        "null_means": _block_means(reps, TWO_LEVEL_BLOCK),
        "fs": float(fs),
        "n": int(x.size),
    }


def matched_block(tau_c: float, fs: float, n: int) -> int | None:
    """Block length (samples, a multiple of 8) matched to a correlation time ``tau_c``.

    :data:`BLOCK_FRACTION` of ``tau_c`` rounded to whole 8-sample blocks (at least one, and
    long enough that at most :data:`MAX_BLOCKS` blocks fill the ``n`` samples); None when fewer
    than :data:`MIN_BLOCKS` blocks fit.
    """
    k = max(1, round(BLOCK_FRACTION * tau_c * fs / TWO_LEVEL_BLOCK))
    k = max(k, -(-n // (MAX_BLOCKS * TWO_LEVEL_BLOCK)))  # at most MAX_BLOCKS blocks (cost)
    b = k * TWO_LEVEL_BLOCK
    return b if n // b >= MIN_BLOCKS else None


def _unit_means(kind: str, tau_c: float, fs: float, n: int, n_rep: int) -> NDArray[np.float64]:
    """8-sample block means of ``n_rep`` unit processes (``markov`` or ``telegraph``), cached."""
    from allanite.model import NoiseModel
    from allanite.terms import term_from_dict

    tau_r = float(2.0 ** (round(np.log2(tau_c) * 16) / 16))  # 16 steps per octave: shared fits
    key = (kind, tau_r, fs, n, n_rep)
    if key not in _UNIT_CACHE:
        if len(_UNIT_CACHE) >= 64:
            _UNIT_CACHE.pop(next(iter(_UNIT_CACHE)))
        level = "sigma" if kind == "markov" else "amplitude"
        term = term_from_dict({"type": kind, level: 1.0, "tau_c": tau_r})
        x = NoiseModel((term,)).simulate(
            n, fs=fs, n_channels=n_rep, seed=UNIT_SEED, allow_aliasing=True
        )
        _UNIT_CACHE[key] = _block_means(np.asarray(x, dtype=float).reshape(n, n_rep).T, 8)
    return _UNIT_CACHE[key]


def _log_likelihoods(
    y: NDArray[np.float64], amplitude: float, phi: float, noise: float
) -> NDArray[np.float64]:
    """``log L(two levels) - log L(Gaussian twin)`` of each row of block means ``y``.

    Both hypotheses with the same second-order law: a slow part of variance ``a^2`` whose
    block-to-block correlation is ``phi``, plus independent noise of variance ``noise``. Two
    levels: a two-state hidden Markov chain ``+-a`` switching with probability
    ``(1 - phi) / 2`` per block (forward algorithm); Gaussian: an AR(1) state (Kalman filter).
    """
    r, a2 = noise, amplitude * amplitude
    q = 0.5 * (1.0 - phi)
    ll_g = np.zeros(y.shape[0])
    m = np.zeros(y.shape[0])
    p_var = a2
    log_p = np.full((2, y.shape[0]), np.log(0.5))
    ll_h = np.zeros(y.shape[0])
    log_stay, log_move = np.log1p(-q), np.log(q)
    for t in range(y.shape[1]):
        yt = y[:, t]
        s = p_var + r
        innov = yt - m
        ll_g += -0.5 * (np.log(2.0 * np.pi * s) + innov * innov / s)
        gain = p_var / s
        m = phi * (m + gain * innov)
        p_var = phi * phi * (1.0 - gain) * p_var + a2 * (1.0 - phi * phi)
        pred_up = np.logaddexp(log_stay + log_p[0], log_move + log_p[1])
        pred_dn = np.logaddexp(log_move + log_p[0], log_stay + log_p[1])
        up = pred_up - (yt - amplitude) ** 2 / (2.0 * r)
        dn = pred_dn - (yt + amplitude) ** 2 / (2.0 * r)
        c = np.logaddexp(up, dn)
        ll_h += c - 0.5 * np.log(2.0 * np.pi * r)
        log_p = np.stack([up - c, dn - c])
    return np.asarray(ll_h - ll_g)


def _detrended(means: NDArray[np.float64]) -> NDArray[np.float64]:
    m = np.atleast_2d(means)
    t = np.arange(m.shape[-1], dtype=np.float64)
    t -= t.mean()
    c = m - m.mean(axis=-1, keepdims=True)
    return np.asarray(c - np.outer((c @ t) / (t @ t), t))


def with_set(view: Any, terms: list[Any]) -> Any:
    """The time view whose two-level context holds the effects already chosen (``terms``).

    The joint attribution fits a telegraph on top of a set of effects; the null of its
    two-level test is the simulated sensor *plus those effects* (their processes simulated
    over the fitted length, :func:`_term_means`) plus the Gaussian twin. Unchanged when the
    view carries no two-level context.
    """
    ctx = view.lf_kurtosis.get("two_level") if view is not None else None
    if ctx is None:
        return view
    ctx = {**ctx, "background": tuple(terms)}
    out: Any = replace(view, lf_kurtosis={**view.lf_kurtosis, "two_level": ctx})
    return out


def _term_means(term: Any, fs: float, n: int, n_rep: int) -> NDArray[np.float64]:
    """8-sample block means of ``n_rep`` replicates of one effect of the set, cached."""
    from allanite.model import NoiseModel

    key = ("set:" + repr(term), 0.0, fs, n, n_rep)
    if key not in _UNIT_CACHE:
        if len(_UNIT_CACHE) >= 64:
            _UNIT_CACHE.pop(next(iter(_UNIT_CACHE)))
        x = NoiseModel((term,)).simulate(
            n, fs=fs, n_channels=n_rep, seed=SET_SEED, allow_aliasing=True
        )
        _UNIT_CACHE[key] = _block_means(np.asarray(x, dtype=float).reshape(n, n_rep).T, 8)
    return _UNIT_CACHE[key]


def _null_base(ctx: dict[str, Any], k: int) -> NDArray[np.float64]:
    """The sensor's replicates plus the chosen effects' (``ctx["background"]``), ``k``-blocks."""
    base = np.asarray(ctx["null_means"], dtype=np.float64)
    for term in ctx.get("background", ()):
        base = base + _term_means(term, float(ctx["fs"]), int(ctx["n"]), base.shape[0])
    return _block_means(base, k)


def _p_value(
    y: NDArray[np.float64],
    base: NDArray[np.float64],
    unit: NDArray[np.float64],
    a: float,
    phi: float,
    rng: np.random.Generator,
) -> float:
    """One-sided p of the record's ratio ``y`` against ``base`` + ``a`` x ``unit`` + white."""
    nb = min(base.shape[-1], unit.shape[-1], y.shape[-1])
    total = float(y.var())
    # each base replicate with PAIRINGS of the unit replicates (shifted): the null sums
    r = base.shape[0]
    pick = (np.arange(r)[:, None] + np.arange(PAIRINGS)[None, :]) % r
    sums = (base[:, None, :nb] + a * unit[pick, :nb]).reshape(-1, nb)
    # the record's block-mean variance beyond the null's: white noise
    rest = total - float(sums.var(axis=1).mean())
    if rest > 0:
        sums = sums + np.sqrt(rest) * rng.standard_normal(sums.shape)
    noise = max(total - a * a, 1e-3 * total)
    real = _log_likelihoods(y[:, :nb], a, phi, noise)[0]
    null = _log_likelihoods(_detrended(sums), a, phi, noise)
    sd = float(null.std(ddof=1))
    z = (real - float(null.mean())) / sd if sd > 0 else 0.0
    return float(stats.norm.sf(z))


def two_level_p(
    term: Any, ctx: dict[str, Any], twins: list[tuple[float, float]] | None = None
) -> tuple[float, float, int] | None:
    """p-values of the two-level test of a telegraph ``term`` (see the module docstring).

    Parameters
    ----------
    term : Telegraph
        The fitted candidate (its ``amplitude`` and ``tau_c``).
    ctx : dict
        :func:`two_level_context` of the record (with ``background``, :func:`with_set`).
    twins : list of (sigma, tau_c), optional
        The Gaussian twins the record must be told from (default: the candidate's own
        ``(amplitude, tau_c)``); ``p_gauss`` is the largest of their p-values.

    Returns
    -------
    (p_gauss, p_own, block) or None
        ``p_gauss``: one-sided p-value of the likelihood ratio (two levels against the
        Gaussian twin) being as large as the record's if the process were the Gaussian twin
        (small: two levels shown); ``p_own``: the same against the telegraph itself (small:
        the record has more of a two-level look than the candidate explains); ``block``: the
        block in samples. None when the record is too short for the correlation time.
    """
    fs, n = float(ctx["fs"]), int(ctx["n"])
    tau_c, amplitude = float(term.tau_c), float(term.amplitude)
    b = matched_block(tau_c, fs, n)
    if b is None or not np.isfinite(amplitude) or amplitude <= 0:
        return None
    k = b // TWO_LEVEL_BLOCK
    y = _detrended(_block_means(ctx["means"], k))
    base = _null_base(ctx, k)
    r = base.shape[0]
    rng = np.random.default_rng(UNIT_SEED + b)
    p_gauss = 0.0
    for sigma, tc in twins if twins else [(amplitude, tau_c)]:
        unit = _block_means(_unit_means("markov", tc, fs, n, r), k)
        phi = float(np.exp(-b / (fs * tc)))
        p_gauss = max(p_gauss, _p_value(y, base, unit, sigma, phi, rng))
    # the telegraph itself at its most favourable level: all of the record's block-mean
    # variance beyond the sensor and the set (a telegraph fitted next to more white noise
    # takes only part)
    own = float(np.sqrt(max(amplitude**2, float(y.var()) - float(base.var(axis=1).mean()))))
    unit = _block_means(_unit_means("telegraph", tau_c, fs, n, r), k)
    p_own = _p_value(y, base, unit, own, float(np.exp(-b / (fs * tau_c))), rng)
    return p_gauss, p_own, b
