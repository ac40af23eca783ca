r"""Time-domain shape check of the level effects (step, warm-up, ramp) on the window means.

A bias step, a warm-up transient and a rate ramp all explain level jumps; their shapes differ.
The window means ``l_w`` of the real record (record mean removed) with their null spread
``s_w`` are fitted by each shape by weighted least squares and the misfit

.. math:: \chi^2 = \sum_w \left(\frac{l_w - \hat l_w}{s_w}\right)^2

is compared with its expectation ``W - p`` (``W`` windows, ``p`` fitted parameters): the excess
``max(0, chi^2 - (W - p))`` enters the ranking of the two candidates.

* step(s) at the detected change points ``t_c``: ``l_w = sum_c b_c (f_w(t_c) - (T - t_c)/T)``
  with ``f_w`` the fraction of window ``w`` after ``t_c``, plus further steps at window
  boundaries (all of them when no change point was detected: the level starts flat, so a
  step proposed on the jump evidence alone pays for its shape too)
  while each lowers ``chi^2`` by more than 10.8 (``chi2_1`` quantile 0.999): bias
  steps come at random times with random sizes. Each further step has two parameters the
  tau view does not see (its time and size), so it adds ``2 c`` to the misfit, with ``c`` the
  per-parameter penalty of the ranking (a staircase of many steps can mimic any smooth level
  shape, e.g. a warm-up, and must pay for its flexibility);
* warm-up: window means of ``A e^{-t/T_w}`` minus the record mean, ``A`` by least squares and
  ``T_w`` on a logarithmic grid from a quarter window to the record length;
* ramp: a straight line ``R (t_w - T/2)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from allanite.diagnosis.time_view import TimeView

__all__ = ["level_misfit", "ramp_shape", "warmup_shape", "warmup_time_constant"]

#: at most this many bias steps in the shape fit
MAX_STEPS = 8
#: chi-square drop that justifies one more step (chi2_1 quantile 0.999)
STEP_GAIN = 10.83


def _wls(
    design: NDArray[np.float64], level: NDArray[np.float64], sd: NDArray[np.float64]
) -> tuple[float, NDArray[np.float64]]:
    """Weighted least squares of ``level`` on the columns of ``design``: ``(chi^2, coef)``."""
    a = design / sd[:, None]
    b = level / sd
    coef, *_ = np.linalg.lstsq(a, b, rcond=None)
    r = b - a @ coef
    return float(r @ r), np.asarray(coef, dtype=np.float64)


def _wls_chi2(
    design: NDArray[np.float64], level: NDArray[np.float64], sd: NDArray[np.float64]
) -> float:
    return _wls(design, level, sd)[0]


def _level_sd(view: TimeView) -> NDArray[np.float64]:
    """The window means' null spreads, infinite (no weight) where there is none."""
    return np.where(view.level_sd > 0, view.level_sd, np.inf)


def _flat_chi2(view: TimeView, sd: NDArray[np.float64]) -> float:
    """``chi^2`` of the window means against no level shape at all."""
    return float(np.sum((view.level / sd) ** 2))


def _step_column(
    tc: float, t1: NDArray[np.float64], window: float, duration: float
) -> NDArray[np.float64]:
    after = np.clip((t1 - tc) / window, 0.0, 1.0)
    return np.asarray(after - (duration - tc) / duration)


