"""The diagnosis PDF: the gap map over time, frequency and regime, the ranked effects with
before/after, and the residual before and after the chosen effects.

Plotting only: :class:`matplotlib.figure.Figure` objects written by ``PdfPages``, without pyplot
and without choosing a backend (a notebook's stays as it is); the numbers come from a
:class:`~limbstiff.diagnosis.result.Diagnosis`. Written atomically.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from .. import __version__
from ..files.atomic import atomic_output

A4 = (8.27, 11.69)
#: Trials given their own pages (the rest are summarised in diagnosis.json).
MAX_TRIAL_PAGES = 8


def _pct(x, digits=1):
    return "—" if x is None else f"{100 * x:.{digits}f} %"


def _footer(fig, d):
    fig.text(0.06, 0.015, f"limbstiff {__version__} · diagnose · seed {d.seed}", fontsize=7, color="0.4")


def _lines(fig, y, items, *, size=9, indent=0.06, width=105, step=0.019, color="k"):
    for text in items:
        for j, line in enumerate(textwrap.wrap(text, width) or [""]):
            fig.text(indent + (0.02 if j else 0.0), y, line, fontsize=size, color=color)
            y -= step
    return y


#: Trials whose own selection the summary page lists (all of them are in diagnosis.json).
MAX_TRIAL_LINES = 10


def _per_trial(fig, y, d):
    """Each trial's own selection beside the pooled one, and the warning when they differ."""
    if not d.per_trial:
        return y
    y -= 0.01
    fig.text(0.06, y, "Each trial alone (its own selection, beside the pooled one)", fontsize=11, weight="bold")
    y -= 0.024
    items = [f"pooled ({len(d.per_trial)} trials): {', '.join(d.diagnosis) or 'none'}"]
    for s in d.per_trial[:MAX_TRIAL_LINES]:
        removed = f", {_pct(s.shrink_heldout, 0)} of it removed by them" if s.effects else ""
        items.append(f"{s.trial} alone: {', '.join(s.diagnosis) or 'none'} (held-out gap {_pct(s.gap_heldout, 2)}"
                     f"{removed}) — " + ("agrees" if s.agrees else "DIFFERS from the pooled"))
    if len(d.per_trial) > MAX_TRIAL_LINES:
        items.append(f"… and {len(d.per_trial) - MAX_TRIAL_LINES} more trials (diagnosis.json, per_trial)")
    y = _lines(fig, y, items, size=8.5, step=0.018)
    if d.disagreements:
        y = _lines(fig, y - 0.004, [f"Warning: {w}" for w in d.disagreements], size=8.5, step=0.018, color="C3")
    return y


def _iv(iv) -> str:
    return f"{iv.median:.4g} [{iv.lo:.4g}, {iv.hi:.4g}]"


def _stiffness(fig, y, d):
    """Per trial: the stiffness summary.csv reports, and with the chosen effects in the model."""
    if not d.stiffness:
        return y
    y -= 0.01
    fig.text(0.06, y, f"Stiffness per trial, N·m/rad (median, {100 * d.settings.ci_level:.0f} % interval)",
             fontsize=11, weight="bold")
    y -= 0.024
    items = []
    for s in d.stiffness[:MAX_TRIAL_LINES]:
        line = f"{s.trial}: default model (summary.csv) {_iv(s.reported)}, {s.verdict}"
        if s.with_effects is not None:
            line += (f"; with {' + '.join(s.effects)} in the model {_iv(s.with_effects)}, {s.verdict_with_effects} "
                     f"(limbstiff analyze --effect {' --effect '.join(s.effects)})")
        items.append(line)
        if s.note and s.note != "no effect chosen":
            items.append(f"   {s.note}")
    return _lines(fig, y, items, size=8.5, step=0.018)


def _param_text(name: str, value, unit: str) -> str:
    """One parameter with its unit; delays in ms, dimensionless ones bare."""
    if value is None:
        return f"{name} = none"
    if unit == "s":
        return f"{name} = {1e3 * value:.3g} ms"
    unit = unit.split(" (")[0]
    return f"{name} = {value:.4g}" + ("" if unit in ("1", "") else f" {unit}")


