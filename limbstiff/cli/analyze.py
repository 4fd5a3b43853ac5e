"""``limbstiff analyze``: stiffness of each trial file, written as docs/interface.md section 4 says."""

from __future__ import annotations

import click

from ..protocol import ESTIMATORS, MODEL_EFFECTS
from .options import (fail, finish, jobs_option, load_protocol_or_default, n_jobs, out_option, overwrite_option,
                      protocol_option, reports_errors, scheduler_option, seed_option, stopped_on_kill,
                      with_curve_options)


@click.command("analyze")
@click.argument("paths", nargs=-1, required=True)
@protocol_option
@out_option("limbstiff-out")
@jobs_option
@scheduler_option
@seed_option
@click.option("--no-pdf", is_flag=True, help="Do not write report.pdf.")
@click.option("--inertia", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Fix the inertia m (kg·m², or kg for translational trials) instead of identifying it.")
@click.option("--damping", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Fix the damping b (N·m·s/rad, or N·s/m) instead of identifying it.")
@click.option("--gain", "observer_gain", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Fix the observer gain α (1/rad or 1/m) instead of deriving it from the data.")
@click.option("--estimator", type=click.Choice(ESTIMATORS), default=None,
              help="Estimator (default kalman: Kalman filter and RTS smoother).")
@click.option("--effect", "effects", type=click.Choice(MODEL_EFFECTS), multiple=True,
              help="Put this unmodelled effect in the model (repeat for several): its shape chosen from the data, its "
                   "amplitude identified with m and b; e.g. --effect reflex when the verdict names a stretch reflex.")
@click.option("--period", "period_s", type=click.FloatRange(min=0, min_open=True), default=None, metavar="SECONDS",
              help="Cut the trial into cycles of this length (from --cycle-start) and report the stiffness by "
                   "phase (stiffness_by_phase.csv); as [cycles] period_s in the protocol.")
@click.option("--cycle-start", "start_s", type=click.FloatRange(min=0), default=None, metavar="SECONDS",
              help="Time from the first sample at which the first --period cycle starts (default 0).")
@click.option("--marker", default=None, metavar="COLUMN",
              help="Start a cycle at each rising edge of this trigger column and report the stiffness by phase; "
                   "as [cycles] marker in the protocol.")
@click.option("--ensemble", is_flag=True,
              help="Take every trial file in PATHS as one cycle of ONE ensemble (files in natural order of their "
                   "names) and report its stiffness by phase in OUT/<folder name>/; not with --period or --marker.")
@click.option("--schedule", default=None, metavar="COLUMN[:UNIT]",
              help="Report the stiffness as a function of this recorded column (an operating position, an EMG "
                   "envelope…) in stiffness_by_schedule.csv; as [columns.schedule] in the protocol.")
@click.option("--reference", "reference_path", type=click.Path(dir_okay=False), default=None,
              help="Calibration JSON from 'limbstiff calibrate', used as reference stiffness.")
@click.option("--sort-by", default="", metavar="KEY[,KEY...]",
              help="Metadata keys (subject, condition…) that order and group overview.pdf.")
@overwrite_option
@click.option("--resume", is_flag=True,
              help="Skip trials whose outputs are complete and match the input's SHA-256 and the settings.")
@reports_errors
def command(paths: tuple[str, ...], protocol_path: str | None, out: str, jobs: int | None, scheduler: str | None,
            seed: int, no_pdf: bool, inertia: float | None, damping: float | None, observer_gain: float | None,
            estimator: str | None, effects: tuple[str, ...], period_s: float | None, start_s: float | None,
            marker: str | None, ensemble: bool, schedule: str | None, reference_path: str | None, sort_by: str,
            overwrite: bool, resume: bool) -> None:
    """Estimate the stiffness of every trial in PATHS (files, folders, globs)."""
    if ensemble and (period_s is not None or marker is not None or start_s is not None):
        fail("--ensemble takes each file as one cycle: give it without --period, --cycle-start or --marker")
    jobs = n_jobs(jobs, scheduler)            # before connecting to any scheduler
    from ..batch.jobs import analyze_ensemble, analyze_files, check_reference
    from ..batch.cluster import dask_executor
    from .progress import Progress

    protocol = load_protocol_or_default(protocol_path).override(
        inertia=inertia, damping=damping, observer_gain=observer_gain, estimator=estimator,
        effects=tuple(effects) if effects else None)
    protocol = with_curve_options(protocol, period_s=period_s, start_s=start_s, marker=marker, schedule=schedule)
    reference = check_reference(reference_path) if reference_path else None
    keys = [k.strip() for k in sort_by.split(",") if k.strip()]
    with stopped_on_kill(), dask_executor(scheduler) as executor:
        if ensemble:
            finish(analyze_ensemble(paths, protocol=protocol, out=out, seed=seed, pdf=not no_pdf, overwrite=overwrite,
                                    resume=resume, reference=reference, executor=executor, progress=Progress()))
        finish(analyze_files(paths, protocol=protocol, out=out, jobs=jobs, seed=seed, pdf=not no_pdf,
                             overwrite=overwrite, resume=resume, reference=reference, sort_by=keys,
                             executor=executor, progress=Progress()))
