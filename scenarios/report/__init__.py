"""The self-contained HTML report of a results store (``griploop report``).

Modules: :mod:`~scenarios.report.data` gathers and aggregates (no drawing): swept
factors, outcome summary with Wilson intervals, paired controller differences,
faceted outcome grids, loop designs with their stored margins;
:mod:`~scenarios.report.findings` finds the factor that changes the outcome most and
writes the first section;
:mod:`~scenarios.report.figures` draws SVG figures in memory (every text at 9 pt or more),
:mod:`~scenarios.report.svg` writes the inline force-trace charts,
:mod:`~scenarios.report.html` renders the Jinja2 templates of ``templates/``
(autoescaped), and
:mod:`~scenarios.report.build` puts the sections together; the sections themselves are
registered in :mod:`~scenarios.report.sections` (one builder per section, in page order).

:mod:`~scenarios.report.feedback` shows the feedback benchmarks (eggs, slip recovery,
force matching) side by side.

May import: :mod:`scenarios.store`, :mod:`scenarios.schema`, :mod:`scenarios.stats`,
:mod:`scenarios.feedback_summary`, :mod:`controllers` (loop responses; python-control
only to re-analyse loops), matplotlib and Jinja2.
"""

from scenarios.report.build import ReportLimits, ReportResult, build_report
from scenarios.report.data import ReportInputError

__all__ = ["ReportInputError", "ReportLimits", "ReportResult", "build_report"]
