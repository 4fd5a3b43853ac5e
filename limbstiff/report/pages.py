"""Pages of the per-trial report about the stiffness itself: the answer on page 1, the signals
and the stiffness over time, stiffness against angle and torque, and the error against a
reference stiffness.

Each ``*_page(result)`` returns one :class:`matplotlib.figure.Figure` (A4 portrait, fixed
layout, no footer: :mod:`limbstiff.report.trial` adds it); the plots on them are the
axes-level functions of :mod:`limbstiff.report.plots`.
"""

from __future__ import annotations

import textwrap

import numpy as np

from ..digest import (ANGLE_PROPERTY, INFORMED_GLOSS, VERDICT_WORDS, gloss_rows, headline_rows, recording_rows,
                      verdict_line)
from ..trial_level import REFERENCE_SKIP_S
from .common import (A4, FONT, FOOTER_HEIGHT, LIMIT_VALUES, ROW_SPACING, envelope, envelope_band, fmt, grid,
                     key_value_lines, new_page, robust_limits, shade_false, text_panel)
from .plots import (angle_course_words, angle_figure, names, plot_angle_course, plot_relation, plot_stiffness,
                    recorded_torque)

#: The page the stiffness against angle is on (the check's message names it).
ANGLE_PAGE = 3



def summary_page(result):
    """Page 1, the answer: verdict with its reasons, the stiffness over time (one median per motion
    cycle with its band), the trial's figures with their intervals, warnings and a short table of
    what was recorded. The room the text leaves goes to the stiffness against torque when there is
    enough for a second plot (:data:`TORQUE_PANEL_MIN`), else to the course's plot."""
    fig = new_page()
    fig.text(0.06, 0.962, "Stiffness report", fontsize=FONT["title"], weight="bold", va="center")
    fig.text(0.94, 0.962, result.trial.name, fontsize=FONT["heading"], color="0.3", ha="right", va="center")
    y = verdict_box(fig, result, 0.935)
    height = COURSE_HEIGHT[0]
    ax = fig.add_axes((0.1, y - height - 0.035, 0.84, height))        # room for the legend above it
    plot_stiffness(result, ax=ax)
    first = len(fig.texts)
    figures = headline_rows(result) + angle_rows(result)
    y = _key_values(fig, figures, y - height - 0.08, fontsize=FONT["body"], wrap=80, title="The trial's figures")
    y = _key_values(fig, gloss_rows(result, figures), y + 0.005, fontsize=FONT["small"], wrap=95)
    recording = recording_rows(result)
    room = 0.036 + 2.4 * ROW_SPACING * 1.05 * FONT["small"] / 72 / A4[1]   # the recording's title, source, sampling
    y = _bullets(fig, "Warnings", list(result.warnings) or ["none"], y - 0.01, floor=FOOTER_HEIGHT + room + 0.01)
    y = _key_values(fig, recording, y - 0.01, fontsize=FONT["small"], wrap=95, title="Recording",
                    floor=FOOTER_HEIGHT + 0.01)
    spare = y - FOOTER_HEIGHT - 0.02
    if spare >= TORQUE_PANEL_MIN and result.observable.any():
        _torque_panel(fig, result, y, FOOTER_HEIGHT + 0.045)
    elif spare > 0:                       # a taller course, the text below it moved down
        spare = min(spare, COURSE_HEIGHT[1] - height)
        x0, y0, w, h = ax.get_position().bounds
        ax.set_position((x0, y0 - spare, w, h + spare))
        for text in fig.texts[first:]:
            text.set_y(text.get_position()[1] - spare)
    return fig


#: Page 1's course plot: its height at least and at most, in page fractions (the text is laid out
#: below the smallest, and the room it leaves makes the plot taller).
COURSE_HEIGHT = (0.16, 0.32)
#: Page 1's room below its text, in page fractions, from which the stiffness against torque is drawn
#: there (less would be a plot too flat to read; the course's plot is made taller instead).
TORQUE_PANEL_MIN = 0.2


