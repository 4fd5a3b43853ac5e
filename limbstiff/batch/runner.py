"""Running the trials of a batch: one at a time or in parallel, one failure never stopping the others.

Each trial's error becomes a ``failed`` outcome with a one-line reason (a row of
``summary.csv``). The runner is generic: a job carries options of any (picklable) type, and an
outcome the row its work returned (:class:`~limbstiff.batch.table.TrialRow` for ``analyze`` and
``identify``). Standard library (and the package) only.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import signal
import threading
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Generic, Iterator, Sequence, TypeVar

from ..errors import LimbstiffError, NotATrial

#: What a trial's work returns (the outcome's row).
RowT = TypeVar("RowT")
#: What every job of a batch is run with.
OptionsT = TypeVar("OptionsT")


@dataclass(frozen=True)
class TrialOutcome(Generic[RowT]):
    """What happened to one trial of a batch (one row of ``summary.csv``).

    Parameters
    ----------
    trial : str
        Its name (the output folder's).
    source : str
        Its file, as given.
    status : {"ok", "failed", "skipped"}
        ``skipped``: a file found in a folder that is no trial (:class:`~limbstiff.errors.NotATrial`).
    error : str
        Why it failed or was skipped, in one line ("" when ok).
    row : RowT or None
        What its work returned (None when it failed).
    resumed : bool
        Its outputs were current and kept, not made again.
    """

    trial: str
    source: str
    status: str
    error: str = ""
    row: RowT | None = None
    resumed: bool = False


@dataclass(frozen=True)
class BatchJob(Generic[OptionsT]):
    """Everything a worker needs to analyse one trial (picklable).

    ``source`` and ``out`` are as the user gave them (and are recorded so); ``options`` what every
    trial of the batch is run with; ``cwd``, set when the job runs on an executor (another
    process, maybe another machine), is the client's working directory, which relative paths
    are opened from (:meth:`at`); ``searched``, that the file was found by searching a folder
    (not named): one that is no trial is skipped, not failed.
    """

    source: Path
    name: str
    out: Path
    options: OptionsT
    cwd: str | None = None
    searched: bool = False

    def at(self, path: Path) -> Path:
        """``path`` as this job opens it: from the client's working directory when relative."""
        path = Path(path)
        return path if self.cwd is None or path.is_absolute() else Path(self.cwd) / path


def run_one(job: BatchJob, analyse_and_write: Callable[[BatchJob], RowT]) -> TrialOutcome[RowT]:
    """Run one trial, turning any failure into a ``failed`` outcome with a one-line reason (a
    file found in a folder that is no trial: ``skipped``)."""
    try:
        row = analyse_and_write(job)
    except NotATrial as exc:
        return TrialOutcome(job.name, str(job.source), "skipped" if job.searched else "failed", _one_line(str(exc)))
    except LimbstiffError as exc:
        return TrialOutcome(job.name, str(job.source), "failed", _one_line(str(exc)))
    except MemoryError:
        return TrialOutcome(job.name, str(job.source), "failed", f"{job.source}: out of memory")
    except Exception as exc:  # noqa: BLE001 - a batch must survive any one trial
        if _raised_by_interrupt(exc):
            return TrialOutcome(job.name, str(job.source), "failed", f"{job.source}: {INTERRUPTED}")
        return TrialOutcome(job.name, str(job.source), "failed",
                            _one_line(f"{job.source}: internal error ({type(exc).__name__}: {exc})"))
    return TrialOutcome(job.name, str(job.source), "ok", "", row)


def _raised_by_interrupt(exc: BaseException) -> bool:
    """Whether ``exc`` was raised while an interrupt (Ctrl-C's SystemExit in a worker, or a
    KeyboardInterrupt) was being handled: a library that wraps it (a callback inside compiled
    code) turns the interrupt into an ordinary error, which is no failure of the trial's."""
    for _ in range(CHAIN_MAX):                  # a chain may loop back on itself: walk a bounded part
        if exc is None:
            return False
        if isinstance(exc, (SystemExit, KeyboardInterrupt)):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


#: Links of an exception's cause/context chain looked through for an interrupt.
CHAIN_MAX = 16


def _one_line(text: str) -> str:
    return " ".join(text.split())


def run_jobs(jobs: Sequence[BatchJob], worker: Callable[[BatchJob], TrialOutcome], *, n_jobs: int = 1,
             executor: Executor | None = None,
             progress: Callable[[TrialOutcome, int, int], None] | None = None) -> list[TrialOutcome]:
    """Run ``worker`` on every job, in input order: serially, in ``n_jobs`` local processes, or on
    ``executor`` (any :class:`concurrent.futures.Executor`, e.g. a dask cluster's; it is not shut
    down here; each job carries the client's working directory, :attr:`BatchJob.cwd`).

    A task whose worker dies (killed, out of memory) is a failed outcome; the others go on.
    """
    outcomes: list[TrialOutcome | None] = [None] * len(jobs)
    if executor is None and (n_jobs <= 1 or len(jobs) <= 1):
        for i, job in enumerate(jobs):
            outcomes[i] = worker(job)
            if progress:
                progress(outcomes[i], i + 1, len(jobs))
        return [o for o in outcomes if o is not None]
    own = executor is None
    pool = ProcessPoolExecutor(max_workers=n_jobs, initializer=_quiet_on_interrupt) if own else executor
    if not own:
        cwd = os.getcwd()
        jobs = [dataclasses.replace(job, cwd=cwd) for job in jobs]
    futures = {}
    try:
        futures = {pool.submit(worker, job): i for i, job in enumerate(jobs)}
        for done, fut in enumerate(as_completed(futures), start=1):
            i = futures[fut]
            outcomes[i] = _outcome(fut, jobs[i])
            if progress:
                progress(outcomes[i], done, len(jobs))
    finally:
        # on Ctrl-C, trials not yet started are dropped; finished ones are complete on disk
        if own:
            pool.shutdown(wait=True, cancel_futures=True)
        else:
            for fut in futures:
                fut.cancel()
    return [o for o in outcomes if o is not None]


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Ctrl-C (SIGINT) and a kill (SIGTERM) wait until the end of the block, then act as their
    handlers would have (also when the block raised: the interrupt then comes first).

    For importing the analysis (numpy, scipy, numba: a second or more): an interrupt raised inside
    an import can be lost there (a library that catches every exception) or, once it is caught,
    still end the process by SIGINT instead of the command's exit status 130 (CPython remembers an
    interrupt raised inside code an extension module runs at import). Noted instead of raised, it
    acts after the import, where the batch handles it. (Blocking the signals in this thread would
    not do: the threads numpy's BLAS started before take them.) Main thread only, and only signals
    whose handler Python set; elsewhere the block runs as it is.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    before = {signum: handler for signum, handler in before.items() if handler is not None}
    noted: list[int] = []
    is_open = True

    def note(signum, frame):
        if is_open:
            noted.append(signum)
        else:                                   # after the block, before its handler is back
            _act_on(signum, before[signum], frame)

    for signum in before:
        signal.signal(signum, note)
    try:
        yield
    finally:
        is_open = False
        for signum, handler in before.items():
            signal.signal(signum, handler)
        if noted:
            _act_on(noted[0], before[noted[0]], None)


def _act_on(signum: int, handler, frame) -> None:
    """What ``handler`` (as :func:`signal.getsignal` gives it) does with ``signum``."""
    if callable(handler):
        handler(signum, frame)
    elif handler == signal.SIG_DFL:
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)


