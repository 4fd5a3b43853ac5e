"""From trial files to output folders: the library call behind ``limbstiff analyze``.

:func:`analyze_files` discovers the trials, analyses each (in parallel processes when asked),
writes every trial's outputs and the run's ``summary.csv``, and returns the outcomes. The
command line only parses options and calls it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from . import batch
from .errors import LimbstiffError
from .protocol import Protocol


@dataclass(frozen=True)
class BatchReport:
    """Outcome of a batch run.

    Parameters
    ----------
    outcomes : tuple of batch.TrialOutcome
        One per trial, in input order.
    out : Path
        Output folder.
    notes : tuple of str
        Run-level remarks (stem collisions…).
    """

    outcomes: tuple
    out: Path
    notes: tuple[str, ...] = ()

    @property
    def n_failed(self) -> int:
        return sum(o.status != "ok" for o in self.outcomes)

    @property
    def exit_status(self) -> int:
        """0 when every trial is done, 1 when some failed (INTERFACE.md section 2)."""
        return 1 if self.n_failed else 0


def _analyse_and_write(job: batch.BatchJob) -> dict:
    """Read, analyse and write one trial (runs in a worker process)."""
    from .analysis import analyze
    from .io import read_trial
    from .io.outputs import REPORT_PDF, write_result

    opts = job.options
    protocol: Protocol = opts["protocol"]
    if batch.outputs_exist(job.out) and not opts["overwrite"]:
        raise LimbstiffError(f"{job.source}: outputs already exist in {job.out} (use --overwrite)")
    trial = read_trial(job.source, protocol, name=job.name)
    reference = None
    if opts.get("reference") is not None:
        reference = opts["reference"].stiffness(trial.angle)
    result = analyze(trial, protocol, seed=opts["seed"], reference=reference)
    files = ["stiffness.csv", "summary.json"]
    if opts["pdf"]:
        from .report import write_report
        write_report(result, job.out / REPORT_PDF)
        files.append(REPORT_PDF)
    return write_result(result, job.out, extra={"output": str(job.out), "files": files})


def _run(paths, work, options, *, out, jobs, progress) -> BatchReport:
    """Discover the trials, run ``work`` on each (one failure never stops the others), write
    ``summary.csv``."""
    files = batch.discover(paths)
    names, notes = batch.output_names(files)
    out = Path(out)
    jobs_list = [batch.BatchJob(source=f, name=n, out=out / n, options=options) for f, n in zip(files, names)]
    outcomes = batch.run_jobs(jobs_list, functools.partial(batch.run_one, analyse_and_write=work),
                              n_jobs=jobs, progress=progress)
    out.mkdir(parents=True, exist_ok=True)
    batch.write_summary_csv(out / "summary.csv", outcomes)
    return BatchReport(outcomes=tuple(outcomes), out=out, notes=tuple(notes))


def _identify_and_write(job: batch.BatchJob) -> dict:
    """Read one trial, identify m and b, write posterior.json and draws.csv (worker process)."""
    from .analysis import identify_trial
    from .io import read_trial
    from .io.atomic import atomic_write_text
    from .io.outputs import write_json
    from .result import _jsonable

    opts = job.options
    if (job.out / "posterior.json").exists() and not opts["overwrite"]:
        raise LimbstiffError(f"{job.source}: outputs already exist in {job.out} (use --overwrite)")
    trial = read_trial(job.source, opts["protocol"], name=job.name)
    out = identify_trial(trial, opts["protocol"], seed=opts["seed"])
    job.out.mkdir(parents=True, exist_ok=True)
    if out["posterior"] is not None:
        atomic_write_text(job.out / "draws.csv", out["posterior"].to_frame().to_csv(index=False, float_format="%.10g"))
    summary = _jsonable(dict(out["summary"], output=str(job.out)))
    write_json(job.out / "posterior.json", summary)
    return summary


def identify_files(paths: Sequence[str], *, protocol: Protocol | None = None, out: str | Path = "limbstiff-identify",
                   jobs: int = 1, seed: int = 0, overwrite: bool = False,
                   progress: Callable[[batch.TrialOutcome, int, int], None] | None = None) -> BatchReport:
    """Identify inertia and damping of every trial named by ``paths`` (``limbstiff identify``).

    Writes ``OUT/<trial>/posterior.json`` (intervals, noise levels, MCMC diagnostics),
    ``OUT/<trial>/draws.csv`` (posterior draws) and ``OUT/summary.csv``.
    """
    options = {"protocol": protocol or Protocol(), "seed": seed, "overwrite": overwrite}
    return _run(paths, _identify_and_write, options, out=out, jobs=jobs, progress=progress)


def analyze_files(paths: Sequence[str], *, protocol: Protocol | None = None, out: str | Path = "limbstiff-out",
                  jobs: int = 1, seed: int = 0, pdf: bool = True, overwrite: bool = False,
                  reference=None,
                  progress: Callable[[batch.TrialOutcome, int, int], None] | None = None) -> BatchReport:
    """Analyse every trial named by ``paths`` and write the outputs of INTERFACE.md section 4.

    Parameters
    ----------
    paths : sequence of str
        Files, folders (searched for ``*.csv``) or globs.
    protocol : Protocol, optional
        Resolved settings (file plus overrides).
    out : str or Path
        Output folder; one sub-folder per trial.
    jobs : int
        Worker processes.
    seed : int
        Seed of every random draw.
    pdf : bool
        Write ``report.pdf`` per trial.
    overwrite : bool
        Replace outputs that already exist.
    reference : SpringCalibration, optional
        Reference stiffness curve from ``limbstiff calibrate``.
    progress : callable, optional
        Called as ``progress(outcome, done, total)`` after each trial.

    Returns
    -------
    BatchReport

    Raises
    ------
    batch.NothingToDo
        When no trial file is found.
    """
    options = {"protocol": protocol or Protocol(), "seed": seed, "pdf": pdf, "overwrite": overwrite,
               "reference": reference}
    return _run(paths, _analyse_and_write, options, out=out, jobs=jobs, progress=progress)


def check_reference(path: str | Path):
    """Read a calibration JSON written by ``limbstiff calibrate``."""
    import json

    from .calibrate import SpringCalibration
    try:
        return SpringCalibration.from_dict(json.loads(Path(path).read_text(encoding="utf-8")))
    except FileNotFoundError:
        raise LimbstiffError(f"{path}: calibration file not found") from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise LimbstiffError(f"{path}: not a limbstiff calibration file ({exc})") from None
