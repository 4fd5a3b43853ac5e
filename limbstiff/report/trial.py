"""The per-trial PDF stiffness report.

:func:`report_figures` builds the pages as matplotlib figures (no file, no pyplot), in order:

1. the answer: the verdict with its reasons, the stiffness over time with its band, the trial's
   figures with what each interval is, warnings, a short table of what was recorded;
2. angle, torque and stiffness over time, uninformed stretches shaded;
3. stiffness against angle and against torque (medians in bins with the band), and the stiffness
   against the angle within the motion cycle (from the angle terms, when they were fitted);
4. posterior of inertia and damping (pairwise plot, priors drawn), or why there is none;
5. data quality (sampling, bandwidth and spectra, quantisation, observer, MCMC);
6. error against the reference stiffness (only when there is one).

Every page carries a provenance footer. :func:`write_report` writes them as one PDF, atomically.
"""

from __future__ import annotations

from pathlib import Path

from ..provenance import dependencies_text, software
from .common import footer, style, write_pdf
from .curve import curve_page
from .mechanics import mechanics_page
from .pages import reference_page, relation_page, summary_page, time_page
from .quality import quality_page
from .ticks import lean_ticks

#: Page builders, in order; each takes the result and returns a Figure (or None to skip).
PAGES = (summary_page, curve_page, time_page, relation_page, mechanics_page, quality_page, reference_page)


def provenance_lines(result) -> list[str]:
    """The footer's lines: version, seed, source and settings hashes, dependency versions."""
    sha = result.trial.source_sha256
    settings = result.settings_sha256               # summary.json's, of which the footer shows a prefix
    block = software()
    return [f"limbstiff {block['version']} · trial {result.trial.name} · seed {result.seed} · source sha256 "
            f"{sha[:12] if sha else '— (in memory)'} · settings {settings[:12]}",
            dependencies_text(block)]


def report_figures(result) -> list:
    """The report's pages as figures, without writing anything.

    Parameters
    ----------
    result : StiffnessResult

    Returns
    -------
    list of matplotlib.figure.Figure
        A4 portrait pages; the texts of text panels have gid ``"text-panel"``; the ticks of every
        axis are fixed (:func:`~limbstiff.report.ticks.fix_ticks`).
    """
    with style():
        figures = [fig for fig in (page(result) for page in PAGES) if fig is not None]
        lines = provenance_lines(result)
        for k, fig in enumerate(figures, start=1):
            lean_ticks(fig)
            footer(fig, lines, k, len(figures))
    return figures


def write_report(result, path: str | Path) -> Path:
    """Write the PDF report of one :class:`~limbstiff.result.StiffnessResult`, atomically.

    Parameters
    ----------
    result : StiffnessResult
    path : str or Path

    Returns
    -------
    Path
        The file written.
    """
    trial = result.trial
    metadata = {"Title": f"limbstiff stiffness report: {trial.name}",
                "Subject": f"Joint stiffness of trial {trial.name}"
                           + (f" ({trial.source})" if trial.source else ""),
                "Keywords": f"stiffness; {trial.kind}; {result.variant}; {result.estimator}"}
    with style():
        return write_pdf(report_figures(result), path, metadata)
