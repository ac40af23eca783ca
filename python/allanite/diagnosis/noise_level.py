r"""Shape of a noise level that changes over the record: a drift or step, or bursts.

The time view's ``hf`` statistic is the log mean square of the first differences per window,
real minus simulated, with the median over the windows removed (``r_w``, null spread
``s_w``). A white-noise level that changes over the record moves it in time; two shapes
describe such a change:

* ``white_drift`` (:class:`allanite.terms.WhiteDrift`): the variance moves linearly from one
  level to another between ``t_start`` and ``t_end`` (a step when they coincide):
  ``r_w = c + log(1 + beta g_w)`` with ``g_w`` the window mean of
  :func:`allanite.terms.white_drift.ramp_fraction`; ``t_start``, ``t_end`` on the window
  boundaries, then refined to a sixteenth of a window, and ``beta`` on a log grid, then
  refined between its neighbours, ``c`` by weighted least squares;
* ``bursts`` (:class:`allanite.terms.WhiteBursts`): raised in the windows the time view flags
  (``z_w`` above its threshold), each at its own level (a burst may cover a window partly),
  the quiet windows at one common level ``c``.

Each shape's misfit ``chi^2 = sum_w ((r_w - fit_w) / s_w)^2`` is compared with its
expectation ``W - p`` (``p`` = fitted numbers: 4 for the drift, ``1 + raised windows`` for the
bursts); the excess ``max(0, chi^2 - (W - p))`` plus the ranking's per-parameter penalty for
every shape number the tau view does not see (drift: ``ratio``, ``t_start``, ``t_end``;
bursts: one per raised window) enters the ranking of the two candidates (:func:`noise_misfit`,
through :func:`allanite.diagnosis.level_shape.level_misfit`). Separate raised stretches fit
only the bursts; a level that rises or falls once fits the drift with fewer numbers. Spikes,
which also raise ``hf``, raise it only by what their heights add to the windows that hold
them (:func:`noise_misfit`).

The drift's ``ratio`` (final over initial white-noise level) is then measured on the record
itself: the per-window white-noise variance is ``(D_w - D_o) / (2 fs)`` with ``D_w`` the
window's mean square of first differences and ``D_o = 2 A_sim(dt) - 2 fs N_sim^2`` the part
of the simulated sensor's that is not white noise (quantization, ...), and ``a + b g_w`` is
fitted to it; ``ratio = sqrt((a + b) / a)``.

The bursts' duty and mean length are then measured on the record too (:func:`burst_spans`):
each run of raised windows, widened by a window on either side, is searched for the span
``[s, e)`` of first differences whose mean square ``v`` departs most from the quiet windows'
``v_0``: the variance-change likelihood ratio ``n (v / v_0 - 1 - log(v / v_0))``, ``n = e -
s``, is maximised over ``s`` and ``e`` on a grid of at most :data:`SPAN_POSITIONS` positions
per run (a sixteenth of a window or finer), so a burst that covers windows partly is measured
to the sample scale rather than counted in whole windows.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from allanite.diagnosis.candidates import EVIDENCE
from allanite.diagnosis.null import runs
from allanite.diagnosis.time_view import TimePlan, TimeView
from allanite.terms.white_drift import ramp_window_mean

__all__ = ["DriftShape", "burst_spans", "drift_shape", "noise_misfit"]

#: grid of the variance ratio (final / initial) of the drift shape
BETA_GRID = np.concatenate([np.geomspace(1.0 / 64.0, 0.95, 40), np.geomspace(1.05, 64.0, 48)]) - 1
#: the drift has this many fitted numbers on the windows (offset, beta, t_start, t_end)
DRIFT_PARAMS = 4
#: positions per window at which the ends of the change are refined
SUBSTEPS = 16
#: at most this many candidate positions of a burst's start and end per run of raised windows
SPAN_POSITIONS = 1024


@dataclass(frozen=True)
class DriftShape:
    """Best drift/step shape of the windows' short-term noise level.

    Attributes
    ----------
    ratio : float
        Final over initial white-noise level (amplitude, not variance).
    t_start, t_end : float
        Start and end of the change in seconds (equal: a step).
    chi2 : float
        Misfit of the shape on the ``hf`` window residuals.
    n_windows : int
        Number of windows.
    """

    ratio: float
    t_start: float
    t_end: float
    chi2: float
    n_windows: int

    @property
    def excess(self) -> float:
        """``max(0, chi2 - (W - 4))``."""
        return max(0.0, self.chi2 - (self.n_windows - DRIFT_PARAMS))


def _hf(view: TimeView) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    r = view.residual.get("hf")
    sd = view.spread.get("hf")
    if r is None or sd is None or r.size < 4:
        return None
    ok = np.isfinite(sd) & (sd > 0)
    if not ok.all():
        return None
    return np.asarray(r, dtype=np.float64), np.asarray(sd, dtype=np.float64)


def _ramp_grid(
    w: int, step: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Window means ``(P, W)``, starts and ends of every ramp with ends on window boundaries.

    ``w`` windows of ``step`` seconds.
    """
    edges = np.arange(w + 1) * step
    a, b = edges[:-1], edges[1:]
    starts, ends, shapes = [], [], []
    for i in range(w):
        for j in range(i, w + 1):
            if j == i and i == 0:
                continue  # a step at t = 0 is no change
            t0, t1 = float(edges[i]), float(edges[j])  # j == i: a step at a window boundary
            starts.append(t0)
            ends.append(t1)
            shapes.append(ramp_window_mean(a, b, t0, t1))
    return np.array(shapes), np.array(starts), np.array(ends)


