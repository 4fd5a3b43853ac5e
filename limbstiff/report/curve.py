"""The stiffness against a cycle's phase or a recorded schedule: the axes-level plot and its page."""

from __future__ import annotations

import textwrap

import numpy as np

from .common import FONT, TITLE_HEIGHT, grid, new_page, text_panel
from .pages import verdict_box


def plot_curve(curve, *, ax=None, unit_stiffness: str = "N·m/rad", legend: bool = True):
    """Draw a :class:`~limbstiff.scheduled.curve.ScheduleCurve`: the pooled stiffness per bin, its
    band, and (ensembles) the 10th–90th percentile of the cycles' own means.

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
    """The stiffness by phase or by schedule with its band, the trial's verdict with the reasons
    that concern the curve (its own failed checks first), how the curve was made. None for a
    plain analysis."""
    analysis = getattr(result, "curve", None)
    if analysis is None:
        return None
    curve = analysis.curve
    fig = new_page(f"Stiffness by {'phase of the cycle' if curve.against == 'phase' else 'schedule'}")
    top = verdict_box(fig, result, 1 - TITLE_HEIGHT - 0.01, _curve_reasons(result, analysis))
    gs = grid(fig, 2, 1, hspace=0.3, height_ratios=(1.3, 1), top=top - 0.045)    # the plot's title above it
    ax = plot_curve(curve, ax=fig.add_subplot(gs[0]), unit_stiffness=result.trial.units["stiffness"], legend=False)
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
    rows.append((f"{100 * curve.level:.0f} % band", "the estimate's own uncertainty (the walk, m, b, the curve's "
                 "weights); not yet calibrated: on an independent simulator it was too narrow, the curves "
                 "said ok within a few percent (docs/benchmarks.md)"))
    passed = [c.message for c in analysis.checks if c.passed]
    if passed and result.checks is not None:
        rows.append(("the curve's own checks", "passed: " + "; ".join(passed) + f" (the verdict above, the "
                     "trial's, applies to the curve)"))
    text_panel(fig, gs[1], rows, title="How the curve was made", wrap=70)
    return fig


def _curve_reasons(result, analysis) -> list[str]:
    """The trial's reasons for its verdict, the curve's own failed checks first: the curve is the
    trial's stiffness pooled by phase or schedule, so every reason concerns it."""
    if result.checks is None:
        return []
    own = [c.message for c in analysis.checks if not c.passed]
    return own + [r for r in result.checks.reasons if r not in own]
