"""Writing the outputs of ``limbstiff analyze`` (INTERFACE.md section 4), atomically.

Each file is written to a temporary name and renamed, so a reader never sees half a file and
an interrupted run leaves the previous complete file (or none). ``summary.json`` is written
last: its presence marks a trial whose outputs are complete.
"""

from __future__ import annotations

import json
from pathlib import Path

from .atomic import atomic_write_text

STIFFNESS_CSV = "stiffness.csv"
SUMMARY_JSON = "summary.json"
REPORT_PDF = "report.pdf"


def write_json(path: str | Path, data: dict) -> None:
    """Write ``data`` as indented UTF-8 JSON, atomically."""
    atomic_write_text(path, json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n")


def write_result(result, directory: str | Path, *, extra: dict | None = None) -> dict:
    """Write ``stiffness.csv`` and ``summary.json`` of one result into ``directory``.

    Parameters
    ----------
    result : StiffnessResult
    directory : str or Path
        Created if needed.
    extra : dict, optional
        More keys for ``summary.json`` (for example the outputs written alongside).

    Returns
    -------
    dict
        The summary that was written.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    frame = result.to_frame()
    atomic_write_text(directory / STIFFNESS_CSV, frame.to_csv(index=False, float_format="%.10g"))
    summary = result.summary()
    if extra:
        summary.update(extra)
    write_json(directory / SUMMARY_JSON, summary)
    return summary
