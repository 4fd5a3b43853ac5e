"""The stiffness against a cycle's phase or a recorded schedule: the axes-level plot and its page."""

from __future__ import annotations

import textwrap

import numpy as np

from .common import FONT, grid, new_page, text_panel


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
    """The stiffness by phase or by schedule with its band, the resolution chosen, the curve's
    checks. None for a plain analysis."""
    analysis = getattr(result, "curve", None)
    if analysis is None:
        return None
    curve = analysis.curve
    fig = new_page(f"Stiffness by {'phase of the cycle' if curve.against == 'phase' else 'schedule'}")
    gs = grid(fig, 2, 1, hspace=0.3, height_ratios=(1.5, 1))
    ax = plot_curve(curve, ax=fig.add_subplot(gs[0]), unit_stiffness=result.trial.units["stiffness"], legend=False)
    if result.reference is not None:
        ax.plot(curve.at, analysis.binned(result.reference, result.observable), "--", color="tab:red", lw=1.2,
                label="reference")
    ax.legend(loc="best", fontsize=FONT["small"], framealpha=0.85)
    prepared, res = analysis.prepared, analysis.resolution
    where = (f"{prepared.get('n_cycles')} cycles ({prepared['how']})" if curve.against == "phase"
             else prepared["how"])
    units = "cycles" if curve.against == "phase" else "stretches"
    resolution = (f"{res.chosen} knots (grey lines)" if res.chosen else
                  f"none finer than the walk (no curve predicted left-out {units} better)")
    ax.set_title(textwrap.fill(f"Pooled over {where}; the curve's resolution: {resolution}, chosen by predicting "
                               f"left-out {units}", 100),
                 fontsize=FONT["small"], loc="left")
    rows = [("tried (knots: held-out log density)",
             ", ".join(f"{s.knots}: {s.score:.0f}" for s in res.scores))]
    if curve.against == "phase":
        rows.append(("ensemble mean taken off", f"{100 * prepared['ensemble_mean_share_of_angle_variance']:.0f} % of "
                     "the angle's variance (the movement every cycle repeats)"))
    rows.append((f"{100 * curve.level:.0f} % band", "the estimate's own uncertainty (the walk, m, b, the curve's "
                 "weights); not yet calibrated: on an independent simulator it was too narrow, the curves "
                 "said ok within a few percent (docs/benchmarks.md)"))
    rows += [(c.name, ("ok: " if c.passed else "FAILED: ") + c.message) for c in analysis.checks]
    text_panel(fig, gs[1], rows, title="How the curve was made, and its checks", wrap=70)
    return fig
