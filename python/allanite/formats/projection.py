"""Project a noise model onto the terms a config format can hold, never silently.

A format holds a few term types (Kalibr: white and rate random walk; the PX4 plugin: white,
one Gauss-Markov bias and a turn-on bias; ...). Terms it cannot hold are either

- *projected*: slow stationary terms (flicker, Gauss-Markov, rate random walk, ramp) are
  replaced by the format's slow term (a Gauss-Markov bias where the format has one, else a
  rate random walk) whose parameters make the model's Allan deviation closest to the full
  model's over a stated tau range (least squares in log AVAR on 40 log-spaced taus); the
  largest ADEV error over that range is reported; or
- *dropped*: fast or deterministic terms (quantization, sinusoids, low-pass, spikes, steps,
  warm-up) are listed with their largest share of the ADEV over the range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from allanite.formats.base import ImuConfig, merge_same, sensor_model
from allanite.model import NoiseModel
from allanite.terms import GaussMarkov, RateRandomWalk, Term

__all__ = ["SLOW_TYPES", "Projection", "default_tau_range", "project", "project_config"]

#: term types a slow slot (Gauss-Markov or random walk) can stand in for
SLOW_TYPES = frozenset({"flicker", "markov", "rrw", "ramp"})


@dataclass(frozen=True)
class Projection:
    """The model the format holds and what was changed to get there."""

    model: NoiseModel
    dropped: list[str] = field(default_factory=list)
    projections: list[str] = field(default_factory=list)


def default_tau_range(dt: float) -> tuple[float, float]:
    """The tau range used when none is given: 10 samples to one hour."""
    return (10.0 * dt, max(3600.0, 100.0 * dt))


def _describe(term: Term) -> str:
    values = ", ".join(f"{k}={v:.4g}" for k, v in term.to_dict().items() if k != "type")
    return f"{term.type} ({values})"


def _taus(tau_range: tuple[float, float], dt: float) -> np.ndarray:
    lo, hi = tau_range
    if not (lo > 0 and hi > lo):
        raise ValueError(f"tau range must be 0 < lo < hi seconds, got {tau_range!r}")
    m = np.unique(np.maximum(1, np.round(np.geomspace(lo, hi, 40) / dt)))
    return m * dt


def _fit_slot(
    slot: str, fixed: list[Term], target: np.ndarray, taus: np.ndarray, dt: float
) -> Term:
    base = np.zeros_like(target)
    for t in fixed:
        base = base + t.avar(taus, dt)
    log_target = np.log(target)

    def build(theta: np.ndarray) -> Term:
        if slot == "markov":
            return GaussMarkov(sigma=float(np.exp(theta[0])), tau_c=float(np.exp(theta[1])))
        return RateRandomWalk(K=float(np.exp(theta[0])))

    def cost(theta: np.ndarray) -> float:
        model = base + build(theta).avar(taus, dt)
        return float(np.sum((np.log(np.maximum(model, 1e-300)) - log_target) ** 2))

    excess = np.maximum(target - base, target * 1e-6)
    if slot == "rrw":
        starts = [np.array([0.5 * math.log(3.0 * float(np.max(excess / taus)))])]
    else:
        starts = []
        for tc in np.geomspace(taus[0], taus[-1], 12):
            sigma = math.sqrt(float(np.max(excess))) / 0.617
            starts.append(np.array([math.log(sigma), math.log(tc)]))
    best = min(starts, key=cost)
    result = optimize.minimize(cost, best, method="Nelder-Mead", options={"xatol": 1e-6})
    return build(result.x if result.fun <= cost(best) else best)


def project(
    model: NoiseModel,
    holds: frozenset[str] | set[str],
    *,
    dt: float,
    tau_range: tuple[float, float] | None = None,
    sensor: str = "gyro",
) -> Projection:
    """Return the part of ``model`` a format can hold, projecting or dropping the rest.

    Parameters
    ----------
    model : NoiseModel
        The model (in SI units).
    holds : set of str
        Term types the format holds, at most one of each (``"white"``, ``"markov"``,
        ``"rrw"``, ``"flicker"``, ``"turn_on_bias"``, ``"quantization"``).
    dt : float
        Sample period in seconds the Allan variances are evaluated at.
    tau_range : (float, float), optional
        Averaging times the projection matches (default :func:`default_tau_range`).
    sensor : str
        ``"gyro"`` or ``"accel"``, for the messages.
    """
    model = merge_same(model)
    taus = _taus(tau_range or default_tau_range(dt), dt)
    rng = f"{taus[0]:.3g}-{taus[-1]:.3g} s"
    kept: list[Term] = []
    slow: list[Term] = []
    dropped: list[str] = []
    seen: set[str] = set()
    for term in model.terms:
        if term.type in holds and term.type not in seen:
            kept.append(term)
            seen.add(term.type)
        elif term.type in SLOW_TYPES:
            slow.append(term)
        else:
            share = 0.0
            if term.stationary or term.type in ("warmup", "step"):
                total = model.avar(taus, dt)
                share = float(np.max(np.sqrt(term.avar(taus, dt) / np.maximum(total, 1e-300))))
            dropped.append(
                f"{sensor}: {_describe(term)}, up to {100 * share:.0f} % of the ADEV over {rng}"
            )
    projections: list[str] = []
    slot = "markov" if "markov" in holds else "rrw" if "rrw" in holds else None
    if slow and slot is None:
        dropped.extend(f"{sensor}: {_describe(t)} (no slow term in the format)" for t in slow)
    elif slot is not None and slow:
        replaced = [t for t in kept if t.type == slot]
        fixed = [t for t in kept if t.type != slot and t.stationary]
        target = sensor_model([*fixed, *replaced, *slow], sensor).avar(taus, dt)
        new = _fit_slot(slot, fixed, target, taus, dt)
        kept = [t for t in kept if t.type != slot] + [new]
        proj = sensor_model(kept, sensor)
        err = np.sqrt(proj.avar(taus, dt) / target) - 1.0
        worst = float(np.max(np.abs(err)))
        sources = ", ".join(_describe(t) for t in [*replaced, *slow])
        projections.append(
            f"{sensor}: {sources} -> {_describe(new)} matching the Allan deviation over "
            f"{rng} (largest ADEV error {100 * worst:.1f} %)"
        )
    return Projection(sensor_model(kept, sensor), dropped, projections)


def project_config(
    config: ImuConfig,
    holds: frozenset[str] | set[str],
    *,
    rate: float | None,
    tau_range: tuple[float, float] | None = None,
) -> tuple[dict[str, NoiseModel], list[str], list[str]]:
    """Project both sensors of ``config`` onto ``holds``: ``(models, dropped, projections)``.

    Without a rate the Allan variances of a projection are evaluated at 100 Hz (said in the
    projection's text).
    """
    dt = 1.0 / rate if rate else 0.01
    models: dict[str, NoiseModel] = {}
    dropped: list[str] = []
    projections: list[str] = []
    for sensor in ("gyro", "accel"):
        model = getattr(config, sensor)
        if model is None:
            continue
        result = project(model, holds, dt=dt, tau_range=tau_range, sensor=sensor)
        models[sensor] = result.model
        dropped.extend(result.dropped)
        note = "" if rate else " (evaluated at 100 Hz: no update rate given)"
        projections.extend(p + note for p in result.projections)
    return models, dropped, projections
