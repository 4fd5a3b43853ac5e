"""Pages of the per-trial report about the stiffness itself: the summary for a clinician,
the signals and the stiffness over time, stiffness against angle and torque, and the error
against a reference stiffness.

Each ``*_page(result)`` returns one :class:`matplotlib.figure.Figure` (A4 portrait, no footer:
:mod:`limbstiff.report.trial` adds it).
"""

from __future__ import annotations

import textwrap

import numpy as np

from ..estimate.observer import informed_samples
from .common import (FONT, envelope, envelope_band, fmt, fmt_interval, new_page, robust_limits, shade_false,
                     text_panel)

#: Most points drawn in a scatter plot (evenly thinned beyond).
MAX_POINTS = 20_000
#: Seconds at the start of a trial left out of the reference error (as in reference_error()).
REFERENCE_SKIP_S = 2.0


def names(trial) -> dict[str, str]:
    """Words for the trial's quantities: angle/torque (rotational) or position/force."""
    if trial.kind == "translational":
        return {"angle": "position", "torque": "force", "elastic_torque": "elastic force"}
    return {"angle": "angle", "torque": "torque", "elastic_torque": "elastic torque"}


def recorded_torque(result) -> tuple[str, np.ndarray]:
    """The torque channel the variant used: (``torque`` or ``elastic_torque``, samples)."""
    trial = result.trial
    if result.variant == "direct" or trial.torque is None:
        return "elastic_torque", trial.elastic_torque
    return "torque", trial.torque


def summary_page(result):
    """Page 1: the trial at a glance, for a clinician (text only)."""
    fig = new_page(constrained=False)
    fig.text(0.06, 0.955, "Stiffness report", fontsize=FONT["title"], weight="bold")
    fig.text(0.06, 0.93, result.trial.name, fontsize=FONT["heading"], color="0.3")
    y = _verdict_box(fig, result, 0.905)
    y = _key_values(fig, _summary_rows(result), y - 0.012)
    y = _warning_list(fig, result.warnings, y - 0.015)
    _metadata_list(fig, list(result.trial.metadata.items()), y)
    return fig


#: How each verdict reads on page 1, and its colour.
VERDICT_TEXT = {
    "ok": ("OK", "the model fits this recording: the stiffness can be used", "#1a7f37"),
    "caution": ("CAUTION", "the model misses part of this recording: the stiffness may be biased", "#b35c00"),
    "unreliable": ("UNRELIABLE", "the model does not fit this recording: do not use the stiffness", "#c62828"),
}


def _verdict_box(fig, result, y: float) -> float:
    """The verdict in plain words, coloured, with the reasons below it, from height ``y`` (page
    fraction) down; the height reached."""
    if result.checks is None:
        return y
    word, meaning, colour = VERDICT_TEXT[result.checks.verdict]
    fig.text(0.06, y, f"Verdict: {word}", fontsize=FONT["heading"] + 1, weight="bold", color=colour, va="top")
    fig.text(0.33, y - 0.002, meaning, fontsize=10, color=colour, va="top")
    y -= 0.03
    for reason in result.checks.reasons:
        wrapped = textwrap.wrap(reason, 95)
        fig.text(0.08, y, "• " + "\n  ".join(wrapped), fontsize=FONT["body"], va="top", linespacing=1.3)
        y -= 0.0175 * len(wrapped) + 0.006
    return y


def _summary_rows(result) -> list[tuple[str, str]]:
    """(label, text) of each line at the top of the summary page."""
    trial, u = result.trial, result.trial.units
    median, low, high = result.informed_stiffness()
    rows = [
        ("Trial", trial.name),
        ("Source", trial.source or "(in memory)"),
        ("Variant / estimator", f"{result.variant} variant / {result.estimator} estimator"),
        ("Sampling", f"{trial.fs:.4g} Hz, {trial.n_samples} samples, {trial.duration:.4g} s"),
        *_trial_level_rows(result, median),
        ("Stiffness range", f"{fmt(low)} to {fmt(high, u['stiffness'])} "
                            + ("(informed samples)" if result.observable.any() else "(all samples: none is informed)")),
    ]
    rows += [(name.capitalize(), _mechanics_text(result, name)) for name in ("inertia", "damping")]
    rows.append(("Informed by motion", f"{100 * result.observable_fraction:.1f} % of the trial"))
    err = result.reference_error()
    if err and err.get("median") is not None:
        rows.append(("Error vs reference", f"median {100 * err['median']:.2f} %, 90th percentile "
                                           f"{100 * err['p90']:.2f} %, band covers it {100 * err['coverage']:.0f} %"))
    return rows