def level_misfit(effect: str, view: TimeView, duration: float, per_param: float = 0.0) -> float:
    """Excess misfit of the level shape of ``effect`` (step, warmup, ramp); 0 otherwise.

    ``per_param`` is the ranking's penalty per parameter (``chi2_1`` quantile ``1 - alpha``);
    it is charged twice for every step beyond the detected change points. The effects that
    explain a changed short-term noise level (``white_drift``, ``bursts``, ``spikes``) pay the
    misfit of their shape on the windows' short-term noise level instead
    (:func:`allanite.diagnosis.noise_level.noise_misfit`).
    """
    if effect in ("white_drift", "bursts", "spikes"):
        from allanite.diagnosis.noise_level import noise_misfit

        return noise_misfit(effect, view, per_param)
    if effect not in ("step", "warmup", "ramp"):
        return 0.0
    sd = _level_sd(view)
    w = view.level.size
    t1 = view.t_s + view.window_s / 2
    if effect == "ramp":
        line = view.t_s - duration / 2
        return max(0.0, _wls_chi2(line[:, None], view.level, sd) - (w - 1))
    if effect == "step":
        # no detected change point: the steps are all "further" ones, from a flat level
        cols = [_step_column(tc, t1, view.window_s, duration) for tc in view.change_points_s]
        stacked = np.stack(cols, axis=1) if cols else None
        chi2 = _wls_chi2(stacked, view.level, sd) if stacked is not None else _flat_chi2(view, sd)
        # bias steps come at random times with random sizes: add further steps at window
        # boundaries while each lowers chi^2 by more than chi2_1(0.999) = 10.8
        while len(cols) < MAX_STEPS:
            trials = [
                _wls_chi2(np.stack([*cols, _step_column(tb, t1, view.window_s, duration)], axis=1),
                          view.level, sd)
                for tb in t1[:-1]
            ]  # fmt: skip
            k = int(np.argmin(trials))
            if chi2 - trials[k] <= STEP_GAIN:
                break
            cols.append(_step_column(float(t1[k]), t1, view.window_s, duration))
            chi2 = trials[k]
        extra_steps = len(cols) - len(view.change_points_s)
        return max(0.0, chi2 - (w - len(cols))) + 2.0 * per_param * extra_steps
    best, _, _ = _warmup_fit(view, duration)
    return max(0.0, best - (w - 2))


def _warmup_fit(view: TimeView, duration: float) -> tuple[float, float, float]:
    """Weighted least-squares warm-up on the window means: ``(chi^2, T_w, A)``."""
    sd = _level_sd(view)
    t0 = view.t_s - view.window_s / 2
    t1 = view.t_s + view.window_s / 2
    best, best_tw, best_a = np.inf, float(view.window_s), 0.0
    for tw in np.geomspace(view.window_s / 4, duration, 48):
        shape = tw * (np.exp(-t0 / tw) - np.exp(-t1 / tw)) / view.window_s
        shape = shape - tw * (1.0 - np.exp(-duration / tw)) / duration
        chi2, coef = _wls(shape[:, None], view.level, sd)
        if chi2 < best:
            best, best_tw, best_a = chi2, float(tw), float(coef[0])
    return float(best), best_tw, best_a


def warmup_time_constant(view: TimeView, duration: float) -> float:
    """Warm-up time constant ``T_w`` that best fits the window means (log grid, 48 points)."""
    return _warmup_fit(view, duration)[1]


def warmup_shape(view: TimeView, duration: float) -> tuple[float, float, float]:
    """The warm-up the window means measure, and how much it explains of them.

    Returns
    -------
    (tau_w, amplitude, gain)
        Time constant ``T_w`` and signed amplitude ``A`` of ``A e^{-t/T_w}`` fitted by
        weighted least squares on the window means (spreads ``view.level_sd``), and the drop
        of ``chi^2`` it brings against no shape (``sum_w (l_w / s_w)^2``): chi-square with two
        degrees of freedom (``A``, ``T_w``) when there is no warm-up.
    """
    best, tw, amp = _warmup_fit(view, duration)
    return tw, amp, _flat_chi2(view, _level_sd(view)) - best


def ramp_shape(view: TimeView, duration: float) -> tuple[float, float]:
    """The ramp the window means measure, and how much it explains of them.

    Returns
    -------
    (slope, gain)
        Signed slope ``R`` of ``R (t_w - T/2)`` fitted by weighted least squares on the window
        means (spreads ``view.level_sd``), and the drop of ``chi^2`` it brings against no shape:
        chi-square with one degree of freedom when there is no ramp.
    """
    sd = _level_sd(view)
    line = view.t_s - duration / 2
    if not np.any(np.isfinite(sd) & (line != 0.0)):
        return 0.0, 0.0
    chi2, coef = _wls(line[:, None], view.level, sd)
    return float(coef[0]), _flat_chi2(view, sd) - chi2