def _torque_panel(fig, result, top: float, bottom: float) -> None:
    """The stiffness against torque (:func:`plot_relation`) between heights ``top`` and ``bottom``
    (page fractions; the title above its axes, the labels below)."""
    ax = fig.add_axes((0.1, bottom, 0.84, min(top - 0.045 - bottom, 0.26)))
    plot_relation(result, "torque", ax=ax, legend=False)
    ax.set_title("Stiffness against torque: black, median in bins of equal counts with the median band; "
                 "blue, 10th–90th percentile in the bin (page 3)", fontsize=FONT["small"], loc="left")


def _angle_flagged(result) -> bool:
    """Whether the check ``angle_dependence`` ran and failed."""
    return result.checks is not None and any(c.name == "angle_dependence" for c in result.checks.failed)


def angle_rows(result, figure=None) -> list[tuple[str, str]]:
    """Page 1's row on the stiffness against the angle, when the stiffness changes with the angle
    within the cycle (the check ``angle_dependence`` failed) and the terms were fitted: how it goes,
    in words and numbers, and where it is drawn."""
    if not _angle_flagged(result):
        return []
    figure = figure or angle_figure(result)
    if figure is None:
        return []
    u = result.trial.units
    check = result.checks["angle_dependence"]
    joints = ": a property of the joint," if check.message.startswith(ANGLE_PROPERTY) else ","
    return [("Stiffness vs angle", angle_course_words(figure.course, u["angle"], u["stiffness"])
             + f"{joints} shown on page {ANGLE_PAGE}; the median summarises a stiffness "
               "that varies with the angle")]


def verdict_box(fig, result, y: float, reasons: list[str] | None = None, *, curve=None) -> float:
    """The verdict in plain words, coloured, with the reasons below it (``reasons``, the checks'
    by default), from height ``y`` (page fraction) down (page 1; the curve's page gives its own
    ``curve``, a :class:`~limbstiff.curve_result.CurveAnalysis`, and its reasons); the height reached."""
    verdict = verdict_line(result) if curve is None else VERDICT_WORDS[curve.verdict]
    if verdict is None:
        fig.text(0.06, y, "No model checks were run: no verdict.", fontsize=FONT["heading"], va="top")
        return y - 0.03
    word, meaning, colour = verdict
    title = "Verdict" if curve is None else "Curve"
    fig.text(0.06, y, f"{title}: {word}", fontsize=FONT["heading"] + 2, weight="bold", color=colour, va="top")
    fig.text(0.33, y - 0.003, meaning, fontsize=FONT["body"] + 1, color=colour, va="top")
    return _bullets(fig, None, list(result.checks.reasons) if reasons is None else reasons, y - 0.03, limit=5)


def _key_values(fig, rows: list[tuple[str, str]], y: float, *, fontsize: float, wrap: int,
                title: str | None = None, floor: float = 0.0) -> float:
    """Bold labels with their wrapped texts from height ``y`` (page fraction) down, a little space
    between rows, none below ``floor`` (the rest counted in a last line); the height reached."""
    line = ROW_SPACING * 1.05 * fontsize / 72 / A4[1]        # one line, in page fractions
    gap = 0.35 * line
    if title:
        fig.text(0.06, y, title, fontsize=FONT["heading"], weight="bold", va="top")
        y -= 0.026
    for k, (label, value) in enumerate(rows):
        label_lines, value_lines = key_value_lines(label, value, wrap)
        if y - line * (len(value_lines) + (k < len(rows) - 1)) < floor:
            fig.text(0.06, y, f"… {len(rows) - k} more lines in summary.json", fontsize=FONT["small"],
                     style="italic", va="top")
            return y - line - gap
        fig.text(0.06, y, label, fontsize=fontsize, weight="bold", va="top")
        fig.text(0.31, y, "\n".join(value_lines), fontsize=fontsize, va="top", linespacing=ROW_SPACING)
        y -= line * len(value_lines) + gap
    return y - gap


