"""The gap test alone: a corrected simulated sensor checked against the same record.

``diagnose --write-corrected`` writes the diagnosed effects into the simulator's config, as far
as the format holds them (a Kalibr file holds a Gauss-Markov bias only as a random walk, ...).
What the file then simulates is checked here against the record the diagnosis was made on:
the same three views and the same combined test as :func:`~allanite.diagnosis.diagnose`,
without the attribution that follows a gap (the correction is judged, not diagnosed anew).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from allanite.diagnosis.analysis import Progress, analyze
from allanite.diagnosis.inputs import as_rate, check_units, make_source
from allanite.variance.checks import resolve_source

__all__ = ["GapTest", "gap_test"]


@dataclass(frozen=True)
class GapTest:
    """The combined gap test of a record against a simulated sensor.

    Attributes
    ----------
    statistic : float
        Gap statistic ``G = max(0, T - T0)`` of the tau view.
    p_value : float
        Combined p-value of the three views (as :attr:`Diagnosis.p_value`).
    significant : bool
        ``p_value < significance``.
    n_samples : int
        Rate samples of the record tested (the whole record).
    """

    statistic: float
    p_value: float
    significant: bool
    n_samples: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "statistic": float(self.statistic),
            "p_value": float(self.p_value),
            "significant": bool(self.significant),
            "n_samples": int(self.n_samples),
        }


def gap_test(
    real: Any,
    model: Any,
    *,
    fs: float | None = None,
    input: str | None = None,
    units: str | None = None,
    n_mc: int = 200,
    significance: float = 0.05,
    seed: int = 0,
    progress: Progress | None = None,
) -> GapTest:
    """Test whether ``real`` (the whole record) differs from the simulated ``model``.

    Parameters are those of :func:`~allanite.diagnosis.diagnose` (a Record brings its own
    ``fs``, ``input`` and unit); give the diagnosis' ``n_mc``, ``significance`` and ``seed``
    so that the corrected sensor is judged as the original was.
    """
    samples, rate, input_kind, units, _ = resolve_source(real, fs, input, units)
    x = as_rate(samples, rate, input_kind, name="real")
    source = make_source(model, rate, x.size, sim_units=None)
    check_units(units, source.units)
    analysis = analyze(
        x, source, n_mc=int(n_mc), seed=seed, alpha=significance, progress=progress,
        stage="re-check replicates",
    )  # fmt: skip
    p = float(analysis.p_value)
    return GapTest(float(analysis.tau.gap), p, bool(p < significance), int(x.size))