def _trial_level_rows(result, median) -> list[tuple[str, str]]:
    """Page 1's trial-level figures, each with words saying what its interval is."""
    u, ci, level = result.trial.units, result.ci_level, result.trial_level
    if level is None or not np.isfinite(median.lo):
        return [("Median stiffness", fmt_interval(median, u["stiffness"], ci)
                 + " — bounds are the medians of the per-sample band (no joint uncertainty for this estimator)")]
    what = " and ".join({"course": "the stiffness course", "mechanics": "inertia and damping"}[s]
                        for s in level.sources)
    slope_unit = f"({u['stiffness']})/({u['torque']})" if "torque" in u else ""
    return [
        ("Median stiffness", fmt_interval(median, u["stiffness"], ci)
         + f": the median over the informed samples; the interval is that of this median, from the joint "
           f"uncertainty of {what}, not the spread of the stiffness over the trial (see the range below)"),
        ("Stiffness at mean torque", fmt_interval(level.stiffness_at_mean_torque, u["stiffness"], ci)
         + ": the line of stiffness against background torque, at the trial's mean background torque"),
        ("Stiffness vs torque", fmt_interval(level.stiffness_torque_slope, slope_unit, ci)
         + ": that line's slope, the change of stiffness per unit of background torque"),
    ]


def _mechanics_text(result, name: str) -> str:
    """The summary's line for ``inertia`` or ``damping``: interval, given value or not needed."""
    value, unit = getattr(result, name), result.trial.units[name]
    ident = result.identification
    if value is None:
        text = "not needed (direct variant: the elastic torque is measured)"
    else:
        text = fmt_interval(value, unit, result.ci_level)
        if (ident is not None and ident.given) or value.is_fixed:
            text = f"{fmt(value.median, unit)} (given, not identified)"
    expected = None if ident is None else ident.expected_inertia
    if name == "inertia" and expected:
        lo, hi = expected
        text += f"; {'within' if ident.inertia_in_expected_range else 'OUTSIDE'} the expected {lo:g}–{hi:g}"
    return text


def _key_values(fig, rows: list[tuple[str, str]], y: float) -> float:
    """Draw bold labels with their wrapped texts from height ``y`` down; the height reached.

    Heights are fractions of the page (0 at the bottom, 1 at the top).
    """
    for label, value in rows:
        wrapped = textwrap.wrap(str(value), 62) or [""]
        fig.text(0.06, y, label, fontsize=10, weight="bold", va="top")
        fig.text(0.33, y, "\n".join(wrapped), fontsize=10, va="top", linespacing=1.3)
        y -= 0.0205 * len(wrapped) + 0.008
    return y


def _warning_list(fig, warnings, y: float) -> float:
    """Draw the "Warnings" heading and one bullet per warning (``none`` without any) from height
    ``y`` (page fraction) down; the height reached."""
    fig.text(0.06, y, "Warnings", fontsize=FONT["heading"], weight="bold", va="top")
    y -= 0.03
    for w in warnings or ["none"]:
        wrapped = textwrap.wrap(w, 95)
        fig.text(0.08, y, "• " + "\n  ".join(wrapped), fontsize=FONT["body"], va="top", linespacing=1.3)
        y -= 0.0175 * len(wrapped) + 0.006
    return y


