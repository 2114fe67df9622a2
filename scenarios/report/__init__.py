"""The self-contained HTML report of a results store (``griploop report``).

Modules: :mod:`~scenarios.report.data` gathers and aggregates (no drawing),
:mod:`~scenarios.report.figures` draws PNGs in memory,
:mod:`~scenarios.report.html` assembles escaped HTML, and
:mod:`~scenarios.report.build` puts the sections together.
"""

from scenarios.report.build import ReportResult, build_report
from scenarios.report.data import ReportInputError

__all__ = ["ReportInputError", "ReportResult", "build_report"]
