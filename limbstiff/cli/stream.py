"""``limbstiff stream``: the live stiffness of a Lab Streaming Layer stream, and the analysis of its recording."""

from __future__ import annotations

import time
from pathlib import Path

import click

from .options import (fail, finish, load_protocol_or_default, out_option, overwrite_option, protocol_option,
                      reports_errors, seed_option)


@click.command("stream")
@click.option("--name", default=None, help="Name of the LSL stream to read (its 'name').")
@click.option("--type", "type_", default=None, help="Type of the LSL stream to read (e.g. Motion), when no --name.")
@protocol_option
@out_option("limbstiff-out")
@click.option("--trial", default=None, metavar="NAME",
              help="Name of the recording (OUT/NAME.csv and OUT/NAME/); default stream-<date>-<time>.")
@click.option("--duration", "duration_s", type=click.FloatRange(min=0, min_open=True), default=None, metavar="SECONDS",
              help="Stop after this much record (default: at Ctrl-C or when the stream ends).")
@click.option("--warmup", "warmup_s", type=click.FloatRange(min=1), default=5.0, show_default=True, metavar="SECONDS",
              help="Record before m, b and the noise levels are first identified (then again at 2x, 4x… and "
                   "every 60 s).")
@click.option("--timeout", "timeout_s", type=click.FloatRange(min=0, min_open=True), default=10.0, show_default=True,
              metavar="SECONDS", help="End the session when no sample has come for this long.")
@click.option("--resolve-timeout", "resolve_s", type=click.FloatRange(min=0, min_open=True), default=5.0,
              show_default=True, metavar="SECONDS", help="How long to look for the stream.")
@click.option("--outlet", default="limbstiff", show_default=True,
              help="Name of the LSL outlet publishing the stiffness.")
@click.option("--no-outlet", is_flag=True, help="Do not publish the stiffness on LSL.")
@click.option("--inertia", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Fix the inertia m instead of identifying it.")
@click.option("--damping", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Fix the damping b instead of identifying it.")
@seed_option
@click.option("--no-pdf", is_flag=True, help="Do not write report.pdf for the recording.")
@click.option("--quiet", is_flag=True, help="No live status line.")
@overwrite_option
@reports_errors
def command(name, type_, protocol_path, out, trial, duration_s, warmup_s, timeout_s, resolve_s, outlet, no_outlet,
            inertia, damping, seed, no_pdf, quiet, overwrite) -> None:
    """Live stiffness of an LSL stream; at the end the recording is analysed as 'limbstiff analyze' does."""
    if name is None and type_ is None:
        fail("give the stream's --name or --type (see your acquisition software's stream list)")
    from ..live.run import StreamSettings, run_stream

    trial = trial or time.strftime("stream-%Y%m%d-%H%M%S")
    out_dir = Path(out)
    for path in (out_dir / f"{trial}.csv", out_dir / trial):
        if path.exists() and not overwrite:
            fail(f"{path}: exists; use --overwrite or another --trial")
    protocol = load_protocol_or_default(protocol_path).override(inertia=inertia, damping=damping)
    settings = StreamSettings(name=name, type=type_, out=out_dir, trial=trial, protocol=protocol,
                              duration_s=duration_s, timeout_s=timeout_s, warmup_s=warmup_s, resolve_s=resolve_s,
                              outlet=None if no_outlet else outlet, seed=seed, pdf=not no_pdf)

    def show(line: str) -> None:
        click.echo("\r" + line[:160].ljust(160), nl=False, err=True)

    def said(line: str) -> None:       # before the analysis: a Ctrl-C there still leaves this said
        if not quiet:
            click.echo("", err=True)
        click.echo(line, err=True)

    outcome = run_stream(settings, progress=None if quiet else show, announce=said)
    if outcome.report is None:
        fail("no sample was received: nothing recorded")
    finish(outcome.report)
