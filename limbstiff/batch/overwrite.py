"""Outputs that exist: a run refuses, before it touches anything, to replace complete outputs made
from another input or with other settings unless ``--overwrite`` is given, and with it clears a
trial's marker first, so that an interrupted run leaves the folder reading as incomplete.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Sequence

from ..errors import LimbstiffError
from .runner import BatchJob
from .table import outputs_state

if TYPE_CHECKING:
    from .jobs import JobOptions


def clear_or_refuse(job: BatchJob[JobOptions], marker: str) -> None:
    """Refuse to replace complete outputs without ``--overwrite``; with it, remove ``marker``
    first, so that the folder reads as incomplete until the new outputs are all written."""
    if not (job.at(job.out) / marker).exists():
        return
    if not job.options.overwrite:
        why = "were made from another input or other settings, or lack a file this run writes"
        raise LimbstiffError(f"{job.source}: outputs in {job.out} {why} (use --overwrite to replace them)")
    (job.at(job.out) / marker).unlink()


def refuse_other_outputs(jobs: Sequence[BatchJob[JobOptions]], out: Path, *, marker: str,
                         files: Sequence[str]) -> None:
    """Stop a run, before it touches anything, that would have to replace complete outputs in
    ``out`` without ``--overwrite``: made with other settings (seed, protocol, reference,
    version), from another input, or lacking a file this run writes. Current outputs are kept
    by the run itself (up to date, skipped).

    Raises
    ------
    OutputExists
        One line naming the folder and what to do.
    OutputPathError
        A file stands where a trial's output folder goes (with ``--overwrite`` too).
    """
    from ..files.outputs import OutputExists, OutputPathError

    blocked = [job.name for job in jobs if job.out.exists() and not job.out.is_dir()]
    if blocked:
        raise OutputPathError(f"{out}: cannot write the outputs of {_names(blocked)} (a file is there, not a folder); "
                              "move it or choose another --out")
    if not jobs or jobs[0].options.overwrite:
        return
    stale: dict[str, list[str]] = {}
    for job in jobs:
        stale.setdefault(_outputs_state(job, files=files, marker=marker), []).append(job.name)
    what = "use --overwrite or another --out"
    if "settings" in stale:
        raise OutputExists(f"outputs in {out} were made with other settings: {what}")
    if "input" in stale:
        raise OutputExists(f"outputs in {out} were made from another input ({_names(stale['input'])}): {what}")
    if "files" in stale:
        lacking = [f for f in files if any(not (out / name / f).is_file() for name in stale["files"])]
        raise OutputExists(f"outputs in {out} lack {', '.join(lacking)}, which this run writes "
                           f"({_names(stale['files'])}): {what}")


def _names(names: Sequence[str], shown: int = 3) -> str:
    return ", ".join(names[:shown]) + (f" and {len(names) - shown} more" if len(names) > shown else "")


def _outputs_state(job: BatchJob[JobOptions], *, files: Sequence[str], marker: str) -> str:
    """What the job's outputs are to this run (:func:`~limbstiff.batch.table.outputs_state`);
    an ensemble's input is its files, by :func:`source_sha256`."""
    ensemble = getattr(job.options, "ensemble", ())
    return outputs_state(job.out, source=job.source, run_sha256=job.options.run_sha256, files=files, marker=marker,
                         input_sha256=(lambda: source_sha256(job)) if ensemble else None)


def source_sha256(job: BatchJob) -> str:
    """SHA-256 of the job's input: its file's, or an ensemble's over its files' (in order)."""
    from ..files.atomic import sha256_file
    from ..files.ensemble import ensemble_sha256

    files = getattr(job.options, "ensemble", ())
    if files:
        return ensemble_sha256(sha256_file(job.at(f)) for f in files)
    return sha256_file(job.at(job.source))
