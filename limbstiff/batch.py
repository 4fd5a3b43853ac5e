"""Batch runs of ``limbstiff analyze``: discovery, one trial at a time or in parallel, summary.

One failed trial never stops the others: each trial's error becomes a row of
``OUT/summary.csv`` with status ``failed``. Standard library (and the package) only.
"""

from __future__ import annotations

import csv
import glob
import io as _io
import json
import os
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Sequence

from .errors import LimbstiffError
from .io.atomic import atomic_write_text
from .io.outputs import SUMMARY_JSON

SUMMARY_COLUMNS = ("trial", "status", "error", "source", "variant", "stiffness_median", "stiffness_lo",
                   "stiffness_hi", "inertia_median", "damping_median", "observable_fraction", "resumed",
                   "output")
#: What folders are searched for. ``.txt`` is read when named, but not searched for: a data
#: folder's README.txt or notes would otherwise become failed trials.
FOLDER_EXTENSIONS = (".csv", ".tsv", ".mat")
#: Prefix of the ``summary.csv`` columns that carry each trial's metadata (``# key: value`` lines).
METADATA_PREFIX = "meta."


class NothingToDo(LimbstiffError):
    """No trial file was found in the paths given."""


def discover(paths: Iterable[str | os.PathLike], *, extensions: tuple[str, ...] = FOLDER_EXTENSIONS) -> list[Path]:
    """Trial files named by ``paths``: files, folders (searched recursively) or globs.

    Folders are searched for files whose extension is in ``extensions`` (case-insensitive);
    files named explicitly or matched by a glob are taken whatever their extension (the reader
    says if it cannot read one).

    Raises
    ------
    NothingToDo
        When a path matches nothing, or nothing at all is found.
    """
    found: list[Path] = []
    for raw in paths:
        text = str(raw)
        p = Path(text)
        if p.is_dir():
            found += sorted(q for q in p.rglob("*") if q.is_file() and q.suffix.lower() in extensions
                            and not q.name.startswith("."))
        elif p.is_file():
            found.append(p)
        elif glob.has_magic(text):
            matches = sorted(Path(q) for q in glob.glob(text, recursive=True) if Path(q).is_file())
            if not matches:
                raise NothingToDo(f"{text}: no file matches this pattern")
            found += matches
        else:
            raise NothingToDo(f"{text}: no such file or folder")
    unique = list(dict.fromkeys(q.resolve() for q in found))
    if not unique:
        raise NothingToDo("no trial files found (folders are searched for "
                          + ", ".join(f"*{e}" for e in extensions) + ")")
    return unique


def output_names(files: Sequence[Path]) -> tuple[list[str], list[str]]:
    """One output folder name per file: its stem, made unique when stems collide.

    Returns
    -------
    names : list of str
    notes : list of str
        One line per collision, saying which file went where.
    """
    names, notes, used = [], [], set()
    for f in files:
        name, k = f.stem, 2
        while name in used:
            name, k = f"{f.stem}-{k}", k + 1
        if name != f.stem:
            notes.append(f"{f}: another trial is also named '{f.stem}'; its outputs are in '{name}/'")
        used.add(name)
        names.append(name)
    return names, notes


@dataclass(frozen=True)
class TrialOutcome:
    """What happened to one trial of a batch (one row of ``summary.csv``)."""

    trial: str
    source: str
    status: str
    error: str = ""
    row: dict = field(default_factory=dict)
    resumed: bool = False


@dataclass(frozen=True)
class BatchJob:
    """Everything a worker needs to analyse one trial (picklable)."""

    source: Path
    name: str
    out: Path
    options: dict


