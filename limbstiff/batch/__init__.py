"""Batches of trials: from files and folders to one output folder per trial and the run's table.

| module | job |
|---|---|
| ``discovery.py`` | which files a batch analyses, and each one's output folder name |
| ``runner.py`` | running the trials (serially or in processes), one failure never stopping the others |
| ``table.py`` | ``summary.csv``, and whether a trial's outputs are current (``--resume``) |
| ``jobs.py`` | :func:`analyze_files` and :func:`identify_files`: read, analyse, write, per trial |
"""

from __future__ import annotations

from .discovery import NothingToDo, discover
from .jobs import BatchReport, JobOptions, analyze_files, check_reference, identify_files, run_fingerprint
from .runner import TrialOutcome
from .table import TrialRow

__all__ = ["analyze_files", "identify_files", "BatchReport", "JobOptions", "TrialOutcome", "TrialRow", "NothingToDo",
           "discover", "check_reference", "run_fingerprint"]