def _shape_chi2(
    r: NDArray[np.float64], sd: NDArray[np.float64], g: NDArray[np.float64], betas: Any
) -> NDArray[np.float64]:
    """``chi2[p, k]`` of shape ``g[p]`` (window means, ``(P, W)``) with ``beta = betas[k]``."""
    wgt = 1.0 / sd**2
    # pred[p, k, w] = log(1 + beta_k g_pw); the offset c is the weighted mean of r - pred
    pred = np.log1p(np.asarray(betas)[None, :, None] * g[:, None, :])
    resid = r[None, None, :] - pred
    c = (resid * wgt).sum(axis=2) / wgt.sum()
    return np.asarray((((resid - c[:, :, None]) / sd) ** 2).sum(axis=2))


def _best_shape(
    r: NDArray[np.float64], sd: NDArray[np.float64], g: NDArray[np.float64]
) -> tuple[float, int, float]:
    """``(chi2, shape index, beta)`` of the best of the window-mean shapes ``g (P, W)``.

    ``beta`` on :data:`BETA_GRID` (9 % steps of the variance ratio), then refined to
    :data:`SUBSTEPS` steps between the neighbours of the best (a long record measures a
    window's level to about 1 %).
    """
    chi2 = _shape_chi2(r, sd, g, BETA_GRID)
    p, k = np.unravel_index(int(np.argmin(chi2)), chi2.shape)
    lo, hi = BETA_GRID[max(k - 1, 0)], BETA_GRID[min(k + 1, BETA_GRID.size - 1)]
    fine = np.geomspace(1.0 + lo, 1.0 + hi, 2 * SUBSTEPS + 1) - 1.0
    chi2_f = _shape_chi2(r, sd, g, fine)
    q, j = np.unravel_index(int(np.argmin(chi2_f)), chi2_f.shape)
    if chi2_f[q, j] < chi2[p, k]:
        return float(chi2_f[q, j]), int(q), float(fine[j])
    return float(chi2[p, k]), int(p), float(BETA_GRID[k])


def _drift_fit(view: TimeView) -> tuple[float, float, float, float] | None:
    """``(chi2, beta, t_start, t_end)`` of the best drift shape on the hf residuals.

    The ends are first searched on the window boundaries, then refined to
    :data:`SUBSTEPS` positions per window within one window of each (a step inside a
    window leaves that window at an intermediate level, which a long record measures
    precisely: a boundary-only step would misfit it by many standard errors). The ranking
    and the joint selection ask for it once per candidate fit: it is computed once per view.
    """
    hf = _hf(view)
    if hf is None:
        return None
    r, sd = hf
    return _drift_fit_of(r.tobytes(), sd.tobytes(), float(view.window_s))


