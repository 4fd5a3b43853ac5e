"""PDF reports: the only package that imports matplotlib, and only when a report is made.

``trial`` writes the per-trial stiffness report. Every module here uses the non-interactive
Agg backend and writes its file atomically.
"""

from __future__ import annotations

from .trial import write_report

__all__ = ["write_report"]