def _bullets(fig, title: str | None, items: list[str], y: float, *, limit: int = 8, floor: float = 0.0) -> float:
    """A heading (optional) and one bullet per item from height ``y`` down, at most ``limit`` and
    none below ``floor``; the rest counted in a last line. The height reached."""
    line = 1.3 * FONT["body"] / 72 / A4[1]
    if title:
        fig.text(0.06, y, title, fontsize=FONT["heading"], weight="bold", va="top")
        y -= 0.026
    for k, item in enumerate(items):
        wrapped = textwrap.wrap(item, 100)
        if (k >= limit or y - line * len(wrapped) < floor) and item != "none":
            fig.text(0.08, y, f"… {len(items) - k} more in summary.json", fontsize=FONT["small"], style="italic",
                     va="top")
            return y - line
        fig.text(0.08, y, "• " + "\n  ".join(wrapped), fontsize=FONT["body"], va="top", linespacing=1.3)
        y -= line * len(wrapped) + 0.35 * line
    return y


def time_page(result):
    """Page 2: angle, torque and stiffness (with its band) over time; uninformed stretches grey."""
    trial = result.trial
    u, word = trial.units, names(trial)
    fig = new_page("Signals and stiffness over time")
    gs = grid(fig, 3, 1, hspace=0.12)
    axes = [fig.add_subplot(gs[0])]
    axes += [fig.add_subplot(gs[k], sharex=axes[0]) for k in (1, 2)]
    axes[0].plot(*envelope(trial.time, trial.angle), lw=0.6, color="C2")
    axes[0].set_ylabel(f"{word['angle']} [{u['angle']}]")
    key, torque = recorded_torque(result)
    axes[1].plot(*envelope(trial.time, torque), lw=0.6, color="C1")
    axes[1].set_ylabel(f"{word[key]} [{u[key]}]")
    plot_stiffness(result, ax=axes[2], per_cycle=False, legend=False)
    axes[2].fill_between([], [], [], color="0.88", lw=0, label="not informed by motion")
    axes[2].legend(loc="upper left", ncols=4)
    for ax in axes[:2]:
        ax.tick_params(labelbottom=False)
    axes[2].set_title(f"{result.variant} variant, {result.estimator} estimator; grey: not informed by motion "
                      f"(no estimate drawn there)\n{INFORMED_GLOSS}", fontsize=FONT["small"], loc="right")
    return fig


def relation_page(result):
    """Page 3: stiffness against angle and against torque, as medians in bins over the samples, and,
    when the angle terms were fitted, the stiffness against the angle within the cycle from them
    (:func:`~limbstiff.report.plots.plot_angle_course`)."""
    fig = new_page("Stiffness against angle and torque")
    if not result.observable.any():
        text_panel(fig, (0.06, 0.5, 0.88, 0.38), "No sample of this trial is informed by motion, so the "
                   "stiffness cannot be related to the angle or the torque.", wrap=90)
        return fig
    figure = angle_figure(result)
    gs = grid(fig, 3 if figure is not None else 2, 1, hspace=0.45 if figure is not None else 0.25)
    for k, against in enumerate(("angle", "torque")):
        ax = plot_relation(result, against, ax=fig.add_subplot(gs[k]), legend=False)
        if k == 0:                                   # the same symbols on both; "best" is slow on a scatter
            ax.legend(loc="upper right", framealpha=0.85)
    fig.axes[0].set_title("black: median of the estimate in bins of equal counts, bars: the median "
                          f"{100 * result.ci_level:.0f} % band there; blue: 10th–90th percentile of the estimate "
                          f"in the bin (its change over the trial). {INFORMED_GLOSS.capitalize()}",
                          fontsize=FONT["small"], loc="left", wrap=True)
    if figure is not None:
        u, word = result.trial.units, names(result.trial)
        ax = plot_angle_course(fig.add_subplot(gs[2]), figure, units=u, word=word["angle"])
        words = angle_course_words(figure.course, u["angle"], u["stiffness"])
        note = ("; the course over time averages over it" if _angle_flagged(result) else "")
        ax.set_title(textwrap.fill(f"Within the motion cycle (the angle terms): {words}{note}", 110),
                     fontsize=FONT["small"], loc="left")
    return fig