@lru_cache(maxsize=8)
def _drift_fit_of(
    r_bytes: bytes, sd_bytes: bytes, step: float
) -> tuple[float, float, float, float]:
    r = np.frombuffer(r_bytes, dtype=np.float64)
    sd = np.frombuffer(sd_bytes, dtype=np.float64)
    w = r.size
    g, starts, ends = _ramp_grid(w, step)
    chi2, p, beta = _best_shape(r, sd, g)
    duration = w * step
    edges = np.arange(w + 1) * step

    def near(t: float) -> NDArray[np.float64]:
        lo, hi = max(0.0, t - step), min(duration, t + step)
        return np.asarray(np.unique(np.round(np.arange(lo, hi + 1e-9 * step, step / SUBSTEPS), 9)))

    pairs = [
        (a, b) for a in near(starts[p]) for b in near(ends[p]) if b >= a and b > 0 and a < duration
    ]
    if pairs:
        fine = np.array([ramp_window_mean(edges[:-1], edges[1:], a, b) for a, b in pairs])
        chi2_f, q, beta_f = _best_shape(r, sd, fine)
        if chi2_f < chi2:
            return chi2_f, beta_f, float(pairs[q][0]), float(pairs[q][1])
    return chi2, beta, float(starts[p]), float(ends[p])


def _burst_fit(view: TimeView, raised: NDArray[np.bool_]) -> tuple[float, int, int] | None:
    """``(chi2, quiet windows, raised windows)`` of a shape raised in the windows ``raised``.

    A burst may cover a window partly, so each raised window keeps its own level; the quiet
    windows must share one.
    """
    hf = _hf(view)
    if hf is None:
        return None
    r, sd = hf
    quiet = ~raised
    if not raised.any() or not quiet.any():
        return None
    wgt = 1.0 / sd[quiet] ** 2
    c = float((r[quiet] * wgt).sum() / wgt.sum())
    chi2 = float((((r[quiet] - c) / sd[quiet]) ** 2).sum())
    return chi2, int(quiet.sum()), int(raised.sum())


def _flat_fit(
    view: TimeView, raise_: NDArray[np.float64] | None = None
) -> tuple[float, int, int] | None:
    """``(chi2, W, 0)`` of one common level on the hf residuals (a stationary noise level).

    ``raise_``: a known per-window raise on top of the common level (the spikes' own, see
    :attr:`TimeView.spike_raise`), no fitted number.
    """
    hf = _hf(view)
    if hf is None:
        return None
    r, sd = hf
    if raise_ is not None:
        r = r - raise_
    wgt = 1.0 / sd**2
    c = float((r * wgt).sum() / wgt.sum())
    return float((((r - c) / sd) ** 2).sum()), int(r.size), 0


def noise_misfit(effect: str, view: TimeView, per_param: float = 0.0) -> float:
    """Excess misfit of the noise-level shape of ``effect`` (drift, bursts, spikes); else 0.

    The excess ``max(0, chi^2 - (W - p))`` plus ``per_param`` (the ranking's per-parameter
    penalty, ``chi2_1`` quantile ``1 - alpha``) for every shape number the tau view does not
    see: three for the drift (``ratio``, ``t_start``, ``t_end``), one per raised window for the
    bursts. Spikes explain a changed short-term level only by as much as their heights raise
    it: when ``hf`` is significant (``alpha / len(EVIDENCE)``, the evidence's Bonferroni level)
    they pay the misfit of all windows around one common level plus each window's
    :attr:`TimeView.spike_raise` (their times and heights come from the time view, no
    penalty). A level step raises the tails of the sample distribution enough for the spike
    finder to list a few samples per window after it, but those add a fraction of a percent
    to a window's level, not the step's factor: the step stays a misfit of the spikes.
    """
    w = int(view.t_s.size)
    if effect == "spikes":
        alpha = float(stats.chi2.sf(per_param, 1)) if per_param > 0 else 0.05
        if view.family_p.get("hf", 1.0) >= alpha / len(EVIDENCE) or "hf" not in view.z:
            return 0.0
        # no located spike (a dense, fitted spike process is stationary): one common level
        spiky = _flat_fit(view, view.spike_raise if view.spike_raise.size == w else None)
        if spiky is None:
            return 0.0
        return max(0.0, spiky[0] - (spiky[1] - 1))
    if effect == "white_drift":
        fit = _drift_fit(view)
        if fit is None:
            return 0.0
        return max(0.0, fit[0] - (w - DRIFT_PARAMS)) + per_param * (DRIFT_PARAMS - 1)
    if effect == "bursts":
        burst = _burst_fit(view, view.z["hf"] > view.thresholds["hf"])
        if burst is None:
            return 0.0
        chi2, n_quiet, n_raised = burst
        return max(0.0, chi2 - (n_quiet - 1)) + per_param * n_raised
    return 0.0


def _window_white_variance(
    x: NDArray[np.float64], plan: TimePlan, fs: float, other: float
) -> NDArray[np.float64]:
    used = x[: plan.n_windows * plan.length].reshape(plan.n_windows, plan.length)
    d = np.diff(used, axis=1)
    return np.asarray((np.mean(d * d, axis=1) - other) / (2.0 * fs))


