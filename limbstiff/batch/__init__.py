"""Batches of trials: from files and folders to one output folder per trial and the run's table.

| module | job |
|---|---|
| ``discovery.py`` | which files a batch analyses, and each one's output folder name |
| ``runner.py`` | running the trials (serially or in processes), one failure never stopping the others |
| ``table.py`` | ``summary.csv`` (rebuilt from the trial folders, under a lock); whether outputs are current |
| ``overwrite.py`` | outputs that exist: refused without ``--overwrite``, cleared with it |
| ``jobs.py`` | :func:`analyze_files` and :func:`identify_files`: read, analyse, write, per trial |
| ``outcome.py`` | :class:`BatchReport`, what a run returns (``to_dict``, ``to_frame``, ``plot``, ``report``) |
"""

from __future__ import annotations

from .discovery import NothingToDo, discover
from .jobs import JobOptions, analyze_files, check_reference, identify_files, run_fingerprint
from .outcome import BatchReport
from .runner import TrialOutcome
from .table import TrialRow

__all__ = ["analyze_files", "identify_files", "BatchReport", "JobOptions", "TrialOutcome", "TrialRow", "NothingToDo",
           "discover", "check_reference", "run_fingerprint"]
