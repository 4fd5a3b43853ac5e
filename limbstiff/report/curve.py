"""The stiffness against a cycle's phase or a recorded schedule: the axes-level plot and its page."""

from __future__ import annotations

import textwrap

import numpy as np

from .common import FONT, TITLE_HEIGHT, grid, new_page, text_panel
from .pages import verdict_box


def plot_curve(curve, *, ax=None, unit_stiffness: str = "N·m/rad", legend: bool = True, least_squares=None):
    """Draw a :class:`~limbstiff.scheduled.curve.ScheduleCurve`: the pooled stiffness per bin, its
    band, (ensembles) the 10th–90th percentile of the cycles' own means, and the least-squares
    cross-check's points with their intervals beside it (``least_squares``, a
    :class:`~limbstiff.scheduled.least_squares.LeastSquaresCurve`) when given.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if ax is None:
        import matplotlib.pyplot as plt
        ax = plt.gca()
    x, ok = curve.at, curve.informed
    if np.any(np.isfinite(curve.spread_lo)):
        ax.fill_between(x, curve.spread_lo, curve.spread_hi, color="tab:blue", alpha=0.15, lw=0,
                        label="cycles: 10th–90th percentile")
    ax.fill_between(x, np.where(ok, curve.lo, np.nan), np.where(ok, curve.hi, np.nan), color="0.55", alpha=0.5, lw=0,
                    label=f"{100 * curve.level:.0f} % band")
    ax.plot(x, curve.stiffness, color="k", lw=1.4, label="stiffness, pooled")
    if least_squares is not None and least_squares.informed.any():
        ls, on = least_squares, least_squares.informed
        ax.errorbar(x[on], ls.stiffness[on], yerr=[ls.stiffness[on] - ls.lo[on], ls.hi[on] - ls.stiffness[on]],
                    fmt="o", ms=2.5, color="tab:orange", ecolor="tab:orange", elinewidth=0.8, capsize=0, zorder=3,
                    label=f"least squares per bin, {100 * ls.level:.0f} % interval")
    ls_below = least_squares is not None and np.nanmin(least_squares.lo, initial=0) < 0
    if np.any(curve.informed & (curve.hi < 0)) or ls_below:
        ax.axhline(0.0, color="0.3", lw=0.6)
    for k in curve.knots:
        ax.axvline(k, color="0.85", lw=0.6, zorder=0)
    ax.set_xlabel("phase of the cycle (0–1)" if curve.against == "phase" else f"schedule ({curve.unit})")
    ax.set_ylabel(f"stiffness ({unit_stiffness})")
    if curve.against == "phase":
        ax.set_xlim(0, 1)
    if legend:
        ax.legend(loc="best", fontsize=FONT["small"], framealpha=0.85)
    return ax


def curve_page(result):
    """The stiffness by phase or by schedule with its band and the least-squares cross-check, the
    curve's own verdict with its reasons, how the curve was made. None for a plain analysis."""
    analysis = getattr(result, "curve", None)
    if analysis is None:
        return None
    curve = analysis.curve
    fig = new_page(f"Stiffness by {'phase of the cycle' if curve.against == 'phase' else 'schedule'}")
    top = verdict_box(fig, result, 1 - TITLE_HEIGHT - 0.01, list(analysis.reasons), curve=analysis)
    gs = grid(fig, 2, 1, hspace=0.3, height_ratios=(1.3, 1), top=top - 0.045)    # the plot's title above it
    ax = plot_curve(curve, ax=fig.add_subplot(gs[0]), unit_stiffness=result.trial.units["stiffness"], legend=False,
                    least_squares=analysis.least_squares)
    if result.reference is not None:
        ax.plot(curve.at, analysis.binned(result.reference, result.observable), "--", color="tab:red", lw=1.2,
                label="reference")
    ax.legend(loc="best", fontsize=FONT["small"], framealpha=0.85)
    prepared, res = analysis.prepared, analysis.resolution
    units = "cycles" if curve.against == "phase" else "stretches"
    resolution = (f"{res.chosen} knots (grey lines)" if res.chosen else
                  f"none finer than the walk (no curve predicted left-out {units} better)")
    ax.set_title(textwrap.fill(f"Pooled over {analysis.pooled_over}; the curve's resolution: {resolution}, chosen "
                               f"by predicting left-out {units}", 100),
                 fontsize=FONT["small"], loc="left")
    rows = [("tried (knots: held-out log density)",
             ", ".join(f"{s.knots}: {s.score:.0f}" for s in res.scores))]
    if curve.against == "phase":
        rows.append(("ensemble mean taken off", f"{100 * prepared['ensemble_mean_share_of_angle_variance']:.0f} % of "
                     "the angle's variance (the movement every cycle repeats)"))
    ratio = curve.width_ratio
    rows.append((f"{100 * curve.level:.0f} % band", "the envelope of the estimate's own uncertainty (the walk, m, b, "
                 f"the curve's weights), of the {units} resampled whole, and of the misfit against the least-squares "
                 f"points ({100 * curve.misfit:.0f} % of the stiffness, rms) and the straight lines' error between "
                 f"the knots ({100 * (curve.interpolation_share or 0.0):.1f} %, median) added to the estimate's own"
                 + ("" if ratio is None else f": {ratio:.2f}× the estimate's own width (median)")))
    if analysis.least_squares is not None:
        rows.append(("least squares (points)", analysis.least_squares.how))
    passed = [c.message for c in (*analysis.checks, *analysis.band_checks) if c.passed]
    if passed:
        rows.append(("the curve's checks passed", "; ".join(passed) + " (the curve's verdict above is the worst "
                     "of the trial's and of its own checks)"))
    text_panel(fig, gs[1], rows, title="How the curve was made", wrap=70)
    return fig

