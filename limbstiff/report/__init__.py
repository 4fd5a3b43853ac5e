"""PDF reports: the only package that draws, and it is imported only when a report is made.

- :mod:`~limbstiff.report.trial`: the per-trial stiffness report (:func:`write_report`,
  :func:`report_figures`);
- :mod:`~limbstiff.report.batch`: the overview of a batch run (:func:`write_batch_overview`,
  :func:`batch_figures`).

Pages are matplotlib figures built without pyplot; files are written atomically.
"""

from __future__ import annotations

from .batch import batch_figures, write_batch_overview
from .trial import report_figures, write_report

__all__ = ["write_report", "report_figures", "write_batch_overview", "batch_figures"]