def drift_shape(
    x: NDArray[np.float64], fs: float, view: TimeView, model: Any = None
) -> DriftShape | None:
    """The drift/step shape of the record's white-noise level, or None.

    None when the time view flags no window of changed short-term level (``hf``) or when the
    white-noise variance measured on the record's windows is not positive at both ends of the
    change.

    Parameters
    ----------
    x : numpy.ndarray
        The analysed rate record.
    fs : float
        Sampling frequency in Hz.
    view : TimeView
        Its time view.
    model : NoiseModel, optional
        The simulated sensor; its non-white share of the first differences is removed before
        the ratio is measured (without it the differences are taken as all white noise).
    """
    z = view.z.get("hf")
    if z is None or not (np.abs(z) > view.thresholds["hf"]).any():
        return None
    fit = _drift_fit(view)
    if fit is None:
        return None
    chi2, beta, t_start, t_end = fit
    if abs(beta) < 1e-12:
        return None
    w = int(view.t_s.size)
    length = round(view.window_s * fs)
    plan = TimePlan(n_windows=w, length=length, m=max(2, length // 16))
    other = 0.0
    if model is not None:
        dt = 1.0 / fs
        total = 2.0 * float(np.asarray(model.avar(np.array([dt]), dt))[0])
        white = sum(2.0 * fs * float(t.N) ** 2 for t in model.terms if t.type == "white")
        other = max(total - white, 0.0)
    v = _window_white_variance(x, plan, fs, other)
    edges = np.arange(w + 1) * view.window_s
    g = ramp_window_mean(edges[:-1], edges[1:], t_start, t_end)
    design = np.stack([np.ones(w), g], axis=1)
    (a, b), *_ = np.linalg.lstsq(design, v, rcond=None)
    if a <= 0 or a + b <= 0:
        return None
    return DriftShape(
        ratio=float(np.sqrt((a + b) / a)),
        t_start=t_start,
        t_end=t_end,
        chi2=chi2,
        n_windows=w,
    )


def _best_span(d2: NDArray[np.float64], v0: float, step: int) -> tuple[int, int]:
    """``[s, e)`` (multiples of ``step``) maximising the variance-change likelihood ratio.

    ``n (v / v0 - 1 - log(v / v0))`` with ``v`` the mean of ``d2[s:e]``, ``n = e - s``; only
    raised spans (``v > v0``) count.
    """
    edges = np.arange(0, d2.size + 1, step)
    if edges[-1] != d2.size:
        edges = np.append(edges, d2.size)
    cum = np.concatenate([[0.0], np.cumsum(d2)])[edges]
    n = (edges[None, :] - edges[:, None]).astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = (cum[None, :] - cum[:, None]) / (n * v0)
        gain = n * (ratio - 1.0 - np.log(ratio))
    gain[~(ratio > 1.0) | (n <= 0)] = -np.inf
    i, j = np.unravel_index(int(np.argmax(gain)), gain.shape)
    return int(edges[i]), int(edges[j])


def burst_spans(
    x: NDArray[np.float64], fs: float, view: TimeView, raised: NDArray[np.bool_]
) -> list[tuple[int, int]]:
    """Sample spans ``[start, stop)`` of the bursts in the runs of ``raised`` windows.

    Each run of raised windows, widened by one window on either side, holds one burst; its
    ends are where the mean square of the first differences departs most from the quiet
    windows' (module docstring). ``x`` is the analysed record (the time view's windows start at
    its first sample).
    """
    length = round(view.window_s * fs)
    d2 = np.square(np.diff(np.asarray(x, dtype=np.float64)))
    w = min(raised.size, d2.size // length)
    per_window = d2[: w * length].reshape(w, length).mean(axis=1)
    quiet = ~raised[: per_window.size]
    if per_window.size == 0 or not quiet.any():
        return []
    v0 = float(np.median(per_window[quiet]))
    spans: list[tuple[int, int]] = []
    for a, b in runs(raised):
        lo = max(0, (a - 1) * length)
        hi = min(d2.size, (b + 2) * length)
        if hi - lo < 2:
            continue
        step = max(1, min(length // SUBSTEPS, -(-(hi - lo) // SPAN_POSITIONS)))
        s, e = _best_span(d2[lo:hi], v0, step)
        if e > s:
            spans.append((lo + s, lo + e))
    return spans
