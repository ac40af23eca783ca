"""The default confidence level of every interval the library reports, defined once.

Intervals are two-sided at :data:`DEFAULT_LEVEL` = 0.95 unless the caller asks for another
level: Allan-deviation error bars (:meth:`allanite.variance.AllanResult.ci`), fitted
coefficients (:meth:`allanite.fit.FitResult.table`), batch and datasheet checks, the report, the
plots and the CLI's ``--level``. 0.95 is the level a reader assumes for an interval whose level
is not stated and the one the fit, batch and datasheet pass/fail checks already used; the
outputs print the level next to the intervals (the report's subtitle and captions, the CLI's
table header, the notebook tables) so a 1-sigma (0.683) interval asked for explicitly is never
mistaken for the default. The JSON columns ``dev_low_68``/``dev_high_68`` of
:meth:`allanite.variance.AllanResult.to_dict` stay the 68.3 % interval their names state.
"""

from __future__ import annotations

__all__ = ["DEFAULT_LEVEL", "ONE_SIGMA", "check_level", "level_tag"]

#: default two-sided confidence level of every interval
DEFAULT_LEVEL = 0.95
#: the two-sided level of +-1 standard deviation of a normal distribution
ONE_SIGMA = 0.683


def check_level(level: float, name: str = "level") -> float:
    """``level`` as a float in (0, 1), or a ValueError naming it and giving an example."""
    try:
        value = float(level)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a number between 0 and 1 (e.g. 0.95), got {level!r}"
        ) from None
    if not 0.0 < value < 1.0:
        raise ValueError(f"{name} must lie between 0 and 1 (e.g. 0.95), got {level!r}")
    return value


def level_tag(level: float) -> str:
    """The column-name tag of an interval at ``level``: ``68`` (1 sigma), ``95``, ``99p9``.

    Names the ``dev_low_TAG``/``dev_high_TAG`` columns of a written table so a file says which
    interval it holds.
    """
    value = check_level(level)
    if value == ONE_SIGMA:
        return "68"
    return f"{100 * value:.4g}".replace(".", "p")