def _quiet_on_interrupt() -> None:
    """A worker process ends on Ctrl-C (its process group's SIGINT) without printing a traceback:
    the batch's own process says what happened, and a trial cut short leaves no complete outputs."""
    signal.signal(signal.SIGINT, _exit_quietly)


def _exit_quietly(signum, frame):
    raise SystemExit(128 + signum)


#: Exception names of executors whose worker died under a task (the task itself may be fine).
LOST_WORKER = ("BrokenProcessPool", "BrokenExecutor", "KilledWorker", "CommClosedError")


#: The reason a trial fails with when the process running it was lost …
WORKER_LOST = "the worker running it was lost"
#: … or when Ctrl-C reached the worker while it ran.
INTERRUPTED = "interrupted before it finished"


def cut_short(outcome: TrialOutcome) -> bool:
    """Whether ``outcome`` failed only because its worker process was lost — as Ctrl-C does to
    the workers it reaches: such a trial was cut short, not failed by its data."""
    return outcome.status == "failed" and (WORKER_LOST in outcome.error or interrupted(outcome))


def interrupted(outcome: TrialOutcome) -> bool:
    """Whether ``outcome`` failed because Ctrl-C reached its worker: never a failure of the
    trial's, whenever the batch's own process learns of the interrupt (its worker's outcome may
    come back before the batch's own KeyboardInterrupt is raised)."""
    return outcome.status == "failed" and INTERRUPTED in outcome.error


def _outcome(future, job: BatchJob) -> TrialOutcome:
    """The outcome a finished task returned, or a failed one when it could not run."""
    try:
        return future.result()
    except Exception as exc:  # noqa: BLE001 - a task that cannot run fails its trial, not the batch
        what = (WORKER_LOST if type(exc).__name__ in LOST_WORKER
                else "it could not run on the executor")
        return TrialOutcome(job.name, str(job.source), "failed",
                            _one_line(f"{job.source}: {what} ({type(exc).__name__}: {exc})"))
