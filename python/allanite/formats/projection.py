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

from allanite.formats.base import ImuConfig, describe_term, merge_same, sensor_model
from allanite.model import NoiseModel
from allanite.terms import GaussMarkov, RateRandomWalk, Term, White

__all__ = [
    "SLOW_TYPES",
    "Projection",
    "adev_error",
    "default_tau_range",
    "project",
    "project_config",
]

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


#: a projected Gauss-Markov correlation time is at most this many times the longest tau
TAU_C_CAP = 1000.0


def _taus(tau_range: tuple[float, float], dt: float) -> np.ndarray:
    lo, hi = tau_range
    if not (lo > 0 and hi > lo):
        raise ValueError(f"tau range must be 0 < lo < hi seconds, got {tau_range!r}")
    m = np.unique(np.maximum(1, np.round(np.geomspace(lo, hi, 40) / dt)))
    return m * dt


def _fit_slot(
    slot: str,
    fixed: list[Term],
    white: Term | None,
    target: np.ndarray,
    taus: np.ndarray,
    dt: float,
) -> list[Term]:
    """Fit the slot term (and ``white`` when given) to ``target``; return the fitted terms."""
    base = np.zeros_like(target)
    for t in fixed:
        base = base + t.avar(taus, dt)
    log_target = np.log(target)
    n_slot = 2 if slot == "markov" else 1
    # beyond TAU_C_CAP x the longest tau a Gauss-Markov bias is a random walk over the range
    # (ADEV within ~0.1 %); an unbounded fit drifted to tau_c ~ 1e17 s, where a simulator's
    # phi = exp(-dt/tau_c) rounds to 1 in double precision and the bias never moves
    longest = TAU_C_CAP * float(taus[-1])

    def build(theta: np.ndarray) -> list[Term]:
        if slot == "markov":
            tau_c = min(float(np.exp(theta[1])), longest)
            out: list[Term] = [GaussMarkov(sigma=float(np.exp(theta[0])), tau_c=tau_c)]
        else:
            out = [RateRandomWalk(K=float(np.exp(theta[0])))]
        if white is not None:
            out.append(White(N=float(np.exp(theta[n_slot]))))
        return out

    def cost(theta: np.ndarray) -> float:
        model = base.copy()
        for t in build(theta):
            model = model + t.avar(taus, dt)
        return float(np.sum((np.log(np.maximum(model, 1e-300)) - log_target) ** 2))

    excess = np.maximum(target - base, target * 1e-6)
    tail = [math.log(max(float(white.values()["N"]), 1e-300))] if white is not None else []
    if slot == "rrw":
        starts = [np.array([0.5 * math.log(3.0 * float(np.max(excess / taus))), *tail])]
    else:
        starts = []
        for tc in np.geomspace(taus[0], taus[-1], 12):
            sigma = math.sqrt(float(np.max(excess))) / 0.617
            starts.append(np.array([math.log(sigma), math.log(tc), *tail]))
    best = min(starts, key=cost)
    result = optimize.minimize(
        cost, best, method="Nelder-Mead", options={"xatol": 1e-6, "maxiter": 4000}
    )
    return build(result.x if result.fun <= cost(best) else best)


def adev_error(model: NoiseModel, target: np.ndarray, taus: np.ndarray, dt: float) -> float:
    """Largest relative Allan-deviation error of ``model`` against the AVAR ``target``."""
    return float(np.max(np.abs(np.sqrt(model.avar(taus, dt) / target) - 1.0)))


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
    projected_fast: list[str] = []
    for term in model.terms:
        if term.type in holds and term.type not in seen:
            kept.append(term)
            seen.add(term.type)
        elif term.type in SLOW_TYPES:
            slow.append(term)
        elif term.type == "lowpass_white" and "white" in holds and "white" not in seen:
            white = White(N=float(term.values()["N"]))
            kept.append(white)
            seen.add("white")
            projected_fast.append(
                f"{sensor}: {describe_term(term, sensor)} -> {describe_term(white, sensor)}: "
                "the format has no "
                f"sensor filter, so the ADEV below ~{1.0 / term.values()['bandwidth']:.3g} s "
                "differs"
            )
        else:
            share = 0.0
            if term.stationary or term.type in ("warmup", "step"):
                total = model.avar(taus, dt)
                share = float(np.max(np.sqrt(term.avar(taus, dt) / np.maximum(total, 1e-300))))
            dropped.append(
                f"{sensor}: {describe_term(term, sensor)}, up to {100 * share:.0f} % of the ADEV "
                f"over {rng}"
            )
    projections: list[str] = list(projected_fast)
    slot = "markov" if "markov" in holds else "rrw" if "rrw" in holds else None
    if slow and slot is None:
        dropped.extend(
            f"{sensor}: {describe_term(t, sensor)} (no slow term in the format)" for t in slow
        )
    elif slot is not None and slow:
        replaced = [t for t in kept if t.type == slot]
        fixed = [t for t in kept if t.type != slot and t.stationary]
        target = sensor_model([*fixed, *replaced, *slow], sensor).avar(taus, dt)
        others = [t for t in kept if t.type != slot]
        new = _fit_slot(slot, fixed, None, target, taus, dt)
        worst = adev_error(sensor_model([*others, *new], sensor), target, taus, dt)
        whites = [t for t in fixed if t.type == "white"]
        if whites:
            # the white noise free as well: taken only when it halves the largest error
            rest = [t for t in fixed if t.type != "white"]
            joint = _fit_slot(slot, rest, whites[0], target, taus, dt)
            others_joint = [t for t in others if t.type != "white"]
            trial = sensor_model([*others_joint, *joint], sensor)
            worst_joint = adev_error(trial, target, taus, dt)
            if worst_joint < 0.5 * worst:
                replaced, others, new, worst = (
                    [*replaced, whites[0]],
                    others_joint,
                    joint,
                    worst_joint,
                )
        kept = [*others, *new]
        sources = ", ".join(describe_term(t, sensor) for t in [*replaced, *slow])
        result = ", ".join(describe_term(t, sensor) for t in new)
        projections.append(
            f"{sensor}: {sources} -> {result} matching the Allan deviation over "
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
