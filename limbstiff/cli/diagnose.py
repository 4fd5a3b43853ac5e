"""``limbstiff diagnose``: where the nominal model misses the data, which unmodelled effect causes
it, and how far the gap shrinks once that effect is added (docs/interface.md section 5)."""

from __future__ import annotations

import sys

import click

from .options import (fail, jobs_option, load_protocol_or_default, n_jobs, out_option, overwrite_option,
                      protocol_option, reports_errors, scheduler_option, seed_option)


@click.command("diagnose")
@click.argument("paths", nargs=-1, required=True)
@protocol_option
@out_option("limbstiff-diagnose")
@seed_option
@click.option("--inertia", type=click.FloatRange(min=0, min_open=True), default=None,
              help="The inertia m the set-up assumes (kg·m², or kg); otherwise identified from each trial.")
@click.option("--damping", type=click.FloatRange(min=0, min_open=True), default=None,
              help="The damping b the set-up assumes (N·m·s/rad, or N·s/m); otherwise identified.")
@jobs_option
@scheduler_option
@click.option("--no-pdf", is_flag=True, help="Do not write diagnosis.pdf.")
@overwrite_option
@reports_errors
def command(paths: tuple[str, ...], protocol_path: str | None, out: str, seed: int, inertia: float | None,
            damping: float | None, jobs: int | None, scheduler: str | None, no_pdf: bool, overwrite: bool) -> None:
    """Diagnose the gap between the nominal model and the trials in PATHS (together: the effects'
    amplitudes are shared, each trial is held out block by block); write diagnosis.json and
    diagnosis.pdf (not with --no-pdf)."""
    jobs = n_jobs(jobs, scheduler)            # before connecting to any scheduler
    from ..files.outputs import refuse_existing
    from ..diagnosis.from_files import diagnose_files

    refuse_existing(out, ("diagnosis.json", "diagnosis.pdf"), overwrite=overwrite)     # before any trial runs
    from ..batch.cluster import dask_executor
    from .progress import Progress

    with dask_executor(scheduler) as executor:
        report = diagnose_files(paths, protocol=load_protocol_or_default(protocol_path), out=out, seed=seed,
                                inertia=inertia, damping=damping, jobs=jobs, executor=executor,
                                progress=Progress(), pdf=not no_pdf)
    for line in report.failed:
        click.echo(f"limbstiff: error: {line}", err=True)
    if report.diagnosis is None:
        fail("no trial could be diagnosed", report.exit_status)
    d = report.diagnosis
    click.echo(f"{d.headline}; outputs in {report.out}", err=True)
    differ = [s for s in d.per_trial if not s.agrees]
    if differ:
        alone = "; ".join(f"{s.trial} alone: {', '.join(s.diagnosis) or 'none'}" for s in differ)
        click.echo(f"limbstiff: warning: the trials disagree with the pooled diagnosis ({alone}); diagnose them "
                   "separately or pool only trials of one set-up (diagnosis.json per_trial)", err=True)
    sys.exit(report.exit_status)
