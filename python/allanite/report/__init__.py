"""Self-contained HTML reports: summary, plots, coefficients, slopes, pass/fail, diagnosis.

>>> report = build_report([DeviceAnalysis(record, result)], datasheet=Datasheet.load("ds.json"))
>>> report.write("report.html")          # one file, figures embedded, no network
"""

from __future__ import annotations

from allanite.datasheet import Check, Datasheet, Limit, check_limits
from allanite.report.build import DeviceAnalysis, Report, build_report
from allanite.report.coefficients import CoefficientRow, coefficient_table, customary_rate
from allanite.slopes import SlopeRow, slope_table

__all__ = [
    "Check",
    "CoefficientRow",
    "Datasheet",
    "DeviceAnalysis",
    "Limit",
    "Report",
    "SlopeRow",
    "build_report",
    "check_limits",
    "coefficient_table",
    "customary_rate",
    "slope_table",
]