def _summary_page(fig, d):
    fig.text(0.06, 0.955, "Sim-to-real gap: diagnosis", fontsize=15, weight="bold")
    names = ", ".join(t.trial for t in d.trials)
    y = _lines(fig, 0.92, [f"Trials: {names}", f"Held out: {d.heldout.scheme} "
                           f"({d.heldout.units} scoring units of at most one motion period)"])
    y -= 0.01
    fig.text(0.06, y, "Nominal model: the analysis's Kalman model (m·ÿ + b·ẏ + walking stiffness)", fontsize=10,
             weight="bold")
    y -= 0.024
    items = [f"{t.trial}: m = {t.inertia:.4g} kg·m², b = {t.damping:.4g} N·m·s/rad ({t.mechanics}), "
             f"median stiffness {t.stiffness_median:.4g} N·m/rad, gap {_pct(t.gap_train, 2)} "
             f"(noise floor at least {_pct(t.noise_floor, 2)})" for t in d.trials[:12]]
    items.append(f"Gap (one-step prediction error over the torque's variance): {_pct(d.gap_train, 2)} in-sample, "
                 f"{_pct(d.gap_heldout, 2)} held out; white sensor noise alone: at least {_pct(d.noise_floor, 2)}")
    y = _lines(fig, y, items)
    y -= 0.01
    fig.text(0.06, y, "Diagnosis", fontsize=11, weight="bold")
    y -= 0.024
    if d.diagnosis:
        a = d.after
        bias = a.stiffness_bias.median_relative if a.stiffness_bias is not None else None
        lo, hi = a.shrink_heldout_interval
        items = [f"{i + 1}. {name}: " + ", ".join(_param_text(k, v, a.units[name].get(k, "1"))
                                                   for k, v in a.params[name].items()
                                                   if v is None or isinstance(v, (int, float)))
                 for i, name in enumerate(d.diagnosis)]
        items.append(f"With these effects the held-out gap falls from {_pct(d.gap_heldout, 2)} to "
                     f"{_pct(a.gap_heldout, 2)}: shrink {_pct(a.shrink_heldout)} "
                     f"[{_pct(lo)}, {_pct(hi)}]" + ("" if bias is None else
                                                     f"; the nominal stiffness is {100 * bias:+.1f} % off because of them"))
    else:
        items = ["None: no candidate effect removes a significant and relevant share of the held-out gap; "
                 "the nominal model explains these data as far as the library can tell."]
    y = _lines(fig, y, items)
    y = _stiffness(fig, y, d)
    y = _per_trial(fig, y, d)
    if d.ambiguities:
        y -= 0.01
        fig.text(0.06, y, "Cannot be told apart", fontsize=11, weight="bold")
        y -= 0.024
        y = _lines(fig, y, [f"{' vs '.join(a.effects)}: {a.reason}. Separate by {a.separate_by}."
                            for a in d.ambiguities[:6]], size=8, step=0.017)
    y -= 0.01
    fig.text(0.06, y, "Notes", fontsize=11, weight="bold")
    y -= 0.024
    _lines(fig, y, list(d.notes) + [f"warning: {w}" for w in d.warnings[:4]], size=8, step=0.017)
    _footer(fig, d)


def _effects_page(fig, d):
    cands = [c for c in d.candidates if c.evidence.tried]
    untried = [c for c in d.candidates if not c.evidence.tried]
    ax = fig.add_axes([0.30, 0.55, 0.62, 0.38])
    ypos = np.arange(len(cands))[::-1]
    for yy, c in zip(ypos, cands):
        chosen = c.effect in d.diagnosis
        ok = c.evidence.significant and c.evidence.relevant
        color = "C3" if chosen else ("C1" if ok else "0.6")
        lo, hi = c.shrink_interval
        ax.barh(yy, 100 * c.shrink_heldout, color=color, alpha=0.8)
        ax.plot([100 * lo, 100 * hi], [yy, yy], color="k", lw=1)
    ax.set_yticks(ypos, [c.effect for c in cands])
    ax.axvline(0, color="k", lw=0.6)
    ax.set_xlabel(f"held-out gap removed [%] (line: {100 * d.settings.ci_level:.0f} % bootstrap interval)",
                  fontsize=8)
    ax.set_title("Candidate effects (red: chosen, orange: significant and relevant, grey: not)", fontsize=9)
    rows = [["effect", "fitted parameters", "gap held out", "p (Holm)", "stiffness bias"]]
    for c in cands:
        bias = c.stiffness_bias.median_relative if c.stiffness_bias is not None else None
        params = ", ".join(_param_text(k, v, c.units.get(k, "1")) for k, v in c.params.items()
                           if k in c.units and (v is None or isinstance(v, (int, float))))
        rows.append([c.effect, params, _pct(c.gap_heldout, 2), f"{c.evidence.p_adjusted:.3g}",
                     "—" if bias is None else f"{100 * bias:+.1f} %"])
    tax = fig.add_axes([0.06, 0.16, 0.88, 0.32])
    tax.axis("off")
    table = tax.table(cellText=rows, loc="upper center", cellLoc="left", colWidths=[0.17, 0.5, 0.11, 0.09, 0.13])
    table.auto_set_font_size(False)
    table.set_fontsize(6.5)
    table.scale(1, 1.25)
    fig.text(0.06, 0.965, f"Ranked effects; nominal held-out gap {_pct(d.gap_heldout, 2)}", fontsize=12,
             weight="bold")
    _lines(fig, 0.13, [f"Not tried: {c.effect} ({c.evidence.reason})" for c in untried], size=7, step=0.014)
    _footer(fig, d)


