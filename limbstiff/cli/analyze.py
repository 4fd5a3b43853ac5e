"""``limbstiff analyze``: stiffness of each trial file, written as INTERFACE.md section 4 says."""

from __future__ import annotations

import os
import sys

import click

from .options import (EXIT_USAGE, load_protocol_or_default, out_option, protocol_option,
                      reports_errors, seed_option)


@click.command("analyze")
@click.argument("paths", nargs=-1, required=True)
@protocol_option
@out_option("limbstiff-out")
@click.option("--jobs", type=click.IntRange(min=1), default=None,
              help="Trials analysed in parallel (default: number of cores).")
@seed_option
@click.option("--no-pdf", is_flag=True, help="Do not write report.pdf.")
@click.option("--inertia", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Fix the inertia m (kg·m², or kg for translational trials) instead of identifying it.")
@click.option("--damping", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Fix the damping b (N·m·s/rad, or N·s/m) instead of identifying it.")
@click.option("--gain", "observer_gain", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Fix the observer gain α (1/rad or 1/m) instead of deriving it from the data.")
@click.option("--estimator", type=click.Choice(["kalman", "observer-smoothed", "observer"]), default=None,
              help="Estimator (default kalman: Kalman filter and RTS smoother).")
@click.option("--reference", "reference_path", type=click.Path(dir_okay=False), default=None,
              help="Calibration JSON from 'limbstiff calibrate', used as reference stiffness.")
@click.option("--overwrite", is_flag=True, help="Replace outputs that already exist.")
@reports_errors
def command(paths, protocol_path, out, jobs, seed, no_pdf, inertia, damping, observer_gain, estimator,
            reference_path, overwrite):
    """Estimate the stiffness of every trial in PATHS (files, folders, globs)."""
    from ..pipeline import analyze_files, check_reference

    protocol = load_protocol_or_default(protocol_path).override(
        inertia=inertia, damping=damping, observer_gain=observer_gain, estimator=estimator)
    reference = check_reference(reference_path) if reference_path else None

    def progress(outcome, done, total):
        mark = "ok" if outcome.status == "ok" else f"FAILED: {outcome.error}"
        click.echo(f"[{done}/{total}] {outcome.trial}: {mark}", err=True)

    report = analyze_files(paths, protocol=protocol, out=out, jobs=jobs or os.cpu_count() or 1, seed=seed,
                           pdf=not no_pdf, overwrite=overwrite, reference=reference,
                           progress=progress)
    for note in report.notes:
        click.echo(f"limbstiff: note: {note}", err=True)
    n = len(report.outcomes)
    click.echo(f"{n - report.n_failed} of {n} trials done; outputs in {report.out}", err=True)
    sys.exit(report.exit_status if n else EXIT_USAGE)
