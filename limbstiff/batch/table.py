"""The batch's table, ``summary.csv``, and the test of whether a trial's outputs are current.

Standard library only.
"""

from __future__ import annotations

import csv
import json
from io import StringIO
from pathlib import Path
from typing import Iterable, Sequence

from ..files.atomic import atomic_write_text
from ..files.outputs import SUMMARY_JSON
from .runner import TrialOutcome

SUMMARY_COLUMNS = ("trial", "status", "verdict", "error", "source", "variant", "stiffness_median", "stiffness_lo",
                   "stiffness_hi", "inertia_median", "damping_median", "observable_fraction", "resumed",
                   "output", "inertia_lo", "inertia_hi", "damping_lo", "damping_hi", "stiffness_at_mean_torque",
                   "stiffness_at_mean_torque_lo", "stiffness_at_mean_torque_hi", "stiffness_torque_slope",
                   "stiffness_torque_slope_lo", "stiffness_torque_slope_hi")
#: Prefix of the ``summary.csv`` columns that carry each trial's metadata (``# key: value`` lines).
METADATA_PREFIX = "meta."


def summary_row(outcome: TrialOutcome) -> dict:
    """The ``summary.csv`` row of one outcome."""
    s = outcome.row
    stiff = s.get("stiffness") or {}
    return {
        "trial": outcome.trial, "status": outcome.status, "verdict": s.get("verdict") or "", "error": outcome.error,
        "source": outcome.source, "variant": s.get("variant", ""),
        "stiffness_median": stiff.get("median", ""), "stiffness_lo": stiff.get("lo", ""),
        "stiffness_hi": stiff.get("hi", ""),
        "inertia_median": (s.get("inertia") or {}).get("median", ""),
        "damping_median": (s.get("damping") or {}).get("median", ""),
        "observable_fraction": s.get("observable_fraction", ""),
        "resumed": int(outcome.resumed) if outcome.status == "ok" else "",
        "output": s.get("output", ""),
        **_interval_columns(s),
        **{METADATA_PREFIX + str(k): v for k, v in (s.get("metadata") or {}).items()},
    }


def _interval_columns(s: dict) -> dict:
    """The ``_lo``/``_hi`` columns: inertia and damping, the trial-level figures (blank when absent)."""
    out = {}
    for name in ("inertia", "damping"):
        iv = s.get(name) or {}
        out.update({f"{name}_lo": iv.get("lo", ""), f"{name}_hi": iv.get("hi", "")})
    level = s.get("trial_level") or {}
    for name in ("stiffness_at_mean_torque", "stiffness_torque_slope"):
        iv = level.get(name) or {}
        out.update({name: iv.get("median", ""), f"{name}_lo": iv.get("lo", ""), f"{name}_hi": iv.get("hi", "")})
    return out


def write_summary_csv(path: Path, outcomes: Sequence[TrialOutcome]) -> None:
    """Write ``summary.csv``, one row per trial, atomically.

    The fixed columns (:data:`SUMMARY_COLUMNS`) come first, then one ``meta.<key>`` column per
    metadata key found in any trial (empty where a trial lacks it), so a spreadsheet can sort
    and group the trials by subject, condition….
    """
    rows = [summary_row(o) for o in outcomes]
    meta = sorted({k for r in rows for k in r if k.startswith(METADATA_PREFIX)})
    buf = StringIO()
    writer = csv.DictWriter(buf, fieldnames=[*SUMMARY_COLUMNS, *meta], lineterminator="\n", restval="")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_text(path, buf.getvalue())


def up_to_date(directory: Path, *, source_sha256: str, run_sha256: str, files: Iterable[str],
               marker: str = SUMMARY_JSON) -> dict | None:
    """The existing summary of a trial whose outputs need not be made again, or None.

    They need not when ``marker`` (``summary.json`` or ``posterior.json``, written last, so
    present only for a complete trial) records the same input SHA-256 and the same run
    fingerprint (settings, seed, reference, version), and every file in ``files`` is there.
    """
    try:
        summary = json.loads((directory / marker).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(summary, dict):
        return None
    if summary.get("source_sha256") != source_sha256 or summary.get("run_sha256") != run_sha256:
        return None
    if not all((directory / f).is_file() for f in files):
        return None
    return summary


def folder_outcomes(out: Path, marker: str, *, exclude: set[str]) -> list[TrialOutcome]:
    """The rows of trials of earlier runs kept in ``out``: every sub-folder whose ``marker``
    (``summary.json`` or ``posterior.json``, written last) is there and readable, read back from
    it, in name order; those named in ``exclude`` (this run's) are left out. They count as up to
    date (``resumed`` 1): this run did not touch them."""
    rows = []
    for path in sorted(Path(out).glob(f"*/{marker}")):
        name = path.parent.name
        if name in exclude:
            continue
        try:
            summary = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if isinstance(summary, dict):
            rows.append(TrialOutcome(name, str(summary.get("source", "")), "ok", "", summary, resumed=True))
    return rows