def _metadata_list(fig, meta: list[tuple[str, str]], y: float) -> None:
    """Draw the file's ``key: value`` metadata from height ``y`` (page fraction) down, as many
    lines as fit above the footer, then how many more there are."""
    if not meta:
        return
    y -= 0.02
    fig.text(0.06, y, "Metadata (from the file)", fontsize=FONT["heading"], weight="bold", va="top")
    y -= 0.03
    room = max(0, int((y - 0.08) / 0.017))
    shown = meta[:room] if len(meta) <= room else meta[:max(room - 1, 0)]
    for key, value in shown:
        fig.text(0.08, y, textwrap.shorten(f"{key}: {value}", 110), fontsize=FONT["small"], va="top")
        y -= 0.017
    if len(shown) < len(meta):
        fig.text(0.08, y, f"… {len(meta) - len(shown)} more in summary.json", fontsize=FONT["small"],
                 style="italic", va="top")


def _stiffness_axes(ax, result, *, reference: bool = True) -> None:
    t, u = result.trial.time, result.trial.units
    shade_false(ax, t, result.observable)
    ax.fill_between(*envelope_band(t, result.stiffness_lo, result.stiffness_hi), color="C0", alpha=0.3, lw=0,
                    label=f"{100 * result.ci_level:.0f} % band")
    ax.plot(*envelope(t, result.stiffness), lw=0.8, color="C0", label="estimate")
    if reference and result.reference is not None:
        ax.plot(*envelope(t, result.reference), lw=0.9, color="k", ls="--", label="reference")
    obs = informed_samples(result.observable)
    values = [result.stiffness[obs], result.stiffness_lo[obs], result.stiffness_hi[obs]]
    if reference and result.reference is not None:
        values.append(result.reference[obs])
    limits = robust_limits(np.concatenate(values), pad=0.2)
    if limits is not None:
        ax.set_ylim(*limits)
    ax.set_ylabel(f"stiffness [{u['stiffness']}]")
    ax.legend(loc="upper left", ncols=3)


def time_page(result):
    """Page 2: angle, torque and stiffness (with its band) over time; uninformed stretches grey."""
    trial = result.trial
    u, word = trial.units, names(trial)
    fig = new_page("Signals and stiffness over time")
    axes = fig.subplots(3, 1, sharex=True)
    axes[0].plot(*envelope(trial.time, trial.angle), lw=0.6, color="C2")
    axes[0].set_ylabel(f"{word['angle']} [{u['angle']}]")
    key, torque = recorded_torque(result)
    axes[1].plot(*envelope(trial.time, torque), lw=0.6, color="C1")
    axes[1].set_ylabel(f"{word[key]} [{u[key]}]")
    _stiffness_axes(axes[2], result)
    axes[2].set_xlabel("time [s]")
    axes[2].set_xlim(trial.time[0], trial.time[-1])
    axes[2].set_title("grey: not informed by motion (no estimate there, only the model's drift)",
                      fontsize=FONT["small"], loc="right")
    return fig


