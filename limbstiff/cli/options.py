"""Options shared by several commands, defined once, and the error handling they all use."""

from __future__ import annotations

import contextlib
import functools
import os
import signal
import sys
import threading
from typing import TYPE_CHECKING, Iterator, NoReturn

import click

from ..errors import LimbstiffError

if TYPE_CHECKING:
    from ..batch.outcome import BatchReport

EXIT_OK, EXIT_SOME_FAILED, EXIT_USAGE = 0, 1, 2

protocol_option = click.option(
    "--protocol", "protocol_path", type=click.Path(dir_okay=False), default=None,
    help="Protocol TOML file describing the set-up (columns, units, settings).")
seed_option = click.option("--seed", type=int, default=0, show_default=True,
                           help="Seed of every random draw (recorded in the outputs).")


jobs_option = click.option("--jobs", type=click.IntRange(min=1), default=None,
                           help="Trials run in parallel processes (default: number of cores).")
overwrite_option = click.option("--overwrite", is_flag=True,
                                help="Replace outputs that already exist (without it an existing output is never "
                                     "replaced: exit status 2).")
scheduler_option = click.option(
    "--scheduler", default=None, metavar="ADDRESS",
    help="Run the trials on the dask.distributed scheduler at ADDRESS (tcp://host:8786) instead of local "
         "processes; inputs and --out must be on a file system the workers share. Needs "
         "pip install 'limbstiff[dask]'.")


def finish(report: BatchReport) -> NoReturn:
    """Say how the batch went and exit with docs/interface.md's status: paths that matched nothing
    (one line each, with why), warnings, notes, then the tally."""
    for why in report.missing:
        click.echo(f"limbstiff: error: {why}", err=True)
    for warning in report.warnings:
        click.echo(f"limbstiff: warning: {warning}", err=True)
    for note in report.notes:
        click.echo(f"limbstiff: note: {note}", err=True)
    click.echo(report.tally, err=True)
    sys.exit(report.exit_status if report.outcomes else EXIT_USAGE)


@contextlib.contextmanager
def stopped_on_kill() -> Iterator[None]:
    """In the block, a kill (SIGTERM) stops this process as Ctrl-C does: the batch writes its table
    once more on the way out and the command exits 130 ("interrupted"). Processes forked from it
    (local workers) keep the default: a kill ends them at once. No effect off the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pid = os.getpid()

    def interrupt(signum, frame):
        if os.getpid() != pid:               # a forked worker: end as the default would
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        raise KeyboardInterrupt

    before = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


def n_jobs(jobs, scheduler=None):
    """``--jobs`` or the number of cores; an error when ``--scheduler`` is given too (the
    cluster's workers set the parallelism then)."""
    import os
    if jobs and scheduler:
        fail("--jobs and --scheduler exclude each other: on a cluster its workers run the trials in parallel")
    return jobs or os.cpu_count() or 1


def out_option(default: str):
    return click.option("--out", "out", type=click.Path(), default=default,
                        show_default=True, help="Output folder.")


def fail(message: str, status: int = EXIT_USAGE) -> NoReturn:
    """Print a one-line error on stderr and exit with ``status``."""
    click.echo(f"limbstiff: error: {' '.join(str(message).split())}", err=True)
    sys.exit(status)


def reports_errors(func):
    """Turn a :class:`LimbstiffError` raised by a command, or a file that cannot be written (an
    :class:`OSError`), into a one-line error and exit 2."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except LimbstiffError as exc:
            fail(str(exc))
        except OSError as exc:
            where = f"{exc.filename}: " if exc.filename else ""
            fail(f"{where}{exc.strerror or type(exc).__name__}; use another path")
        except KeyboardInterrupt:
            fail("interrupted", 130)

    return wrapper


def load_protocol_or_default(path):
    """The protocol of ``--protocol``, or the default one."""
    from ..protocol import Protocol, load_protocol
    return load_protocol(path) if path else Protocol()


def with_curve_options(protocol, *, period_s=None, start_s=None, marker=None, schedule=None):
    """The protocol with ``--period``/``--cycle-start``/``--marker`` (its ``[cycles]``) and
    ``--schedule COLUMN[:UNIT]`` (its ``[columns.schedule]``) in place of its own."""
    import dataclasses

    from ..protocol import Column, Cycles

    if period_s is not None and marker is not None:
        fail("give --period or --marker, not both (cycles of fixed length, or started by a trigger column)")
    if start_s is not None and period_s is None and (protocol.cycles is None or protocol.cycles.period_s is None):
        fail("--cycle-start needs --period (or [cycles] period_s in the protocol)")
    if period_s is not None or marker is not None:
        start = start_s if start_s is not None else (protocol.cycles.start_s if protocol.cycles else 0.0)
        protocol = protocol.override(cycles=Cycles(period_s=period_s, start_s=start if period_s else 0.0,
                                                   marker=marker))
    elif start_s is not None:
        protocol = protocol.override(cycles=dataclasses.replace(protocol.cycles, start_s=start_s))
    if schedule is not None:
        header, _, unit = schedule.partition(":")
        columns = dict(protocol.columns)
        columns["schedule"] = Column(header=header.strip(), unit=unit.strip() or None)
        protocol = protocol.override(columns=columns)
    return protocol