def _regime_axes(ax, w, w_after, key, title):
    """The gap per bin of the regime ``key`` (a field of :class:`~limbstiff.diagnosis.residual.Regimes`),
    nominal and after, with the bins' intervals (χ², n_eff)."""
    bins = getattr(w.regime, key)
    x = np.arange(len(bins))
    for off, src, color, label in ((-0.2, bins, "C0", "nominal"),
                                   (0.2, None if w_after is None else getattr(w_after.regime, key), "C3", "after")):
        if src is None:
            continue
        vals = np.array([100 * (b.gap or 0.0) for b in src])
        ax.bar(x + off, vals, width=0.4, color=color, alpha=0.8, label=label)
        ratio = np.array([b.ratio or 0.0 for b in src])
        lo_hi = np.array([b.interval or [r, r] for b, r in zip(src, ratio)])
        scale = np.divide(vals, ratio, out=np.zeros_like(vals), where=ratio > 0)
        ax.errorbar(x + off, vals, yerr=np.abs(np.vstack([ratio - lo_hi[:, 0], lo_hi[:, 1] - ratio]) * scale),
                    fmt="none", ecolor="k", elinewidth=0.6, capsize=1.5)
    empty = [b.bin[:18] for b in bins if not b.n]
    if empty:
        ax.text(0.5, 0.9, "no steps in: " + ", ".join(empty), transform=ax.transAxes, ha="center", fontsize=6)
    ax.set_xticks(x, [b.bin[:18] for b in bins], rotation=30, ha="right", fontsize=6)
    ax.set_title(title + " (bars: 95 % intervals)", fontsize=8)
    ax.set_ylabel("gap [% of torque variance]", fontsize=7)


def _map_page(fig, d, name, s):
    w, wa = s.where, s.where_after
    axes = fig.subplots(4, 2, gridspec_kw={"hspace": 0.9, "wspace": 0.3, "top": 0.92, "bottom": 0.08})
    ax = axes[0, 0]
    tw = w.time
    edges = list(tw.start_s) + [tw.end_s]
    ax.stairs(100 * np.asarray(tw.gap), edges, color="C0", label="nominal")
    if wa is not None:
        ax.stairs(100 * np.asarray(wa.time.gap), edges, color="C3", label="after")
    for j, cp in enumerate(tw.change_points_s):
        ax.axvline(cp, color="k", ls="--", lw=1.4, label="change point" if j == 0 else None)
    if not len(tw.change_points_s):
        ax.text(0.5, 0.9, "no change point: the gap is steady in time", transform=ax.transAxes, ha="center",
                fontsize=6)
    ax.set_title(f"gap per window of {tw.window_s:.2g} s (dashed: change points)", fontsize=8)
    ax.set_xlabel("time [s]", fontsize=7)
    ax.set_ylabel("gap [% of torque variance]", fontsize=7)
    ax.legend(fontsize=6)
    ax = axes[0, 1]
    fr = w.frequency
    ax.semilogy(fr.freq_hz, fr.torque_psd, color="0.5", lw=0.8, label="torque")
    ax.semilogy(fr.freq_hz, fr.residual_psd, color="C0", lw=0.8, label="residual")
    if wa is not None:
        ax.semilogy(wa.frequency.freq_hz, wa.frequency.residual_psd, color="C3", lw=0.8, label="after")
    ax.set_title("spectra of torque and one-step prediction error", fontsize=8)
    ax.set_ylabel("PSD [(N·m)²/Hz]", fontsize=7)
    ax.set_xlabel("frequency [Hz]", fontsize=7)
    ax.legend(fontsize=6)
    ax = axes[1, 0]
    ax.plot(fr.freq_hz, fr.coherence, color="C0", lw=0.8)
    if wa is not None:
        ax.plot(wa.frequency.freq_hz, wa.frequency.coherence, color="C3", lw=0.8)
    ax.axhline(fr.bound, color="k", ls="--", lw=0.8)
    ax.set_title(f"coherence of the residual with the angle (dashed: {100 * fr.level:.0f} % bound)", fontsize=8)
    ax.set_xlabel("frequency [Hz]", fontsize=7)
    ax.set_ylabel("coherence [1]", fontsize=7)
    ax.set_ylim(0, 1)
    for ax, (key, title) in zip([axes[1, 1], axes[2, 0], axes[2, 1], axes[3, 0], axes[3, 1]],
                                (("speed", "by speed [rad/s]"), ("reversal", "near reversals"), ("angle", "by angle [rad]"),
                                 ("torque", "by torque [N·m]"), ("stiffness", "by estimated stiffness [N·m/rad]"))):
        _regime_axes(ax, w, wa, key, title)
    fig.text(0.06, 0.965, f"Where the gap lies — {name}", fontsize=12, weight="bold")
    _footer(fig, d)


