"""The subcommands of the ``allanite`` command line: module and one-line summary, defined once.

Kept free of heavy imports: ``allanite --help`` lists the commands from here without importing
their modules.
"""

from __future__ import annotations

__all__ = ["SUBCOMMANDS", "SUMMARIES"]

#: subcommand name -> module under allanite.cli
SUBCOMMANDS: dict[str, str] = {
    "analyze": "allanite.cli.analyze",
    "fit": "allanite.cli.fit",
    "simulate": "allanite.cli.simulate",
    "diagnose": "allanite.cli.diagnose",
    "report": "allanite.cli.report",
    "batch": "allanite.cli.batch",
    "gui": "allanite.cli.gui",
    "model": "allanite.cli.model",
}

#: subcommand name -> the one-line summary in ``allanite --help``
SUMMARIES: dict[str, str] = {
    "analyze": "Allan deviation of a record with confidence intervals",
    "fit": "fit IEEE noise terms to the Allan variance and save the noise model",
    "simulate": "simulate sensor noise from a model JSON",
    "diagnose": "sim-to-real gap: where it lies, which effect causes it, how far it shrinks",
    "report": "self-contained HTML report (plots, coefficients, pass/fail, diagnosis)",
    "batch": "noise coefficients and datasheet pass/fail of many recordings",
    "gui": "desktop GUI: open a file, Allan deviation, fit, coefficients, diagnosis, report",
    "model": "noise models in simulator/estimator formats (convert)",
}