def reference_page(result):
    """Error against the reference stiffness (``stiffness_true`` or a calibration).

    Returns
    -------
    Figure or None
        None when the result has no reference.
    """
    if result.reference is None:
        return None
    t = result.trial.time
    ref = np.asarray(result.reference, float)
    fig = new_page("Error against the reference stiffness")
    # the estimate against the reference over time is on pages 1 and 2 already
    gs = grid(fig, 2, 2, height_ratios=[1.0, 0.8], hspace=0.3, wspace=0.3)
    ax1 = fig.add_subplot(gs[0, :])
    err = result.reference_error()          # before rel and width: its temporaries not on top of them
    use = result.reference_samples()
    scale = np.abs(ref)                     # in place below: a long trial's arrays are large
    scale[scale == 0] = np.nan
    np.divide(100, scale, out=scale)        # 100/|ref|; its half is exactly 50/|ref|
    rel = result.stiffness - ref
    rel *= scale
    width = result.stiffness_hi - result.stiffness_lo
    width *= scale
    width *= 0.5
    del scale
    shade_false(ax1, t, result.observable)
    ax1.fill_between(*envelope_band(t, -width, width), color="C0", alpha=0.25, lw=0,
                     label=f"half-width of the {100 * result.ci_level:.0f} % band")
    ax1.plot(*envelope(t, rel), lw=0.7, color="C3", label="(estimate - reference) / reference")
    ax1.axhline(0, color="k", lw=0.6)
    ax1.axvspan(t[0], t[0] + REFERENCE_SKIP_S, color="C1", alpha=0.12, lw=0, label="left out (first 2 s)")
    shown = np.flatnonzero(use)
    shown = shown[::max(1, shown.size // LIMIT_VALUES)]
    limits = robust_limits(np.concatenate([rel[shown], width[shown], -width[shown]]) if shown.size else rel, pad=0.3)
    del width
    if limits is not None:
        ax1.set_ylim(*limits)
    ax1.set_ylabel("relative error [%]")
    ax1.set_xlabel("time [s]")
    ax1.set_xlim(t[0], t[-1])
    ax1.legend(loc="upper right", ncols=2)
    good = use & np.isfinite(rel)
    drawn = rel[good]
    del rel                                 # the histogram's temporaries not on top of it
    _error_histogram(fig, gs[1, 0], np.abs(drawn, out=drawn), err)
    text_panel(fig, gs[1, 1], _reference_rows(result, ref, err), title="Error against the reference",
               key_width=0.42, wrap=30)
    return fig


def _error_histogram(fig, where, drawn: np.ndarray, err: dict) -> None:
    """The |relative errors| (%) of the informed samples after the first seconds, with their median
    and 90th percentile; a sentence where there is none."""
    if not drawn.size:
        text_panel(fig, where, "No informed sample after the first 2 s: no error to show.")
        return
    ax = fig.add_subplot(where)
    ax.hist(drawn, bins=40, color="C3", alpha=0.8, histtype="stepfilled")
    ax.set_xlabel("|relative error| [%]")
    ax.set_ylabel("samples")
    if err and err["median"] is not None:
        ax.axvline(100 * err["median"], color="k", lw=1, label="median")
        ax.axvline(100 * err["p90"], color="k", lw=1, ls="--", label="90th percentile")
        ax.legend(loc="upper right")


def _reference_rows(result, ref: np.ndarray, err: dict) -> list:
    """The reference page's table: the samples used, the errors, the band's coverage, the reference."""
    rows = [("Samples used", f"{err['n']} (informed, after the first {REFERENCE_SKIP_S:g} s)")]
    if err["median"] is not None:
        rows += [("Median error", f"{100 * err['median']:.3g} %"),
                 ("90th percentile", f"{100 * err['p90']:.3g} %"),
                 ("Band coverage", f"{100 * err['coverage']:.1f} % of samples inside the "
                                   f"{100 * result.ci_level:.0f} % band")]
    rows.append(("Reference", "stiffness_true column" if result.trial.stiffness_true is not None
                 and np.array_equal(ref, result.trial.stiffness_true) else "calibration curve"))
    rows.append(("Reference range", f"{fmt(np.nanmin(ref))} to {fmt(np.nanmax(ref), result.trial.units['stiffness'])}"))
    return rows