def relation_page(result):
    """Page 3: stiffness against angle and against torque, informed samples coloured by time."""
    trial = result.trial
    u, word = trial.units, names(trial)
    obs = np.flatnonzero(result.observable)
    if obs.size == 0:
        fig = new_page("Stiffness against angle and torque", constrained=False)
        text_panel(fig.add_axes((0.06, 0.5, 0.88, 0.38)), "No sample of this trial is informed by motion, so the "
                   "stiffness cannot be related to the angle or the torque.", wrap=90)
        return fig
    fig = new_page("Stiffness against angle and torque")
    axes = fig.subplots(2, 1)
    obs = obs[::max(1, int(np.ceil(obs.size / MAX_POINTS)))]
    key, torque = recorded_torque(result)
    limits = robust_limits(result.stiffness[obs], pad=0.15, pct=(0.5, 99.5))
    for ax, x, label in ((axes[0], trial.angle, f"{word['angle']} [{u['angle']}]"),
                         (axes[1], torque, f"{word[key]} [{u[key]}]")):
        points = ax.scatter(x[obs], result.stiffness[obs], c=trial.time[obs], s=3, lw=0, cmap="viridis",
                            rasterized=True)
        ax.set_xlabel(label)
        ax.set_ylabel(f"stiffness [{u['stiffness']}]")
        if limits is not None:
            ax.set_ylim(*limits)
        fig.colorbar(points, ax=ax, label="time [s]", shrink=0.9)
    half = np.median(0.5 * (result.stiffness_hi - result.stiffness_lo)[obs])
    axes[0].set_title(f"{obs.size} informed samples, colour: time in the trial; typical "
                      f"{100 * result.ci_level:.0f} % band ±{half:.3g} {u['stiffness']}", fontsize=FONT["small"],
                      loc="right")
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
    t, u = result.trial.time, result.trial.units
    ref = np.asarray(result.reference, float)
    fig = new_page("Error against the reference stiffness")
    gs = fig.add_gridspec(3, 2, height_ratios=[1.0, 1.0, 0.8])
    ax0 = fig.add_subplot(gs[0, :])
    ax1 = fig.add_subplot(gs[1, :], sharex=ax0)
    _stiffness_axes(ax0, result)
    safe = np.where(ref != 0, np.abs(ref), np.nan)
    rel = 100 * (result.stiffness - ref) / safe
    width = 100 * 0.5 * (result.stiffness_hi - result.stiffness_lo) / safe
    shade_false(ax1, t, result.observable)
    ax1.fill_between(*envelope_band(t, -width, width), color="C0", alpha=0.25, lw=0,
                     label=f"half-width of the {100 * result.ci_level:.0f} % band")
    ax1.plot(*envelope(t, rel), lw=0.7, color="C3", label="(estimate − reference) / reference")
    ax1.axhline(0, color="k", lw=0.6)
    ax1.axvspan(t[0], t[0] + REFERENCE_SKIP_S, color="C1", alpha=0.12, lw=0, label="left out (first 2 s)")
    use = result.observable & (t - t[0] >= REFERENCE_SKIP_S)
    limits = robust_limits(np.concatenate([rel[use], width[use], -width[use]]) if use.any() else rel, pad=0.3)
    if limits is not None:
        ax1.set_ylim(*limits)
    ax1.set_ylabel("relative error [%]")
    ax1.set_xlabel("time [s]")
    ax1.set_xlim(t[0], t[-1])
    ax1.legend(loc="upper right", ncols=2)
    err = result.reference_error(skip=REFERENCE_SKIP_S)
    ax2 = fig.add_subplot(gs[2, 0])
    ax3 = fig.add_subplot(gs[2, 1])
    good = use & np.isfinite(rel)
    if good.any():
        ax2.hist(np.abs(rel[good]), bins=40, color="C3", alpha=0.8)
        ax2.set_xlabel("|relative error| [%]")
        ax2.set_ylabel("samples")
        if err and err["median"] is not None:
            ax2.axvline(100 * err["median"], color="k", lw=1, label="median")
            ax2.axvline(100 * err["p90"], color="k", lw=1, ls="--", label="90th percentile")
            ax2.legend(loc="upper right")
    else:
        text_panel(ax2, "No informed sample after the first 2 s: no error to show.")
    rows = [("Samples used", f"{err['n']} (informed, after the first {REFERENCE_SKIP_S:g} s)")]
    if err["median"] is not None:
        rows += [("Median error", f"{100 * err['median']:.3g} %"),
                 ("90th percentile", f"{100 * err['p90']:.3g} %"),
                 ("Band coverage", f"{100 * err['coverage']:.1f} % of samples inside the "
                                   f"{100 * result.ci_level:.0f} % band")]
    rows.append(("Reference", "stiffness_true column" if result.trial.stiffness_true is not None
                 and np.array_equal(ref, result.trial.stiffness_true) else "calibration curve"))
    rows.append(("Reference range", f"{fmt(np.nanmin(ref))} to {fmt(np.nanmax(ref), u['stiffness'])}"))
    text_panel(ax3, rows, title="Error against the reference", key_width=0.42, wrap=30)
    return fig
