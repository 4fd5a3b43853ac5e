"""From trial files to output folders: the library calls behind ``limbstiff analyze`` and ``identify``.

:func:`analyze_files` discovers the trials, analyses each (in parallel processes when asked),
writes every trial's outputs and the run's ``summary.csv``, and returns the outcomes. The
command line only parses options and calls it.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
from concurrent.futures import Executor
from dataclasses import KW_ONLY, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Sequence

from .discovery import NothingToDo, discover, output_names, writable_folder
from .outcome import BatchReport
from .overwrite import clear_or_refuse, refuse_other_outputs, source_sha256
from .runner import BatchJob, TrialOutcome, cut_short, interrupted, interrupts_deferred, run_jobs, run_one
from .table import FolderTable, TrialRow, mixed_kinds, up_to_date
from ..errors import LimbstiffError
from ..protocol import ENSEMBLE_MARKER, Protocol

if TYPE_CHECKING:
    from ..calibrate import SpringCalibration

OVERVIEW_PDF = "overview.pdf"


@dataclass(frozen=True)
class JobOptions:
    """What every trial of one batch run is analysed and written with (picklable: it travels to
    the workers).

    Parameters
    ----------
    protocol : Protocol
        Resolved settings (file plus overrides).
    seed : int
        Seed of every random draw.
    run_sha256 : str
        The run's fingerprint (:func:`run_fingerprint`), recorded in each trial's JSON output.
    overwrite : bool
        Replace outputs that exist.
    resume : bool
        Keep outputs that are current even with ``overwrite``.
    pdf : bool
        Write ``report.pdf`` per trial.
    reference : SpringCalibration or None
        Reference stiffness curve from ``limbstiff calibrate``.
    ensemble : tuple of Path
        The one-cycle files of the one trial an ensemble run analyses (:func:`analyze_ensemble`),
        in their order; empty for a batch of trial files.
    """

    protocol: Protocol
    seed: int
    _: KW_ONLY
    run_sha256: str = ""
    overwrite: bool = False
    resume: bool = False
    pdf: bool = False
    reference: SpringCalibration | None = None
    ensemble: tuple[Path, ...] = ()


def run_fingerprint(protocol: Protocol, *, seed: int, reference=None) -> str:
    """SHA-256 of everything besides the input that determines a trial's outputs.

    The resolved settings, the seed, the reference curve and limbstiff's version: a trial
    whose ``summary.json`` records this fingerprint and its input's SHA-256 is up to date.
    """
    from .. import __version__
    from ..files.outputs import jsonable

    key = {"settings": jsonable(protocol.to_dict()), "seed": seed, "version": __version__,
           "reference": None if reference is None else jsonable(reference.to_dict())}
    return hashlib.sha256(json.dumps(key, sort_keys=True, default=str).encode("utf-8")).hexdigest()


def read_job_trial(job: BatchJob, protocol: Protocol):
    """The job's trial (an ensemble's files read as one), opened from the client's folder on an
    executor, its source as given."""
    from ..files import read_ensemble, read_trial
    files = getattr(job.options, "ensemble", ())
    if files:
        trial = read_ensemble([job.at(f) for f in files], protocol, name=job.name)
    else:
        trial = read_trial(job.at(job.source), protocol, name=job.name)
    return trial if job.cwd is None else dataclasses.replace(trial, source=str(job.source))


def _analyse_and_write(job: BatchJob[JobOptions]) -> TrialRow:
    """Read, analyse and write one trial (runs in a worker process)."""
    from ..analysis import analyze
    from ..files.outputs import CURVE_CSV, REPORT_PDF, STIFFNESS_CSV, SUMMARY_JSON, write_result

    opts, out = job.options, job.at(job.out)
    files = [STIFFNESS_CSV, SUMMARY_JSON] + ([REPORT_PDF] if opts.pdf else [])
    if opts.resume or not opts.overwrite:
        # current outputs are kept unless --overwrite alone asks to redo them: a re-run of the same
        # command is a no-op, and --resume --overwrite redoes only what changed
        done = up_to_date(out, source_sha256=source_sha256(job), run_sha256=opts.run_sha256, files=files)
        if done is not None:
            return done
    clear_or_refuse(job, SUMMARY_JSON)
    if not opts.pdf and (out / REPORT_PDF).exists():
        (out / REPORT_PDF).unlink()              # a report of an earlier run would not match
    for name in CURVE_CSV.values():              # nor a curve of an earlier run with other cycles
        if (out / name).exists():
            (out / name).unlink()
    trial = read_job_trial(job, opts.protocol)
    reference = None
    if opts.reference is not None:
        calibration = opts.reference
        if calibration.kind is not None and calibration.kind != trial.kind:
            raise LimbstiffError(f"{job.source}: the --reference calibration is {calibration.kind} but the trial "
                                 f"is {trial.kind}; calibrate with pairs of the trial's kind")
        reference = calibration.stiffness(trial.angle)
    result = analyze(trial, opts.protocol, seed=opts.seed, reference=reference)
    if opts.pdf:
        from ..report import write_report
        write_report(result, out / REPORT_PDF)
    files = files + ([CURVE_CSV[result.curve.against]] if result.curve is not None else [])
    return TrialRow.from_summary(write_result(result, out, extra={"output": str(job.out), "files": files,
                                                                  "run_sha256": opts.run_sha256}))


def _run_trial(job: BatchJob[JobOptions], *, work: Callable[[BatchJob[JobOptions]], TrialRow]
               ) -> TrialOutcome[TrialRow]:
    """Run ``work`` on one trial (in a worker): its outcome, ``resumed`` when it kept the outputs."""
    outcome = run_one(job, work)
    return outcome if outcome.row is None else dataclasses.replace(outcome, resumed=outcome.row.resumed)


def _run(paths, work, options: JobOptions, *, out, jobs, executor, progress, marker: str,
         writes: Sequence[str], then=None) -> BatchReport:
    """Discover the trials, run ``work`` on each (one failure never stops the others), and keep
    ``summary.csv`` the folder's table (:class:`~limbstiff.batch.table.FolderTable`).

    A path that matches nothing is a failed row; the output folder, and whether the run may write
    its trials' outputs there (:func:`refuse_other_outputs`), are checked before any trial.
    ``then`` as for :func:`_run_jobs`.
    """
    missing: list[tuple[str, str]] = []
    searched: set[Path] = set()
    files = discover(paths, missing=missing, searched=searched)
    if not files:
        raise NothingToDo("; ".join(why for _, why in missing))
    out = writable_folder(out)
    names, notes = output_names(files)
    jobs_list = [BatchJob(source=f, name=n, out=out / n, options=options, searched=f in searched)
                 for f, n in zip(files, names)]
    return _run_jobs(jobs_list, work, out=out, jobs=jobs, executor=executor, progress=progress, marker=marker,
                     writes=writes, missing=missing, notes=notes, then=then)


def _run_jobs(jobs_list: list[BatchJob[JobOptions]], work, *, out: Path, jobs, executor, progress, marker: str,
              writes: Sequence[str], missing: Sequence[tuple[str, str]] = (), notes: Sequence[str] = (),
              then: Callable[[Path, list[TrialOutcome]], tuple[str, ...]] | None = None) -> BatchReport:
    """:func:`_run` from its jobs on: the refusal, the runs and ``summary.csv``.

    The table is rebuilt from the folder and written when the run begins, after every finished
    trial, and once more on the way out (after Ctrl-C too: trials that finished meanwhile are
    read from their folders), so that after an interruption or a kill it lists the complete
    trial folders and no other. ``then(out, rows)``, run under the table's lock after its last
    writing (not after an interruption), writes what else shows the table (``overview.pdf``) and
    returns notes.
    """
    refuse_other_outputs(jobs_list, out, marker=marker, files=writes)
    if executor is not None:
        from .cluster import check_shared_folder
        check_shared_folder(executor, out)      # workers write there: before any trial runs
    lost = [TrialOutcome(Path(text).stem, text, "failed", why) for text, why in missing]
    table = FolderTable(out, marker, [job.name for job in jobs_list], lost)
    finished: dict[str, TrialOutcome] = {}
    table.write(finished)

    def record(outcome, done, total):
        # a file found in a folder that is no trial has no row; a trial Ctrl-C cut short has none
        # either (its folder stays incomplete and is redone next time)
        if outcome.status != "skipped" and not interrupted(outcome):
            finished[outcome.trial] = outcome
            table.write(finished)
        if progress:
            progress(outcome, done, total)

    if executor is None:
        # local workers are forked from this process: what it has imported they inherit, instead of
        # each importing the analysis (scipy, numba's kernels) again (a serial batch imports it at its
        # first trial anyway); a Ctrl-C meanwhile acts after it
        with interrupts_deferred():
            from .. import analysis  # noqa: F401
    try:
        outcomes = run_jobs(jobs_list, functools.partial(_run_trial, work=work),
                            n_jobs=jobs, executor=executor, progress=record)
    except KeyboardInterrupt:
        # Ctrl-C reaches the workers too: the trials they were running show as lost workers, and
        # are cut short, not failed (their folders stay incomplete and are redone next time)
        table.write({name: o for name, o in finished.items() if not cut_short(o)})
        raise
    except BaseException:
        table.write(finished)
        raise
    final, more = table.write(finished, then=None if then is None else functools.partial(then, out))
    mixed = mixed_kinds(final)
    skipped = [o for o in outcomes if o.status == "skipped"]
    notes = [n for n in notes if not any(n.startswith(f"{o.source}: ") for o in skipped)]   # its name is moot
    return BatchReport(outcomes=tuple(o for o in outcomes if o.status != "skipped") + tuple(lost), out=out,
                       notes=tuple(f"{o.error}; skipped" for o in skipped) + tuple(notes) + tuple(more or ()),
                       missing=tuple(why for _, why in missing), warnings=(mixed,) if mixed else ())


def _identify_and_write(job: BatchJob[JobOptions]) -> TrialRow:
    """Read one trial, identify m and b, write posterior.json and draws.csv (worker process)."""
    from ..analysis import identification_summary, identify_trial
    from ..files.atomic import sha256_file
    from ..files.csv_writer import write_csv
    from ..files.outputs import jsonable, write_json

    opts, out = job.options, job.at(job.out)
    if not opts.overwrite:
        done = up_to_date(out, source_sha256=sha256_file(job.at(job.source)), run_sha256=opts.run_sha256,
                          files=list(_identify_writes(opts.protocol)), marker="posterior.json")
        if done is not None:
            return done
    clear_or_refuse(job, "posterior.json")
    trial = read_job_trial(job, opts.protocol)
    ident = identify_trial(trial, opts.protocol, seed=opts.seed)
    out.mkdir(parents=True, exist_ok=True)
    if ident.posterior is not None:
        write_csv(out / "draws.csv", ident.posterior.to_frame())
    summary = identification_summary(trial, ident, ci_level=opts.protocol.ci_level, seed=opts.seed)
    summary = jsonable(dict(summary, output=str(job.out), run_sha256=opts.run_sha256))
    write_json(out / "posterior.json", summary)
    return TrialRow.from_summary(summary)


def identify_files(paths: Sequence[str], *, protocol: Protocol | None = None, out: str | Path = "limbstiff-identify",
                   jobs: int = 1, seed: int = 0, overwrite: bool = False, executor: Executor | None = None,
                   progress: Callable[[TrialOutcome, int, int], None] | None = None) -> BatchReport:
    """Identify inertia and damping of every trial named by ``paths`` (``limbstiff identify``).

    Writes ``OUT/<trial>/posterior.json`` (intervals, noise levels, MCMC diagnostics),
    ``OUT/<trial>/draws.csv`` (posterior draws) and ``OUT/summary.csv``. ``jobs``, ``executor``
    and ``progress`` as for :func:`analyze_files`.
    """
    protocol = protocol or Protocol()
    options = JobOptions(protocol, seed, run_sha256=run_fingerprint(protocol, seed=seed), overwrite=overwrite)
    return _run(paths, _identify_and_write, options, out=out, jobs=jobs, executor=executor, progress=progress,
                marker="posterior.json", writes=_identify_writes(protocol))


def _identify_writes(protocol: Protocol) -> tuple[str, ...]:
    """What ``identify`` writes beside ``posterior.json``: ``draws.csv``, unless m and b are both
    given (no posterior to draw from)."""
    return () if protocol.inertia is not None and protocol.damping is not None else ("draws.csv",)


def analyze_files(paths: Sequence[str], *, protocol: Protocol | None = None, out: str | Path = "limbstiff-out",
                  jobs: int = 1, seed: int = 0, pdf: bool = True, overwrite: bool = False,
                  resume: bool = False, reference=None, sort_by: Sequence[str] = (), executor: Executor | None = None,
                  progress: Callable[[TrialOutcome, int, int], None] | None = None) -> BatchReport:
    """Analyse every trial named by ``paths`` and write the outputs of docs/interface.md section 4.

    Parameters
    ----------
    paths : sequence of str
        Files, folders (searched for the types of :data:`limbstiff.files.read.FOLDER_EXTENSIONS`)
        or globs.
    protocol : Protocol, optional
        Resolved settings (file plus overrides).
    out : str or Path
        Output folder; one sub-folder per trial.
    jobs : int
        Local worker processes (when no ``executor`` is given).
    seed : int
        Seed of every random draw.
    pdf : bool
        Write ``report.pdf`` per trial and ``overview.pdf`` for the batch.
    overwrite : bool
        Replace outputs that already exist.
    resume : bool
        Skip trials whose complete outputs record the same input SHA-256 and run fingerprint
        (:func:`run_fingerprint`); trials left incomplete by an interrupted run are redone.
    reference : SpringCalibration, optional
        Reference stiffness curve from ``limbstiff calibrate``.
    sort_by : sequence of str
        Metadata keys (``subject``, ``condition``…) that order and group ``overview.pdf``.
    executor : concurrent.futures.Executor, optional
        Where the trials run instead of local processes, e.g. a dask cluster's
        (:func:`limbstiff.batch.cluster.dask_executor`); its workers write the outputs, so ``out``
        must be on a file system they share (checked before any trial runs).
    progress : callable, optional
        Called as ``progress(outcome, done, total)`` after each trial.

    Returns
    -------
    BatchReport

    Raises
    ------
    discovery.NothingToDo
        When no trial file is found.
    """
    protocol = protocol or Protocol()
    options = JobOptions(protocol, seed, run_sha256=run_fingerprint(protocol, seed=seed, reference=reference),
                         overwrite=overwrite, resume=resume, pdf=pdf, reference=reference)
    from ..files.outputs import REPORT_PDF, STIFFNESS_CSV, SUMMARY_JSON
    return _run(paths, _analyse_and_write, options, out=out, jobs=jobs, executor=executor, progress=progress,
                marker="summary.json", writes=(STIFFNESS_CSV, SUMMARY_JSON) + ((REPORT_PDF,) if pdf else ()),
                then=functools.partial(_overview, protocol=protocol, sort_by=sort_by) if pdf else None)


def analyze_ensemble(paths: Sequence[str], *, protocol: Protocol | None = None, out: str | Path = "limbstiff-out",
                     seed: int = 0, pdf: bool = True, overwrite: bool = False, resume: bool = False, reference=None,
                     name: str | None = None, executor: Executor | None = None,
                     progress: Callable[[TrialOutcome, int, int], None] | None = None) -> BatchReport:
    """Analyse every trial file named by ``paths`` as one cycle of ONE ensemble
    (``limbstiff analyze --ensemble``): the files read together
    (:func:`~limbstiff.files.ensemble.read_ensemble`), the stiffness by phase of their cycles.

    Writes ``OUT/<name>/`` (``stiffness.csv``, ``summary.json``, ``stiffness_by_phase.csv``,
    ``report.pdf`` when ``pdf``) and ``OUT/summary.csv`` as :func:`analyze_files` does for one
    trial, with the same rules for outputs that exist; ``name`` is the files' folder's name
    unless given. The protocol's ``[cycles]``, if any, is replaced: each file is one cycle.

    Raises
    ------
    discovery.NothingToDo
        When a path matches nothing or no trial file is found.
    TrialError
        Fewer than :data:`~limbstiff.files.ensemble.MIN_FILES` (the ensemble's least number of cycles) files.
    """
    from ..files.ensemble import ensemble_folder, ensemble_order
    from ..files.outputs import REPORT_PDF, STIFFNESS_CSV, SUMMARY_JSON
    from ..protocol import Cycles

    protocol = protocol or Protocol()
    warnings = ("the protocol's [cycles] is not used: with --ensemble each file is one cycle",) \
        if protocol.cycles is not None else ()
    files = ensemble_order(discover(paths))
    folder = ensemble_folder(files)
    protocol = dataclasses.replace(protocol, cycles=Cycles(marker=ENSEMBLE_MARKER))
    options = JobOptions(protocol, seed, run_sha256=run_fingerprint(protocol, seed=seed, reference=reference),
                         overwrite=overwrite, resume=resume, pdf=pdf, reference=reference, ensemble=tuple(files))
    out = writable_folder(out)
    name = name or folder.name
    job = BatchJob(source=folder, name=name, out=out / name, options=options)
    report = _run_jobs([job], _analyse_and_write, out=out, jobs=1, executor=executor, progress=progress,
                       marker=SUMMARY_JSON, writes=(STIFFNESS_CSV, SUMMARY_JSON) + ((REPORT_PDF,) if pdf else ()),
                       then=functools.partial(_overview, protocol=protocol, sort_by=()) if pdf else None)
    return dataclasses.replace(report, warnings=warnings + report.warnings)


def _overview(out: Path, rows: list[TrialOutcome], *, protocol: Protocol, sort_by: Sequence[str]) -> tuple[str, ...]:
    """Write ``overview.pdf`` of the table's ``rows``; a failure here is a note, never a lost batch."""
    from ..report import write_batch_overview

    try:
        write_batch_overview(_overview_rows(out, rows), out / OVERVIEW_PDF, sort_by=list(sort_by) or None,
                             ci_level=protocol.ci_level)
    except Exception as exc:  # noqa: BLE001 - the trials are done; say why the overview is missing
        return (" ".join(f"{out / OVERVIEW_PDF} not written ({type(exc).__name__}: {exc})".split()),)
    return ()


def _overview_rows(out: Path, rows: list[TrialOutcome]) -> list[dict]:
    """The overview's rows (:func:`~limbstiff.report.write_batch_overview`): each done trial's
    ``summary.json`` as written, a failed trial's reason."""
    from ..files.outputs import SUMMARY_JSON
    return [json.loads((out / o.trial / SUMMARY_JSON).read_text(encoding="utf-8")) if o.status == "ok"
            else {"trial": o.trial, "status": "failed", "error": o.error} for o in rows]


def check_reference(path: str | Path):
    """Read a calibration JSON written by ``limbstiff calibrate``."""
    import json

    from ..calibrate import SpringCalibration
    try:
        return SpringCalibration.from_dict(json.loads(Path(path).read_text(encoding="utf-8")))
    except FileNotFoundError:
        raise LimbstiffError(f"{path}: calibration file not found") from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise LimbstiffError(f"{path}: not a limbstiff calibration file ({exc})") from None
