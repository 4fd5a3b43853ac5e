"""Trial files in, ``diagnosis.json`` and ``diagnosis.pdf`` out: :func:`diagnose_files`, the library
call behind ``limbstiff diagnose``. The trials are read and analysed by the batch's runner (in
processes or on a cluster's executor); the diagnosis itself is :func:`.run.diagnose`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from ..analysis import analyze
from ..errors import LimbstiffError
from ..protocol import Protocol
from ..result import StiffnessResult
from ..trial import Trial
from .result import Diagnosis
from .run import diagnose


@dataclass(frozen=True)
class DiagnoseReport:
    """Outcome of :func:`diagnose_files`.

    Parameters
    ----------
    diagnosis : Diagnosis or None
        None when no trial could be diagnosed.
    out : Path
    failed : tuple of str
        One line per trial that could not be read or analysed.
    files : tuple of str
        Files written.
    """

    diagnosis: Diagnosis | None
    out: Path
    failed: tuple = ()
    files: tuple = ()

    @property
    def exit_status(self) -> int:
        """0 when every trial is done, 1 when some (or all) failed (docs/interface.md section 2)."""
        return 1 if self.failed or self.diagnosis is None else 0


@dataclass(frozen=True)
class AnalysedTrial:
    """One trial read and analysed in a worker, returned to the process that diagnoses."""

    trial: Trial
    result: StiffnessResult


def _read_and_analyze(job) -> AnalysedTrial:
    """Read and analyse one trial file (a :class:`~limbstiff.batch.runner.BatchJob` whose options
    are a :class:`~limbstiff.batch.jobs.JobOptions`: its protocol and seed; nothing is written)."""
    from ..batch.jobs import read_job_trial
    trial = read_job_trial(job, job.options.protocol)
    return AnalysedTrial(trial, analyze(trial, job.options.protocol, seed=job.options.seed))


def diagnose_files(paths: Sequence[str], *, protocol: Protocol | None = None, out: str | Path = "limbstiff-diagnose",
                   seed: int = 0, inertia: float | None = None, damping: float | None = None, jobs: int = 1,
                   executor=None, progress=None, pdf: bool = True) -> DiagnoseReport:
    """Read the trials named by ``paths``, diagnose them together, write the outputs.

    Writes ``OUT/diagnosis.json`` and, with ``pdf``, ``OUT/diagnosis.pdf`` (docs/interface.md section
    5), atomically; without it, a ``diagnosis.pdf`` of an earlier run is removed (it would not match).
    A trial that cannot be read or analysed is left out with a one-line reason (``failed``);
    the others are still diagnosed. The trials are read and analysed in ``jobs`` processes (or on
    ``executor``, e.g. a dask cluster's: each trial and its analysis return to this process, which
    writes the diagnosis) by the batch's runner (:func:`limbstiff.batch.runner.run_jobs`);
    ``progress(outcome, done, total)`` is called after each.

    Raises
    ------
    batch.NothingToDo
        When no trial file is found (a path that matches nothing, among others, is a failed
        trial).
    batch.discovery.OutputFolderError
        When ``out`` cannot be written (checked before any trial runs).
    """
    from ..batch.discovery import NothingToDo, discover, output_names, writable_folder
    from ..batch.jobs import JobOptions
    from ..batch.runner import BatchJob, run_jobs, run_one
    from ..files.outputs import write_json

    protocol = (protocol or Protocol()).override(inertia=inertia, damping=damping, effects=())   # as diagnose's
    missing: list[tuple[str, str]] = []
    files = discover(paths, missing=missing)
    if not files:
        raise NothingToDo("; ".join(why for _, why in missing))
    out = writable_folder(out)                  # before any trial is read
    names, _ = output_names(files)
    work = [BatchJob(source=f, name=n, out=Path(out), options=JobOptions(protocol, seed))
            for f, n in zip(files, names)]
    outcomes = run_jobs(work, functools.partial(run_one, analyse_and_write=_read_and_analyze), n_jobs=jobs,
                        executor=executor, progress=progress)
    done = [o.row for o in outcomes if o.status == "ok"]
    trials, results = [r.trial for r in done], [r.result for r in done]
    failed = [o.error for o in outcomes if o.status != "ok"] + [why for _, why in missing]
    if not trials:
        return DiagnoseReport(None, out, tuple(failed))
    try:
        diag = diagnose(trials, protocol, seed=seed, results=results)
    except LimbstiffError as exc:
        return DiagnoseReport(None, out, tuple(failed) + (" ".join(str(exc).split()),))
    out.mkdir(parents=True, exist_ok=True)
    data = diag.to_dict()
    data["failed"] = list(failed)
    write_json(out / "diagnosis.json", data)
    if pdf:
        diag.write_pdf(out / "diagnosis.pdf")
    elif (out / "diagnosis.pdf").exists():
        (out / "diagnosis.pdf").unlink()
    written = (str(out / "diagnosis.json"),) + ((str(out / "diagnosis.pdf"),) if pdf else ())
    return DiagnoseReport(diag, out, tuple(failed), written)
