"""``limbstiff identify``: the posterior of inertia and damping of each trial, nothing else."""

from __future__ import annotations

import click

from .options import (finish, jobs_option, load_protocol_or_default, n_jobs, out_option, overwrite_option,
                      protocol_option, reports_errors, scheduler_option, seed_option, stopped_on_kill)


@click.command("identify")
@click.argument("paths", nargs=-1, required=True)
@protocol_option
@out_option("limbstiff-identify")
@jobs_option
@scheduler_option
@seed_option
@overwrite_option
@reports_errors
def command(paths: tuple[str, ...], protocol_path: str | None, out: str, jobs: int | None, scheduler: str | None,
            seed: int, overwrite: bool) -> None:
    """Identify inertia and damping of every trial in PATHS; write posterior.json and draws.csv."""
    jobs = n_jobs(jobs, scheduler)            # before connecting to any scheduler
    from ..batch.cluster import dask_executor
    from .progress import Progress
    from ..batch.jobs import identify_files

    with stopped_on_kill(), dask_executor(scheduler) as executor:
        finish(identify_files(paths, protocol=load_protocol_or_default(protocol_path), out=out, jobs=jobs,
                              seed=seed, overwrite=overwrite, executor=executor, progress=Progress()))
