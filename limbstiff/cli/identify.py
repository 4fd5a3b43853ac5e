"""``limbstiff identify``: the posterior of inertia and damping of each trial, nothing else."""

from __future__ import annotations

import os
import sys

import click

from .options import EXIT_USAGE, load_protocol_or_default, out_option, protocol_option, reports_errors, seed_option


@click.command("identify")
@click.argument("paths", nargs=-1, required=True)
@protocol_option
@out_option("limbstiff-identify")
@click.option("--jobs", type=click.IntRange(min=1), default=None,
              help="Trials identified in parallel (default: number of cores).")
@seed_option
@click.option("--overwrite", is_flag=True, help="Replace outputs that already exist.")
@reports_errors
def command(paths, protocol_path, out, jobs, seed, overwrite):
    """Identify inertia and damping of every trial in PATHS; write posterior.json and draws.csv."""
    from ..pipeline import identify_files

    protocol = load_protocol_or_default(protocol_path)

    def progress(outcome, done, total):
        mark = "ok" if outcome.status == "ok" else f"FAILED: {outcome.error}"
        click.echo(f"[{done}/{total}] {outcome.trial}: {mark}", err=True)

    report = identify_files(paths, protocol=protocol, out=out, jobs=jobs or os.cpu_count() or 1, seed=seed,
                            overwrite=overwrite, progress=progress)
    n = len(report.outcomes)
    click.echo(f"{n - report.n_failed} of {n} trials done; outputs in {report.out}", err=True)
    sys.exit(report.exit_status if n else EXIT_USAGE)
