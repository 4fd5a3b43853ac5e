"""``limbstiff diagnose``: where the nominal model misses the data, which unmodelled effect causes
it, and how far the gap shrinks once that effect is added (INTERFACE.md section 5)."""

from __future__ import annotations

import sys

import click

from .options import fail, load_protocol_or_default, out_option, protocol_option, reports_errors, seed_option


def _progress(name, error):
    click.echo(f"{name}: {'read and analysed' if error is None else 'FAILED: ' + error}", err=True)


@click.command("diagnose")
@click.argument("paths", nargs=-1, required=True)
@protocol_option
@out_option("limbstiff-diagnose")
@seed_option
@click.option("--inertia", type=click.FloatRange(min=0, min_open=True), default=None,
              help="The inertia m the set-up assumes (kg·m², or kg); otherwise identified from each trial.")
@click.option("--damping", type=click.FloatRange(min=0, min_open=True), default=None,
              help="The damping b the set-up assumes (N·m·s/rad, or N·s/m); otherwise identified.")
@reports_errors
def command(paths, protocol_path, out, seed, inertia, damping):
    """Diagnose the gap between the nominal model and the trials in PATHS (together: several
    trials are held out one at a time); write diagnosis.json and diagnosis.pdf."""
    from ..gap.run import diagnose_files

    report = diagnose_files(paths, protocol=load_protocol_or_default(protocol_path), out=out, seed=seed,
                            inertia=inertia, damping=damping, progress=_progress)
    for line in report.failed:
        click.echo(f"limbstiff: error: {line}", err=True)
    if report.diagnosis is None:
        fail("no trial could be diagnosed", report.exit_status)
    d = report.diagnosis
    found = ", ".join(d.diagnosis) if d.diagnosis else "none (the nominal model explains the data)"
    click.echo(f"gap {100 * d.gap_heldout:.2f} % held out; effects: {found}; outputs in {report.out}", err=True)
    sys.exit(report.exit_status)