def run_one(job: BatchJob, analyse_and_write: Callable[[BatchJob], dict]) -> TrialOutcome:
    """Run one trial, turning any failure into a ``failed`` outcome with a one-line reason."""
    try:
        summary = analyse_and_write(job)
    except LimbstiffError as exc:
        return TrialOutcome(job.name, str(job.source), "failed", _one_line(str(exc)))
    except MemoryError:
        return TrialOutcome(job.name, str(job.source), "failed", f"{job.source}: out of memory")
    except Exception as exc:  # noqa: BLE001 - a batch must survive any one trial
        return TrialOutcome(job.name, str(job.source), "failed",
                            _one_line(f"{job.source}: internal error ({type(exc).__name__}: {exc})"))
    resumed = bool(summary.pop("resumed", False))
    return TrialOutcome(job.name, str(job.source), "ok", "", summary, resumed)


def _one_line(text: str) -> str:
    return " ".join(text.split())


def run_jobs(jobs: Sequence[BatchJob], worker: Callable[[BatchJob], TrialOutcome], *, n_jobs: int = 1,
             progress: Callable[[TrialOutcome, int, int], None] | None = None) -> list[TrialOutcome]:
    """Run ``worker`` on every job, serially or in ``n_jobs`` processes, in input order."""
    outcomes: list[TrialOutcome | None] = [None] * len(jobs)
    if n_jobs <= 1 or len(jobs) <= 1:
        for i, job in enumerate(jobs):
            outcomes[i] = worker(job)
            if progress:
                progress(outcomes[i], i + 1, len(jobs))
    else:
        pool = ProcessPoolExecutor(max_workers=n_jobs)
        try:
            futures = {pool.submit(worker, job): i for i, job in enumerate(jobs)}
            for done, fut in enumerate(as_completed(futures), start=1):
                outcomes[futures[fut]] = fut.result()
                if progress:
                    progress(outcomes[futures[fut]], done, len(jobs))
        finally:
            # on Ctrl-C, trials not yet started are dropped; finished ones are complete on disk
            pool.shutdown(wait=True, cancel_futures=True)
    return [o for o in outcomes if o is not None]


def summary_row(outcome: TrialOutcome) -> dict:
    """The ``summary.csv`` row of one outcome."""
    s = outcome.row
    stiff = s.get("stiffness") or {}
    return {
        "trial": outcome.trial, "status": outcome.status, "error": outcome.error,
        "source": outcome.source, "variant": s.get("variant", ""),
        "stiffness_median": stiff.get("median", ""), "stiffness_lo": stiff.get("lo", ""),
        "stiffness_hi": stiff.get("hi", ""),
        "inertia_median": (s.get("inertia") or {}).get("median", ""),
        "damping_median": (s.get("damping") or {}).get("median", ""),
        "observable_fraction": s.get("observable_fraction", ""),
        "resumed": int(outcome.resumed) if outcome.status == "ok" else "",
        "output": s.get("output", ""),
        **{METADATA_PREFIX + str(k): v for k, v in (s.get("metadata") or {}).items()},
    }


def write_summary_csv(path: Path, outcomes: Sequence[TrialOutcome]) -> None:
    """Write ``summary.csv``, one row per trial, atomically.

    The fixed columns (:data:`SUMMARY_COLUMNS`) come first, then one ``meta.<key>`` column per
    metadata key found in any trial (empty where a trial lacks it), so a spreadsheet can sort
    and group the trials by subject, condition….
    """
    rows = [summary_row(o) for o in outcomes]
    meta = sorted({k for r in rows for k in r if k.startswith(METADATA_PREFIX)})
    buf = _io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=[*SUMMARY_COLUMNS, *meta], lineterminator="\n", restval="")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_text(path, buf.getvalue())


def up_to_date(directory: Path, *, source_sha256: str, run_sha256: str, files: Iterable[str]) -> dict | None:
    """The existing summary of a trial whose outputs need not be made again, or None.

    They need not when ``summary.json`` (written last, so present only for a complete trial)
    records the same input SHA-256 and the same run fingerprint (settings, seed, reference,
    version), and every file in ``files`` is there.
    """
    try:
        summary = json.loads((directory / SUMMARY_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(summary, dict):
        return None
    if summary.get("source_sha256") != source_sha256 or summary.get("run_sha256") != run_sha256:
        return None
    if not all((directory / f).is_file() for f in files):
        return None
    return summary