def _residual_page(fig, d, name, s):
    axes = fig.subplots(4, 1, gridspec_kw={"hspace": 0.6, "top": 0.92, "bottom": 0.07})
    t, r = s.time, s.residual
    ax = axes[0]
    ax.plot(t, s.torque - np.mean(s.torque), color="0.7", lw=0.4, label="torque (centred)")
    ax.plot(t, r, color="C0", lw=0.4, label="prediction error, nominal")
    ax.set_xlabel("time [s]", fontsize=7)
    ax.set_ylabel("torque [N·m]", fontsize=7)
    ax.legend(fontsize=6, loc="upper right")
    ax.set_title("measured torque and the nominal model's one-step prediction error", fontsize=8)
    ax = axes[1]
    ax.plot(t, r, color="C0", lw=0.4, label="nominal")
    if s.residual_after is not None:
        ax.plot(t, s.residual_after, color="C3", lw=0.4, label="after: " + ", ".join(d.diagnosis))
    else:
        ax.text(0.5, 0.9, "no effect chosen: nothing to compare", transform=ax.transAxes, ha="center", fontsize=6)
    ax.set_xlabel("time [s]", fontsize=7)
    ax.set_ylabel("prediction error [N·m]", fontsize=7)
    ax.legend(fontsize=6, loc="upper right")
    ax.set_title("one-step prediction error before and after the chosen effects", fontsize=8)
    ax = axes[2]
    wh = s.where.whiteness
    lags = np.asarray(wh.lags) * wh.sample_period_s
    ax.plot(lags, wh.acf, "o-", ms=2, color="C0", label="nominal")
    if s.where_after is not None:
        ax.plot(lags, s.where_after.whiteness.acf, "o-", ms=2, color="C3", label="after")
    if wh.reference is not None:
        ax.plot(lags, wh.reference, color="0.5", lw=0.8, label="filtered white noise")
    ref = np.zeros(len(lags)) if wh.reference is None else np.asarray(wh.reference)
    ax.fill_between(lags, ref - wh.bound, ref + wh.bound, color="0.85", lw=0)
    ax.set_title(f"autocorrelation of the prediction error (band: {100 * wh.level:.0f} % bound; Ljung–Box "
                 f"p = {wh.p_value:.2g})", fontsize=8)
    ax.set_xlabel("lag [s]", fontsize=7)
    ax.set_ylabel("autocorrelation [1]", fontsize=7)
    ax.legend(fontsize=6)
    ax = axes[3]
    xc = s.where.cross_correlation.velocity
    ax.plot(xc.lags_s, xc.ccf, color="C0", lw=0.8, label="nominal")
    if s.where_after is not None:
        xa = s.where_after.cross_correlation.velocity
        ax.plot(xa.lags_s, xa.ccf, color="C3", lw=0.8, label="after")
    ax.axhspan(-xc.bound, xc.bound, color="0.85", lw=0)
    ax.set_title(f"cross-correlation of the residual with the velocity (peak at {1e3 * xc.peak_lag_s:.0f} ms; "
                 f"band: Bartlett {100 * xc.level:.0f} % bound)", fontsize=8)
    ax.set_xlabel("lag [s] (positive: the error follows the velocity)", fontsize=7)
    ax.set_ylabel("correlation [1]", fontsize=7)
    ax.legend(fontsize=6)
    fig.text(0.06, 0.965, f"Residual — {name}", fontsize=12, weight="bold")
    _footer(fig, d)


def write_diagnosis_report(diagnosis, path) -> None:
    """Write the PDF of a :class:`~limbstiff.diagnosis.result.Diagnosis`, atomically.

    Pages: summary; ranked effects with held-out shrinkage and intervals; per trial (up to
    :data:`MAX_TRIAL_PAGES`) the gap map over time, frequency and regime, and the residual
    before and after the chosen effects with its autocorrelation and cross-correlation.
    """
    from matplotlib.backends.backend_pdf import PdfPages
    from matplotlib.figure import Figure

    path = Path(path)
    meta = {"Title": "limbstiff diagnosis", "Creator": f"limbstiff {__version__}",
            "Subject": ", ".join(t.trial for t in diagnosis.trials)}
    with atomic_output(path) as tmp:
        with PdfPages(tmp, metadata=meta) as pdf:
            for page in (_summary_page, _effects_page):
                fig = Figure(figsize=A4)
                page(fig, diagnosis)
                pdf.savefig(fig)
            for name, s in list(diagnosis.series.items())[:MAX_TRIAL_PAGES]:
                for page in (_map_page, _residual_page):
                    fig = Figure(figsize=A4)
                    page(fig, diagnosis, name, s)
                    pdf.savefig(fig)
